"""``blinkcan`` command line: one module per subcommand, registered here.

Every error ends the same way: one line on stderr and a non-zero exit (2 for a usage mistake,
1 otherwise); ``-vv`` adds the traceback of an unexpected one.
"""

from __future__ import annotations

import logging
import sys
from collections.abc import Sequence
from typing import Any

import click

from blinkcan import __version__
from blinkcan.cli import (
    control,
    convert,
    decode,
    demo,
    emulate,
    export,
    monitor,
    nmt,
    query,
    scan,
)
from blinkcan.cli.bus_options import bus_options, spread_bus_kwargs

log = logging.getLogger(__name__)


class BlinkcanGroup(click.Group):
    """The root group: python-can's ``--bus-kwargs a=1 b=2`` form, and one-line errors."""

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        return super().parse_args(ctx, spread_bus_kwargs(args))

    def main(self, args: Sequence[str] | None = None, prog_name: str | None = None,
             complete_var: str | None = None, standalone_mode: bool = True,
             **extra: Any) -> Any:
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode, **extra)
        try:
            result = super().main(args, prog_name, complete_var, False, **extra)
        except click.exceptions.NoArgsIsHelpError as error:
            click.echo(error.format_message())
            sys.exit(error.exit_code)
        except click.UsageError as error:
            hint = f" (see '{error.ctx.command_path} -h')" if error.ctx is not None else ""
            _fail(f"{error.format_message()}{hint}", error.exit_code)
        except click.ClickException as error:
            _fail(error.format_message(), error.exit_code)
        except click.Abort:
            _fail("aborted", 1)
        except KeyboardInterrupt:
            _fail("interrupted", 130)
        except OSError as error:
            _fail(_os_error(error), 1)
        except Exception as error:  # one line for the user, the trace with -vv
            log.debug("unexpected error", exc_info=True)
            _fail(f"unexpected {type(error).__name__}: {error} (-vv shows the traceback)", 1)
        sys.exit(result if isinstance(result, int) else 0)


def _os_error(error: OSError) -> str:
    where = f" {error.filename}" if error.filename else ""
    return f"cannot use{where}: {error.strerror or error}"


def _fail(message: str, code: int) -> None:
    click.echo(f"Error: {message}", err=True)
    sys.exit(code)


@click.group(cls=BlinkcanGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="blinkcan")
@click.option("-v", "--verbose", count=True, help="More log output (-vv for debug).")
@bus_options
def cli(verbose: int) -> None:
    """Digital twins, drivers and decoders for Blink Marine CANopen keypads and Keyboxes.

    Bus options (-i, -c, -b, --bus-kwargs) go before or after the command. With none given and
    none configured for python-can: udp_multicast 239.74.163.2:43113, hop limit 0 (processes of
    this machine only).
    """
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
cli.add_command(nmt.command)
cli.add_command(query.command)


def main() -> None:
    cli(prog_name="blinkcan")
