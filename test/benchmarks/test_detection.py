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
    compare = ["--compare-detectors", "cusum,spectral", "--compare-setting", "warn_fraction=0.6"]
    assert main([*argv, *compare]) == 0
    table = (tmp_path / "detection.md").read_text()
    assert "| class |" in table
    # the comparison monitor's report follows, on the same recordings (same hours of data)
    first, _, rest = table.partition("### The same recordings, detectors cusum, spectral only")
    second, _, third = rest.partition("### The same recordings, warn_fraction = 0.6")
    header = "| class | severity |"
    assert third and first.count(header) == second.count(header) == third.count(header) == 1
    hours = [line.split(" in ")[0] for line in table.splitlines() if line.startswith("Healthy")]
    assert len(hours) == 3 and len(set(hours)) == 1
    runs = json.loads((tmp_path / "runs.json").read_text())
    assert runs, "no run recorded"
    assert (tmp_path / "roc.png").stat().st_size > 0


def _arguments(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    detection.add_arguments(parser)
    return parser.parse_args(list(argv))


def test_a_compared_setting_is_one_numeric_setting_changed() -> None:
    argv = ("--compare-setting", "classification_patience=8", "--compare-setting", "warmup=2")
    extra = detection.comparison_settings(_arguments(*argv))
    assert [title for title, _ in extra] == ["classification_patience = 8", "warmup = 2"]
    assert extra[0][1].classification_patience == 8.0 and extra[1][1].warmup == 2.0
    for bad, reason in (("detectors=cusum", "NAME"), ("warmup=soon", "VALUE"), ("x", "NAME")):
        with pytest.raises(ConfigError, match=reason):
            detection.comparison_settings(_arguments("--compare-setting", bad))
    with pytest.raises(ConfigError, match="warmup"):  # the settings' own check
        detection.comparison_settings(_arguments("--compare-setting", "warmup=-1"))


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
