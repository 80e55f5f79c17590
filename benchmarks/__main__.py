"""Run the benchmarks: ``python3 dev.py bench [NAME...]`` (``--smoke`` for a short CI run).

NAME is a benchmark's module name (``sdo_twin``, ``decode_log``...); none runs them all.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from types import ModuleType

from benchmarks import (
    canopen_time,
    decode_log,
    emulator_capacity,
    fleet_parquet,
    j1939_decode,
    memory,
    panel_latency,
    sdo_roundtrip,
    sdo_twin,
    simulated_time,
)

BENCHMARKS: tuple[ModuleType, ...] = (
    sdo_twin,
    sdo_roundtrip,
    emulator_capacity,
    decode_log,
    simulated_time,
    j1939_decode,
    canopen_time,
    fleet_parquet,
    memory,
    panel_latency,
)


def benchmark_name(module: ModuleType) -> str:
    """The name a user gives for a benchmark: its module's own name."""
    return module.__name__.rpartition(".")[2]


def selected(names: Sequence[str]) -> list[ModuleType]:
    """The benchmarks named, in the order named (all of them, in the usual order, for none)."""
    by_name = {benchmark_name(module): module for module in BENCHMARKS}
    unknown = [name for name in names if name not in by_name]
    if unknown:
        raise ValueError(
            f"no benchmark named {', '.join(map(repr, unknown))}; valid: {', '.join(by_name)}"
        )
    if not names:
        return list(BENCHMARKS)
    return [by_name[name] for name in dict.fromkeys(names)]


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python3 dev.py bench",
        description="Each figure beside its anchor, measured in the same run.",
    )
    parser.add_argument("--smoke", action="store_true", help="short run, to check they still work")
    parser.add_argument(
        "names",
        nargs="*",
        metavar="NAME",
        help=f"run only these (default: all): {', '.join(map(benchmark_name, BENCHMARKS))}",
    )
    args = parser.parse_args(argv)
    try:
        modules = selected(args.names)
    except ValueError as error:
        print(f"Error: {error}", file=sys.stderr)
        return 2
    for module in modules:
        module.main(smoke=args.smoke)
    return 0


if __name__ == "__main__":
    sys.exit(main())
