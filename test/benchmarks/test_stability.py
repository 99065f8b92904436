"""``bench stability --quick``: no model produces NaN or garbage under adversarial commands;
outside the validity envelope the answer is clamped with a warning."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import pytest

from ballscrew_twin.benchmarks.stability import (
    QUICK,
    Case,
    Entry,
    cases,
    dynamic_cases,
    model_registry,
    run_case,
)
from ballscrew_twin.cli import main
from ballscrew_twin.errors import NonFiniteOutputError, SolverError
from ballscrew_twin.models.base import OperatingPoint, TwinOutput
from ballscrew_twin.models.registry import ModelName, as_stepping, build
from ballscrew_twin.models.validity import ValidityEnvelope
from ballscrew_twin.params import load_config

CONFIG = load_config()


def _outside(op: OperatingPoint, margin: float) -> bool:
    """Outside the documented default envelope widened by the relative ``margin``: critical
    speed 1884.96 rad/s (Table A.1), -40..100 C, 5000 N preload and axial load."""
    grow = 1.0 + margin
    return (
        abs(op.screw_speed) > 1884.96 * grow
        or not 233.15 / grow <= op.temperature <= 373.15 * grow
        or op.preload > 5000.0 * grow
        or abs(op.axial_load) > 5000.0 * grow
    )


@pytest.fixture(scope="module")
def report(tmp_path_factory: pytest.TempPathFactory) -> tuple[list[dict[str, str]], Path]:
    out = tmp_path_factory.mktemp("stability")
    assert main(["bench", "stability", "--quick", "--quiet", "--out", str(out)]) == 0
    with (out / "stability.csv").open(encoding="utf-8") as handle:
        return list(csv.DictReader(handle)), out


def test_every_model_and_case_reported(report: tuple[list[dict[str, str]], Path]) -> None:
    rows, out = report
    entries, unavailable = model_registry(CONFIG, quick=True)
    names = [e.name for e in entries]
    case_names = [c.name for c in cases(CONFIG, QUICK.ticks, QUICK.long_ticks)]
    expected = {(m, c) for m in names for c in case_names}
    expected |= {("dynamic (1 sphere/nut)", d.name) for d in dynamic_cases(quick=True)}
    expected |= {(u.model, u.case) for u in unavailable}
    assert {(r["model"], r["case"]) for r in rows} == expected
    assert len(rows) == len(expected)
    table = (out / "stability.md").read_text()
    assert table.count("\n| ") == len(rows) + 1  # header + one line a row


def test_no_nan_no_blow_up(report: tuple[list[dict[str, str]], Path]) -> None:
    rows, _ = report
    for row in rows:
        where = (row["model"], row["case"])
        if row["case"] == "(construction)":  # an optional model that could not be built
            continue
        assert row["status"] in ("finished", "error", "budget"), (where, row["first_message"])
        if row["status"] == "error":  # a solver that says so, never a wrong number
            assert "did not converge" in row["first_message"], where
        torque = float(row["max_abs_torque_Nm"])
        assert math.isfinite(torque), where
        assert float(row["max_torque_over_bound"]) < 1.0, where
        # steady: the work-energy identity closes to round-off (docs/model.md section 7);
        # dynamic: the power balance within the 1 % at which simulate flags its breakdown
        balance = float(row["energy_balance_rel"])
        limit = 1e-2 if row["model"].startswith("dynamic") else 1e-6
        assert math.isnan(balance) or balance < limit, where


def test_clamped_exactly_where_outside_the_envelope(
    report: tuple[list[dict[str, str]], Path],
) -> None:
    rows, _ = report
    by_key = {(r["model"], r["case"]): r for r in rows}
    outside_somewhere = 0
    for case in cases(CONFIG, QUICK.ticks, QUICK.long_ticks):
        if case.long:
            continue
        # points within 1e-9 of a bound (a ramp ending on it) may fall on either side
        surely = sum(_outside(op, 1e-9) for op in case.commands)
        maybe = sum(_outside(op, -1e-9) for op in case.commands)
        outside_somewhere += surely > 0
        # the catalogue never fails, so every tick is reported
        for model in ("catalog-literature", "catalog-zhou"):
            row = by_key[(model, case.name)]
            assert row["status"] == "finished"
            assert surely <= int(row["clamped"]) <= maybe, (model, case.name)
    assert outside_somewhere >= 4


def test_memoryless_models_do_not_drift(report: tuple[list[dict[str, str]], Path]) -> None:
    rows, _ = report
    catalog = [r for r in rows if r["case"] == "long_run" and r["model"].startswith("catalog")]
    assert len(catalog) == 2
    for row in catalog:
        assert (
            row["status"] == "finished" and row["ticks"] == f"{QUICK.long_ticks}/{QUICK.long_ticks}"
        )
        assert float(row["drift_rel"]) == 0.0, row["model"]


class _Failing:
    """The catalogue model stepped quasi-statically, whose first ticks raise the given errors
    (a model failing the way a stress case can make it fail)."""

    def __init__(self, errors: list[Exception]) -> None:
        self.model = as_stepping(build(ModelName.CATALOG_ZHOU, CONFIG))
        self.name = "failing"
        self.errors = errors

    def reset(self, op: OperatingPoint) -> None:
        self.model.reset(op)

    def step(self, op: OperatingPoint, dt: float) -> TwinOutput:
        if self.errors:
            raise self.errors.pop(0)
        return self.model.step(op, dt)


def test_a_failing_tick_is_counted_by_kind_and_the_case_runs_on() -> None:
    """Each failure is counted by its kind, the first one's message is kept, the ticks after
    it still run, and the status is the worst kind (nan > exception > error)."""
    op = OperatingPoint(screw_speed=100.0, temperature=293.15, preload=1500.0)
    case = Case(name="hold", description="a hold", commands=[op] * 5)
    envelope = ValidityEnvelope.for_config(CONFIG)
    errors: list[Exception] = [
        SolverError("no convergence"),
        NonFiniteOutputError("drag torque is nan"),
        RuntimeError("boom"),
    ]
    result = run_case(Entry("failing", _Failing(errors)), case, CONFIG, envelope, 1.0)
    assert (result.failed, result.non_finite, result.other) == (1, 1, 1)
    assert result.done == 5 and result.first_message == "no convergence"
    assert result.max_torque > 0.0  # the two ticks after the failures ran
    assert result.status == "nan"
    result.non_finite = 0
    assert result.status == "exception"
    result.other = 0
    assert result.status == "error"
    result.failed = 0
    assert result.status == "finished"
