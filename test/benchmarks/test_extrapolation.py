"""``bench extrapolation``: its table against ratios worked out by hand, the cut of a recording,
its arguments, and its outputs (the per-unit work replaced: it commissions three times)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from ballscrew_twin.benchmarks import extrapolation
from ballscrew_twin.benchmarks.detection_plan import unit_draw
from ballscrew_twin.benchmarks.extrapolation import Row, _cut, shift_table, table
from ballscrew_twin.cli import main
from ballscrew_twin.errors import ConfigError

ROWS: list[Row] = [
    # variant, unit, d_T [K], |error|, band, shift term, transient terms (relative)
    ("whole", 3, 0.0, 0.02, 0.01, 0.0, 0.0),
    ("whole", 3, 10.0, 0.03, 0.01, 0.0, 0.001),
    ("whole", 4, 10.0, 0.03, 0.01, 0.0, 0.01),  # not steady: left out
    ("last 600 s", 4, 25.0, 0.04, 0.02, 0.03, 0.0),
]


def _cells(text: str, start: str) -> list[str]:
    line = next(x for x in text.splitlines() if x.startswith(start))
    return [c.strip() for c in line.strip("|").split("|")]


def test_each_growth_gives_the_ratio_of_the_error_to_the_sigma_it_makes() -> None:
    text = table(ROWS, (0.002, 0.0))
    inside = _cells(text, "| whole | inside |")
    assert inside[2:5] == ["1", "1", "2.00 / 2.00"]
    assert inside[5:] == ["2.00 / 2.00", "2.00 / 2.00"]  # e_T does not act inside
    # d_T = 10 K falls in (5, 10]: sqrt(0.01^2 + 0.02^2 + 0.001^2) at 0.2 %/K, 0.01005 at none
    outside = _cells(text, "| whole | 5-10 K |")
    assert outside[2:4] == ["1", "1"]
    assert outside[5] == f"{0.03 / math.sqrt(5.01e-4):.2f} / {0.03 / math.sqrt(5.01e-4):.2f}"
    assert outside[6] == f"{0.03 / math.sqrt(1.01e-4):.2f} / {0.03 / math.sqrt(1.01e-4):.2f}"
    far = _cells(text, "| last 600 s | > 20 K |")
    assert far[6] == f"{0.04 / math.hypot(0.02, 0.03):.2f} / {0.04 / math.hypot(0.02, 0.03):.2f}"
    assert "| whole | 0-2 K |" not in text


def test_each_shift_scale_gives_the_ratio_with_the_term_rescaled() -> None:
    """The rows' E_dT is on today's scale; five times it makes the term a fifth, inf leaves
    it out."""
    today = extrapolation.SHIFT_EXTRAPOLATION
    text = shift_table(ROWS, 0.002, (today, 5.0 * today, math.inf))
    far = _cells(text, "| > 20 K |")
    assert far[1:5] == ["1", "1", "4.00 / 4.00", "3.00"]
    for cell, shift in zip(far[5:], (0.03, 0.006, 0.0), strict=True):
        ratio = 0.04 / math.sqrt(0.02**2 + 0.05**2 + shift**2)
        assert cell == f"{ratio:.2f} / {ratio:.2f}"
    inside = _cells(text, "| inside |")  # both variants pooled; the unsteady row left out
    assert inside[1:3] == ["1", "1"] and inside[5:] == ["2.00 / 2.00"] * 3
    assert _cells(text, "| 5-10 K |")[1:3] == ["1", "1"]
    assert "no steady block" in shift_table(ROWS[2:3], 0.002, (5.0,))


def test_a_variant_without_a_steady_block_says_so() -> None:
    text = table([("first 200 s", 1, 3.0, 0.01, 0.01, 0.0, 0.05)], (0.005,))
    assert "| first 200 s | no steady block |" in text


def test_the_cut_keeps_the_samples_between_its_times_after_the_first_stamp() -> None:
    stamps = 100.0 + np.arange(0.0, 50.0, 0.5)
    channels = {"torque": (stamps, stamps * 2.0), "speed": (stamps[::2], stamps[::2])}
    cut = _cut(channels, 10.0, 20.0)
    assert cut["torque"][0][0] == 110.0 and cut["torque"][0][-1] == 119.5
    assert np.array_equal(cut["torque"][1], 2.0 * cut["torque"][0])
    assert cut["speed"][0][0] == 110.0 and cut["speed"][0][-1] == 119.0


@pytest.mark.parametrize(
    "argv, reason",
    [
        (["--growths", "0.5%"], "numbers"),
        (["--growths", "0.005,-1"], "finite and >= 0"),
        (["--first", "1300"], "--first and --last"),
        (["--shift-scales", "5 K"], "numbers [K]"),
        (["--shift-scales", "5,0"], "> 0 K"),
        (["--shift-scales", "nan"], "> 0 K"),
        (["--band-reach", "-1"], "--band-reach"),
        (["--band-reach", "nan"], "--band-reach"),
    ],
)
def test_arguments_that_cannot_run_are_refused(
    argv: list[str], reason: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["bench", "extrapolation", "--units", "0:1", *argv]) != 0
    assert reason in capsys.readouterr().err


def test_the_outputs_are_written(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    asked: list[tuple[int, float, float, float]] = []

    def rows(
        number: int, plan: object, first: float, last: float, config: object, reach: float
    ) -> list[Row]:
        asked.append((number, first, last, reach))
        return [(r[0], number, *r[2:]) for r in ROWS]

    monkeypatch.setattr(extrapolation, "unit_rows", rows)
    argv = ["bench", "extrapolation", "--units", "5:7", "--workers", "1", "--out", str(tmp_path)]
    assert main([*argv, "--band-reach", "0.5"]) == 0
    assert sorted(asked) == [(5, 200.0, 600.0, 0.5), (6, 200.0, 600.0, 0.5)]
    text = (tmp_path / "extrapolation.md").read_text()
    assert "Units 5:7" in text and _cells(text, "| whole | 5-10 K |")[3] == "2"
    assert "commissioned with a reach of 0.5 decades" in text
    assert json.loads((tmp_path / "extrapolation.json").read_text())[0]["band_reach"] == 0.5
    assert "ratio at X = 25 K" in text and _cells(text, "| > 20 K |")[1:3] == ["2", "2"]
    assert len((tmp_path / "extrapolation.json").read_text()) > 0
    assert (tmp_path / "extrapolation.png").stat().st_size > 0


def test_a_units_recordings_do_not_depend_on_its_number_of_fault_runs() -> None:
    """The benchmark draws each unit with no fault run; its commissioning and healthy
    recordings are then those ``bench detection`` made of it with four."""
    alone, with_faults = unit_draw(31007, 0), unit_draw(31007, 4)
    assert alone.seeds == with_faults.seeds[:3] and len(with_faults.seeds) == 11
    assert alone.preload == with_faults.preload and alone.unit == with_faults.unit


def test_an_earlier_runs_rows_are_tabulated_again_without_running_a_unit(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(extrapolation, "unit_rows", lambda number, *_: list(ROWS))
    first = tmp_path / "first"
    argv = ["bench", "extrapolation", "--units", "3:4", "--workers", "1", "--out", str(first)]
    assert main(argv) == 0
    capsys.readouterr()

    def refuse(*_: object) -> list[Row]:
        raise AssertionError("a unit was run")

    monkeypatch.setattr(extrapolation, "unit_rows", refuse)
    again = ["bench", "extrapolation", "--rows", str(first / "extrapolation.json")]
    assert main([*again, "--shift-scales", "inf"]) == 0
    text = capsys.readouterr().out
    assert f"the rows of {first / 'extrapolation.json'};" in text and "cold start" not in text
    assert sorted(extrapolation.read_rows(first / "extrapolation.json")) == sorted(ROWS)
    ratio = 0.04 / math.sqrt(0.02**2 + 0.05**2)
    assert _cells(text, "| > 20 K |")[5] == f"{ratio:.2f} / {ratio:.2f}"


@pytest.mark.parametrize("content", ['[{"variant": "whole"}]', "{", "\xff"])
def test_rows_that_are_not_a_runs_are_refused_naming_the_file(
    content: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "extrapolation.json"
    path.write_bytes(content.encode("latin-1"))
    assert main(["bench", "extrapolation", "--rows", str(path)]) != 0
    assert f"--rows {path}: not the extrapolation.json of a run" in capsys.readouterr().err


def test_rows_made_on_another_shift_scale_are_brought_to_todays(tmp_path: Path) -> None:
    path = tmp_path / "extrapolation.json"
    record = dict(zip(extrapolation.ROW_KEYS, ROWS[3], strict=True))
    twice = 2.0 * extrapolation.SHIFT_EXTRAPOLATION
    path.write_text(json.dumps([{**record, "shift_scale": twice}]))
    (row,) = extrapolation.read_rows(path)
    assert row[:5] == ROWS[3][:5] and row[6] == ROWS[3][6]
    assert row[5] == pytest.approx(2.0 * ROWS[3][5], rel=1e-15)
    path.write_text(json.dumps([record]))  # a file that does not say its scale
    with pytest.raises(ConfigError, match=r"not the extrapolation\.json of a run"):
        extrapolation.read_rows(path)
