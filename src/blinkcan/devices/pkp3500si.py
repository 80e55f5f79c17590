"""PKP-3500-SI keypad, 15 keys, the plain one (not the PKP-3500-MT): pkp-3500-si-canopen.md,
manual rev 1.0, pp. 7-10, 15, 19, 26, 28 seen. Other values: the family's, tagged I-n (I-1 ..
I-27 as numbered in pkp-2500-si-canopen.md)."""

from __future__ import annotations

from blinkcan.devices.byte_padded import BytePaddedKeypad

PKP_3500_SI_KEYPAD = BytePaddedKeypad(
    name="pkp-3500-si",
    title="PKP-3500-SI keypad",
    model_id="PKP3500SI",  # p. 26
    grid=((1, 2, 3, 4, 5), (6, 7, 8, 9, 10), (11, 12, 13, 14, 15)),  # I-32
    mask_bits=16,  # p. 8/9
    key_bits=16,  # p. 7: keys 9-15 in byte 1; 1A00h/01 16 bits by I-19
    evidence=(
        "seen p. 7: key PDO 195h, keys 1-8 byte 0, 9-15 byte 1, tick in byte 4 (100 ms)",
        "seen pp. 8-9: 215h/315h one 16-bit word per colour; 415h indicator level, 515h "
        "backlight level with no colour byte",
        "seen p. 10: 2000h/01 key states, all pressed FF 7Fh",
        "seen p. 15: 2003h/05-06 start-up levels, read 4Fh",
        "seen p. 19: 2013h node id 01h-7Fh, in use at once (B4)",
        "seen p. 26: 100Bh \"PKP3500SI\"; 1011h \"load\" acknowledged 43h (B5)",
        "seen p. 28: 1400h, transmission type 00h-F0h synchronous, FEh event-driven; SYNC",
        "I-1: 2010h codes and 125k default (PKP-2600-SI)",
        "I-2, I-3, I-5: 1000h 000B0191h, 1008h, 1018h (PKP-2600-SI)",
        "I-7: start-up defaults as the PKP-2600-SI",
        "I-10, I-17 .. I-20: 1401h-1603h, 1800h, 1A00h as the PKP-2500-SI",
        "I-29: NMT, boot-up, 1016h, 1017h as the PKP-2500-SI pages 5, 6, 22",
        "I-31: 2001h/2002h 16-bit words written 2Bh, read 4Bh (PKP-2500-SI p. 11/12)",
        "I-32: three rows of five keys, 1-5 on top (p. 3 figure not seen)",
    ),
)

PKP_3500_SI = PKP_3500_SI_KEYPAD.model
