"""PKP-2300-SI keypad, 6 keys (pkp-2300-si-canopen.md: the PKP-2300-SI-FR manual rev 1.3,
pp. 16, 18, 19 seen). Its PDO pages are missing, so the LED layout and the generation-2 objects
are the family's (I-n). The older "PKP2300: CAN Open message" firmware (one byte per colour,
2Fh/4Fh, no 415h/515h) is not modelled."""

from __future__ import annotations

from blinkcan.devices.byte_padded import BytePaddedKeypad

PKP_2300 = BytePaddedKeypad(
    name="pkp-2300-si",
    title="PKP-2300-SI keypad",
    model_id="PKP2300SI",  # I-1
    grid=((1, 2, 3), (4, 5, 6)),  # I-2
    mask_bits=16,  # I-3
    key_bits=8,  # I-4
    evidence=(
        "seen FR13 p. 16: 2011h boot-up service, 2012h active on start-up, 2013h node id",
        "seen FR13 p. 18: 1017h producer heartbeat in ms LSB first (E1), 0 off; heartbeat "
        "frame 715h 00h/04h/05h/7Fh",
        "seen FR13 p. 19: 1000h 000B0191h; 1001h not implemented",
        "I-1: 100Bh \"PKP2300SI\" (the family's pattern)",
        "I-2: two rows of three keys, 1-3 on top (figure not seen)",
        "I-3: 215h/315h one 16-bit little-endian word per colour (PKP-2500-SI p. 9/11/12); "
        "the older PKP2300 firmware used one byte per colour",
        "I-4: key PDO 195h keys in byte 0 (the older firmware's layout, p. 6), tick in byte "
        "4, DLC 5; 1A00h/01 with 8 bits (PKP-2400-SI p. 32)",
        "I-5: SYNC, 1016h, 1011h, node id at once: the generation-2 objects (PKP-2500-SI); "
        "FR13's section numbers follow the PKP-2600-SI rev 1.1, so a page may yet say "
        "generation 1",
        "I-6: 415h indicator level, 515h backlight level with no colour byte (PKP-2500-SI p. 9)",
        "I-7: 1008h-100Ah, 1018h, 2010h codes, defaults: the PKP-2600-SI's",
    ),
)

PKP_2300_SI = PKP_2300.model
