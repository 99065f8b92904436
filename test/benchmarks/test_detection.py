"""Smoke test of ``ballscrew-twin bench detection --quick``: it runs and writes its outputs,
with a comparison monitor on the same recordings."""

from __future__ import annotations

import json
from pathlib import Path

from ballscrew_twin.cli import main


def test_quick_detection_benchmark_writes_its_tables_and_plots(tmp_path: Path) -> None:
    argv = ["bench", "detection", "--quick", "--out", str(tmp_path)]
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
