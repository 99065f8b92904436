"""Smoke test of ``ballscrew-twin bench detection --quick``: it runs and writes its outputs."""

from __future__ import annotations

import json
from pathlib import Path

from ballscrew_twin.cli import main


def test_quick_detection_benchmark_writes_its_tables_and_plots(tmp_path: Path) -> None:
    assert main(["bench", "detection", "--quick", "--out", str(tmp_path)]) == 0
    table = (tmp_path / "detection.md").read_text()
    assert "| class |" in table
    runs = json.loads((tmp_path / "runs.json").read_text())
    assert runs, "no run recorded"
    assert (tmp_path / "roc.png").stat().st_size > 0
