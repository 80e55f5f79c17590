"""``blinkcan`` command line: one module per subcommand, registered here."""

from __future__ import annotations

import logging

import click

from blinkcan import __version__
from blinkcan.cli import control, convert, decode, demo, emulate, export, monitor, scan


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="blinkcan")
@click.option("-v", "--verbose", count=True, help="More log output (-vv for debug).")
def cli(verbose: int) -> None:
    """Digital twins, drivers and decoders for Blink Marine CANopen keypads and Keyboxes."""
    level = logging.WARNING - 10 * verbose
    logging.basicConfig(level=max(level, logging.DEBUG),
                        format="%(levelname)s %(name)s: %(message)s")


cli.add_command(emulate.command)
cli.add_command(demo.command)
cli.add_command(decode.command)
cli.add_command(export.command)
cli.add_command(convert.convert)
cli.add_command(convert.record)
cli.add_command(scan.command)
cli.add_command(monitor.command)
cli.add_command(control.keypad)
cli.add_command(control.keybox)


def main() -> None:
    cli(prog_name="blinkcan")
