"""PKP-2400-SI keypad, 8 keys (pkp-2400-si-canopen.md: pages 17, 18, 32 seen).

Seen on its own pages: 2003h/04-06, 2010h codes (default 04h, 125k), 2011h, 1800h/05 periodic
transmission, 1A00h/01 = 2000h/01 with 8 key bits. Everything else is the PKP-2600-SI
generation-2 firmware restricted to 8 keys, each such value tagged I-n in ``EVIDENCE``.
"""

from __future__ import annotations

from blinkcan.devices.byte_padded import BytePaddedKeypad

PKP_2400 = BytePaddedKeypad(
    name="pkp-2400-si",
    title="PKP-2400-SI keypad",
    model_id="PKP2400SI",  # I-1
    grid=((1, 2, 3, 4), (5, 6, 7, 8)),  # I-2
    mask_bits=16,  # I-3
    key_bits=8,  # 1A00h/01 = 20000108h (p. 32)
    evidence=(
        "seen p. 17: 2003h/04-06 default colour, startup levels 00h-3Fh (written 2Fh)",
        "seen p. 18: 2010h codes 00h-07h, default 04h (125k); 2011h boot-up service",
        "seen p. 32: 1800h/05 periodic transmission (2Bh, ms, 0 off); 1A00h/01 reads 20000108h",
        "I-1: 100Bh \"PKP2400SI\" (third-party code, not the manual)",
        "I-2: two rows of four keys, 1-4 on top (the PKP-2600-SI's numbering)",
        "I-3: 215h/315h one 16-bit little-endian word per colour (PKP-2500-SI p. 11/12/32)",
        "I-4: 1000h, 1008h-100Ah, 1018h, 2200h, NMT, heartbeat, SYNC, 1016h, 1011h: the "
        "PKP-2600-SI rev 1.5 values (pkp-rev1.1-vs-rev1.5.md)",
        "I-5: key PDO 195h: keys in byte 0, tick in byte 4, DLC 5 (errata P8, decision E2)",
        "I-6: 415h indicator level, 515h backlight level with no colour byte (PKP-2500-SI p. 9)",
    ),
)

PKP_2400_SI = PKP_2400.model
