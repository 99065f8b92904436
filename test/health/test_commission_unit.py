"""Commissioning end to end on a bench-data unit (a drawn unit, not the nominal twin): its
baseline lets ``detect`` find and name a fault in another run of it.

Apart from test_commission.py: making the unit's runs needs the steady solver's kernels, which
the synthetic commissioning there does not (test/conftest.py runs that module while the steady
solver compiles).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from ballscrew_twin.cli import main
from ballscrew_twin.errors import ConfigError


def test_a_unit_bag_is_not_the_twin_and_detect_takes_its_baseline(tmp_path: Path) -> None:
    # bench-data unit: a drawn unit through a random duty cycle; commission on one run of it,
    # then detect on another with the baseline: a 30 % preload loss is found and named.
    # 150 s of healthy run (was 300 s): the commissioning takes 15 s instead of 22 s, and the
    # verdict is the same (preload_loss, confidence 1.0, found 0.30 s after the onset, with
    # 100 s as well; measured 2026-11-27).
    healthy, faulty = tmp_path / "healthy", tmp_path / "faulty"
    common = ["bench-data", "unit", "--unit", "3", "--preload", "1500"]
    assert (
        main(
            [
                *common,
                "--seed",
                "1",
                "--duration",
                "150",
                "--temperature",
                "ambient",
                "--out",
                str(healthy),
            ]
        )
        == 0
    )
    assert (
        main(
            [
                *common,
                "--seed",
                "2",
                "--duration",
                "60",
                "--temperature",
                "ambient",
                "--fault",
                "preload_loss:0.3:30",
                "--out",
                str(faulty),
            ]
        )
        == 0
    )
    truth = json.loads((tmp_path / "faulty.truth.json").read_text())
    assert truth["model"] == "unit" and truth["unit"]["seed"] == 3
    assert truth["unit"]["preload_scale"] != 1.0  # a unit, not the nominal twin
    baseline = tmp_path / "unit.yaml"
    assert main(["commission", str(healthy), "--out", str(baseline)]) == 0
    out = tmp_path / "detect"
    code = main(
        ["detect", str(faulty), "--baseline", str(baseline), "--out", str(out), "--no-plots"]
    )
    verdict = json.loads((out / "verdict.json").read_text())
    assert verdict["baseline"] == "healthy" and verdict["gated_s"] >= 0.0
    assert code == 1 and verdict["fault_class"] == "preload_loss"
    assert 0.0 <= verdict["detection_delay_s"] <= 5.0


def test_bench_data_unit_refuses_a_malformed_fault(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="CLASS:SEVERITY:ONSET"):
        from ballscrew_twin.commands.bench_data import _fault_argument

        _fault_argument("preload_loss-0.1")
