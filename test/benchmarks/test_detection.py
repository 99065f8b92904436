"""Smoke test of ``ballscrew-twin bench detection``: it runs (two units in two worker processes,
each commissioned on a recording of its own) and writes its outputs, with a comparison monitor
on the same recordings.

The recordings are shorter than ``--quick``'s (commissioning 25 s instead of 120 s, healthy 20 s
instead of 60 s, one fault run of 15 s instead of 30 s): the commissioning fit, which uses up
to 600 blocks, was two thirds of the time, and the outputs are the same files and tables
(122 s -> 24 s measured back to back).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import pytest

from ballscrew_twin.benchmarks import detection
from ballscrew_twin.cli import main
from ballscrew_twin.errors import ConfigError

#: Two units, each: commissioning, healthy and one fault recording [s] (see the module doc).
PLAN = ["--units", "0:2", "--commission", "25", "--healthy", "20", "--faults", "1"]


def test_short_detection_benchmark_writes_its_tables_and_plots(tmp_path: Path) -> None:
    argv = ["bench", "detection", *PLAN, "--fault-length", "15", "--out", str(tmp_path)]
    assert main([*argv, "--compare-detectors", "cusum,spectral"]) == 0
    table = (tmp_path / "detection.md").read_text()
    assert "| class |" in table
    # the comparison monitor's report follows, on the same recordings (same hours of data)
    first, _, second = table.partition("### The same recordings, detectors cusum, spectral only")
    header = "| class | severity |"
    assert second and first.count(header) == second.count(header) == 1
    hours = [line for line in table.splitlines() if line.startswith("Healthy data:")]
    assert len(hours) == 2 and hours[0].split(" in ")[0] == hours[1].split(" in ")[0]
    runs = json.loads((tmp_path / "runs.json").read_text())
    assert runs, "no run recorded"
    assert (tmp_path / "roc.png").stat().st_size > 0


def _arguments(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    detection.add_arguments(parser)
    return parser.parse_args(list(argv))


def test_quick_asks_for_two_training_units_and_short_recordings() -> None:
    units, plan = detection.requested_plan(_arguments("--quick", "--units", "5000:5030"))
    assert units == range(2)  # --quick overrides --units: a smoke test on training units
    assert plan == detection.Plan(commission=120.0, healthy=60.0, faults=1, fault_length=30.0)
    units, plan = detection.requested_plan(_arguments(*PLAN))
    assert units == range(0, 2) and plan == detection.Plan(25.0, 20.0, 1, 60.0)


@pytest.mark.parametrize(
    "argv", [("--faults", "-1"), ("--healthy", "10"), ("--commission", "5"), ("--units", "3:1")]
)
def test_a_plan_that_cannot_run_is_refused_with_its_reason(argv: tuple[str, ...]) -> None:
    with pytest.raises(ConfigError):
        detection.requested_plan(_arguments(*argv))
