"""``python3 dev.py bench NAME...`` runs only the benchmarks named (by module name)."""

from __future__ import annotations

import pytest

from benchmarks import __main__ as bench


@pytest.fixture
def ran(monkeypatch: pytest.MonkeyPatch) -> list[tuple[str, bool]]:
    """Every benchmark's main stubbed out: records (name, smoke) instead of measuring."""
    calls: list[tuple[str, bool]] = []
    for module in bench.BENCHMARKS:
        name = bench.benchmark_name(module)

        def record(smoke: bool = False, name: str = name) -> None:
            calls.append((name, smoke))

        monkeypatch.setattr(module, "main", record)
    return calls


def test_bench_runs_only_the_named_benchmarks_in_the_order_named(
    ran: list[tuple[str, bool]],
) -> None:
    assert bench.main(["--smoke", "decode_log", "sdo_twin"]) == 0
    assert ran == [("decode_log", True), ("sdo_twin", True)]


def test_bench_with_no_name_runs_every_benchmark(ran: list[tuple[str, bool]]) -> None:
    assert bench.main([]) == 0
    assert [name for name, _ in ran] == [bench.benchmark_name(m) for m in bench.BENCHMARKS]
    assert len(ran) == len(bench.BENCHMARKS) > 1


def test_bench_with_an_unknown_name_says_so_in_one_line_listing_the_valid_ones(
    ran: list[tuple[str, bool]], capsys: pytest.CaptureFixture[str]
) -> None:
    assert bench.main(["decode_log", "sdo"]) != 0
    error = capsys.readouterr().err
    assert error.count("\n") == 1
    assert error.startswith("Error: ")
    assert "'sdo'" in error
    assert all(bench.benchmark_name(module) in error for module in bench.BENCHMARKS)
    assert ran == []   # nothing measured: the name is checked before any benchmark runs
