"""PKP-2500-SI keypad, 10 keys (pkp-2500-si-canopen.md: manual rev 1.0, pp. 5, 6, 9, 11, 12,
14, 22, 30, 32, 35 seen). Everything else: the family's generation-2 values, tagged I-n."""

from __future__ import annotations

from blinkcan.devices.byte_padded import BytePaddedKeypad

PKP_2500 = BytePaddedKeypad(
    name="pkp-2500-si",
    title="PKP-2500-SI keypad",
    model_id="PKP2500SI",  # I-4
    grid=((1, 2, 3, 4, 5), (6, 7, 8, 9, 10)),  # I-28
    mask_bits=16,  # p. 9/11/12/32; 215h by I-9
    key_bits=16,  # 1A00h/01 reads 20000110h (p. 35)
    evidence=(
        "seen pp. 5-6: NMT 01h/80h/81h/02h (00h stops), boot-up 715h, SYNC 80h",
        "seen p. 9: 315h one 16-bit word per colour; 415h indicator level, 515h backlight "
        "level with no colour byte",
        "seen pp. 11-12: 2001h/2002h sub 01-03, 16-bit words, LEDs 1-10",
        "seen p. 14: 2003h/03-04 backlight colour, read 4Fh",
        "seen p. 22: 1016h consumer heartbeat; p. 30: 1402h/1403h; p. 32: 1601h 16-bit entries",
        "seen p. 35: 1800h/05 periodic transmission; 1A00h/01 reads 20000110h",
        "I-1: 2010h codes and 125k default (PKP-2600-SI)",
        "I-2, I-3, I-5: 1000h 000B0191h, 1008h, 1018h (PKP-2600-SI)",
        "I-4: 100Bh \"PKP2500SI\" (public code, PKP3500SI pattern)",
        "I-7, I-22: start-up defaults as the PKP-2600-SI",
        "I-8: key PDO 195h keys 1-10 in bytes 0-1, tick in byte 4, DLC 5",
        "I-9: 215h in the layout of 315h",
        "I-10: 1400h/1401h/1800h transmission types as errata G3",
        "I-15: 1011h \"load\" acknowledged 43h (errata G5)",
        "I-28: two rows of five keys, 1-5 on top (p. 3 figure not seen)",
    ),
)

PKP_2500_SI = PKP_2500.model
