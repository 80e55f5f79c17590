"""PKP-2200-SI keypad, 4 keys (pkp-2200-si-canopen.md: manual rev 1.0, pp. 7, 8, 25, 26, 31
seen): the one byte-padded keypad with one byte per colour. Other values: the family's, I-n."""

from __future__ import annotations

from blinkcan.devices.byte_padded import BytePaddedKeypad

PKP_2200 = BytePaddedKeypad(
    name="pkp-2200-si",
    title="PKP-2200-SI keypad",
    model_id="PKP2200SI",  # I-1
    grid=((1, 2), (3, 4)),  # I-2
    mask_bits=8,  # p. 8: one byte per colour, bits 0-3
    key_bits=8,  # p. 8: key byte 0; 1A00h/01 as 8 bits by I-3
    evidence=(
        "seen p. 7: NMT stop 02h (00h stops), boot-up 715h, heartbeat by 1017h, SYNC 80h",
        "seen p. 8: key PDO 195h, K4..K1 in byte 0, tick in byte 4; 215h one byte per colour",
        "seen pp. 25-26: 1400h/1401h, transmission type 00h-F0h synchronous, FEh event-driven; "
        "315h in the layout of 215h",
        "seen p. 31: 1800h sub 00-02, type 01h-F0h every n-th SYNC or FEh; 1800h/05 read 4Bh",
        "I-1: 100Bh \"PKP2200SI\" (the family's pattern)",
        "I-2: two rows of two keys, 1-2 on top (figure not seen)",
        "I-3: 1A00h/01 maps 2000h/01 with 8 bits (as the PKP-2400-SI p. 32)",
        "I-4: 1000h, 1008h-100Ah, 1018h, 2010h codes, defaults, 1016h, 1011h: the PKP-2600-SI "
        "rev 1.5 values (pkp-rev1.1-vs-rev1.5.md)",
        "I-5: 2001h/2002h sub 01-03 one byte per colour (the 215h bytes)",
        "I-6: 415h indicator level, 515h backlight level with no colour byte (PKP-2500-SI p. 9)",
        "not modelled: the J1939 mode of its J1939 manual rev 1.0 (appendix of the fact file)",
    ),
)

PKP_2200_SI = PKP_2200.model
