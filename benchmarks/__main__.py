"""Run the benchmarks: ``python3 dev.py bench`` (``--smoke`` for a short CI run)."""

from __future__ import annotations

import argparse

from benchmarks import (
    canopen_time,
    decode_log,
    emulator_capacity,
    fleet_parquet,
    j1939_decode,
    panel_latency,
    sdo_roundtrip,
    sdo_twin,
    simulated_time,
)


def main() -> None:
    parser = argparse.ArgumentParser(prog="python3 dev.py bench")
    parser.add_argument("--smoke", action="store_true", help="short run, to check they still work")
    args = parser.parse_args()
    sdo_twin.main(smoke=args.smoke)
    sdo_roundtrip.main(smoke=args.smoke)
    emulator_capacity.main(smoke=args.smoke)
    decode_log.main(smoke=args.smoke)
    simulated_time.main(smoke=args.smoke)
    j1939_decode.main(smoke=args.smoke)
    canopen_time.main(smoke=args.smoke)
    fleet_parquet.main(smoke=args.smoke)
    panel_latency.main(smoke=args.smoke)


main()
