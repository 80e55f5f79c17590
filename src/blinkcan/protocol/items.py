"""Masks of numbered things (keys, LEDs, pins, inputs): bit 0 is item 1 in every Blink manual
(PKP §10/§11, KBX §17/§18). One place turns masks into item numbers and back."""

from __future__ import annotations

from collections.abc import Iterable

from blinkcan.protocol.cob import check_range


def item_numbers(mask: int, first: int = 1) -> list[int]:
    """[1, 4, 12] for the set bits of ``mask`` (bit 0 = item ``first``), lowest first."""
    found = []
    while mask:
        lowest = mask & -mask
        found.append(lowest.bit_length() - 1 + first)
        mask ^= lowest
    return found


def item_mask(numbers: Iterable[int], what: str, count: int) -> int:
    """The mask of items ``numbers`` (1..count); ValueError naming the range for others."""
    mask = 0
    for number in numbers:
        mask |= 1 << (check_range(what, number, 1, count) - 1)
    return mask
