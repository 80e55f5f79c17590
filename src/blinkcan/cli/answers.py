"""The user's answer to a question the CLI asks before it changes a device."""

from __future__ import annotations

import click

from blinkcan.errors import BlinkcanError


class DeclinedError(BlinkcanError):
    """The user answered "no": nothing was changed, and that is not an error (exit 0)."""


def confirm(what: str, yes: bool) -> None:
    """Ask "WHAT. Go on?" unless ``yes``; raise :class:`DeclinedError` on "no"."""
    if not yes and not click.confirm(f"{what}. Go on?"):
        raise DeclinedError(what)
