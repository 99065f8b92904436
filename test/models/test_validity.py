"""Validity envelope: clamping is a projection onto the envelope, with one warning per clamp;
invalid input is an error; a wrapped model never returns a non-finite number."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ballscrew_twin.errors import ConfigError, NonFiniteOutputError, OperatingPointError
from ballscrew_twin.models.base import OperatingPoint, QuasiStaticModel, TwinOutput
from ballscrew_twin.models.catalog import CatalogModel
from ballscrew_twin.models.realtime import RealTimeModel
from ballscrew_twin.models.steady import SteadyStateModel
from ballscrew_twin.models.validity import (
    REALTIME_LOW_PRELOAD_ERRORS,
    REALTIME_TABLE_ACCURACY,
    ValidatedModel,
    ValidityEnvelope,
    all_finite,
    clamp_operating_point,
    low_preload_note,
)
from ballscrew_twin.params import load_config

CONFIG = load_config()
ENVELOPE = ValidityEnvelope.for_config(CONFIG)
RPM = 2.0 * math.pi / 60.0


def test_default_envelope_from_the_screw() -> None:
    # Table A.1: critical speed 18000 rpm; documented defaults -40..100 C, 5000 N, 5000 N.
    assert ENVELOPE.max_speed == pytest.approx(18000 * RPM, rel=1e-5)
    assert ENVELOPE.min_temperature == pytest.approx(273.15 - 40.0)
    assert ENVELOPE.max_temperature == pytest.approx(273.15 + 100.0)
    assert (ENVELOPE.max_preload, ENVELOPE.max_axial_load) == (5000.0, 5000.0)
    assert ValidityEnvelope.for_config(CONFIG, max_preload=3000.0).max_preload == 3000.0


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"max_speed": math.nan}, "max_speed: nan is not a finite number"),
        (
            {"max_preload": -1.0},
            r"max_preload = -1.0 is outside the allowed range \(0, inf\] N \(must not be",
        ),
        ({"max_preload": 0.0}, r"max_preload = 0.0 is outside the allowed range \(0, inf\] N"),
        ({"min_temperature": 20.0, "max_temperature": 60.0}, "kelvin"),
        ({"min_temperature": 400.0}, "must be below"),
        ({"max_axial_load": "5000"}, "max_axial_load: expected a number in N"),
    ],
)
def test_invalid_envelope_is_named(changes: dict[str, object], message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        replace(ENVELOPE, **changes)  # type: ignore[arg-type]


def test_inside_point_unchanged() -> None:
    op = OperatingPoint(screw_speed=-100 * RPM, temperature=293.15, preload=0.0, axial_load=-200.0)
    assert clamp_operating_point(op, ENVELOPE) == (op, ())
    # -40 C written as -40 + 273.15 = 233.14999999999998 K is on the bound, not beyond it
    edge = OperatingPoint(screw_speed=1.0, temperature=-40.0 + 273.15, preload=5000.0)
    assert clamp_operating_point(edge, ENVELOPE) == (edge, ())


@pytest.mark.parametrize(
    ("op", "field", "expected", "word"),
    [
        (OperatingPoint(screw_speed=-3000.0, temperature=293.15, preload=1.0), "screw_speed",
         -ENVELOPE.max_speed, "screw_speed"),
        (OperatingPoint(screw_speed=1.0, temperature=200.0, preload=1.0), "temperature",
         233.15, "temperature"),
        (OperatingPoint(screw_speed=1.0, temperature=450.0, preload=1.0), "temperature",
         373.15, "temperature"),
        (OperatingPoint(screw_speed=1.0, temperature=293.15, preload=9e3), "preload",
         5000.0, "preload"),
        (OperatingPoint(screw_speed=1.0, temperature=293.15, preload=1.0, axial_load=-8e3),
         "axial_load", -5000.0, "axial_load"),
    ],
)  # fmt: skip
def test_each_quantity_clamped_with_a_warning(
    op: OperatingPoint, field: str, expected: float, word: str
) -> None:
    clamped, warnings = clamp_operating_point(op, ENVELOPE)
    assert getattr(clamped, field) == pytest.approx(expected)
    assert len(warnings) == 1 and word in warnings[0] and "evaluated at" in warnings[0]
    for other in ("screw_speed", "temperature", "preload", "axial_load"):
        if other != field:
            assert getattr(clamped, other) == getattr(op, other)


@settings(max_examples=200, deadline=None)
@given(
    speed=st.floats(-1e5, 1e5),
    temperature=st.floats(138.5, 2000.0),
    preload=st.floats(0.0, 1e6),
    axial=st.floats(-1e6, 1e6),
)
def test_clamp_is_a_projection(
    speed: float, temperature: float, preload: float, axial: float
) -> None:
    op = OperatingPoint(
        screw_speed=speed, temperature=temperature, preload=preload, axial_load=axial
    )
    clamped, warnings = clamp_operating_point(op, ENVELOPE)
    env = ENVELOPE
    grow = 1.0 + 1e-9  # a bound overshot by round-off (1e-9 relative) is not clamped
    assert abs(clamped.screw_speed) <= env.max_speed * grow
    assert env.min_temperature / grow <= clamped.temperature <= env.max_temperature * grow
    assert 0.0 <= clamped.preload <= env.max_preload * grow
    assert abs(clamped.axial_load) <= env.max_axial_load * grow
    # the nearest point of the box: each coordinate is either kept or set to the nearer bound
    for name, low, high in (
        ("screw_speed", -env.max_speed, env.max_speed),
        ("temperature", env.min_temperature, env.max_temperature),
        ("preload", 0.0, env.max_preload),
        ("axial_load", -env.max_axial_load, env.max_axial_load),
    ):
        assert getattr(clamped, name) in (getattr(op, name), low, high), name
    assert len(warnings) == sum(
        getattr(clamped, f) != getattr(op, f)
        for f in ("screw_speed", "temperature", "preload", "axial_load")
    )
    assert clamp_operating_point(clamped, ENVELOPE) == (clamped, ())


@pytest.mark.parametrize(
    ("op", "message"),
    [
        (OperatingPoint(screw_speed=math.nan, temperature=293.15, preload=1.0), "screw_speed"),
        (OperatingPoint(screw_speed=1.0, temperature=20.0, preload=1.0), "kelvin"),
        (OperatingPoint(screw_speed=1.0, temperature=293.15, preload=-5.0), "preload"),
    ],
)
def test_invalid_input_is_an_error_not_a_clamp(op: OperatingPoint, message: str) -> None:
    with pytest.raises(OperatingPointError, match=message):
        clamp_operating_point(op, ENVELOPE)


def test_wrapped_catalog_is_clamped_with_note() -> None:
    model = ValidatedModel(CatalogModel(CONFIG, formula="zhou"), ENVELOPE)
    out = model.evaluate(OperatingPoint(screw_speed=10.0, temperature=293.15, preload=8000.0))
    # Eq. 52, mu = 0.002: 6.39 N mm at 500 N (MODEL_NOTES), linear in preload -> 63.9 at 5000 N
    assert out.drag_torque == pytest.approx(63.9e-3, rel=2e-3)
    assert out.operating_point.preload == 5000.0
    assert any("preload = 8000 N exceeds 5000 N" in note for note in out.notes)


def test_wrapped_time_stepping_model() -> None:
    model = ValidatedModel(QuasiStaticModel(CatalogModel(CONFIG, formula="zhou")), ENVELOPE)
    hot = OperatingPoint(screw_speed=-5000.0, temperature=293.15, preload=500.0)
    model.reset(hot)
    out = model.step(hot, 1e-3)
    assert out.drag_torque == pytest.approx(-6.39e-3, rel=2e-3)  # sign of the speed kept
    assert out.operating_point.screw_speed == -ENVELOPE.max_speed
    assert any("|screw_speed| = 5000 rad/s exceeds 1884.96 rad/s" in n for n in out.notes)
    with pytest.raises(OperatingPointError, match="time step"):
        model.step(hot, math.nan)
    with pytest.raises(TypeError, match="not a steady-state model"):
        model.evaluate(hot)
    with pytest.raises(TypeError, match="not a time-stepping model"):
        ValidatedModel(CatalogModel(CONFIG), ENVELOPE).step(hot, 1e-3)


def test_wrapped_steady_model_at_the_bound() -> None:
    steady = SteadyStateModel(CONFIG)
    model = ValidatedModel(SteadyStateModel(CONFIG), ENVELOPE)
    op = OperatingPoint(screw_speed=100 * RPM, temperature=150 + 273.15, preload=1500.0)
    out = model.evaluate(op)
    direct = steady.evaluate(replace(op, temperature=ENVELOPE.max_temperature))
    assert out.drag_torque == pytest.approx(direct.drag_torque, rel=1e-8)
    assert any("temperature = 423.15 K" in note for note in out.notes)


class _Broken:
    """A model whose drag torque is NaN (stands in for a diverged solver)."""

    name = "broken"

    def evaluate(self, op: OperatingPoint) -> TwinOutput:
        out = CatalogModel(CONFIG).evaluate(op)
        return replace(out, drag_torque=math.nan)


def test_non_finite_output_is_never_returned() -> None:
    model = ValidatedModel(_Broken(), ENVELOPE)
    with pytest.raises(NonFiniteOutputError, match="drag_torque = nan"):
        model.evaluate(OperatingPoint(screw_speed=1.0, temperature=293.15, preload=100.0))


@given(
    st.lists(
        st.lists(st.floats(allow_nan=True, allow_infinity=True, width=64), max_size=8),
        max_size=5,
    )
)
def test_all_finite_agrees_with_an_element_by_element_check(values: list[list[float]]) -> None:
    arrays = [np.asarray(v, dtype=np.float64) for v in values]
    expected = all(math.isfinite(x) for v in values for x in v)
    assert all_finite(arrays) is expected


def test_all_finite_of_huge_values_and_of_nothing() -> None:
    huge = np.full(4, 1.0e308)
    assert all_finite([huge, -huge])
    assert not all_finite([huge, np.array([0.0, math.nan])])
    assert all_finite([])


def _band_error(preload: float) -> float:
    """The measured error [-] of ``preload``'s band."""
    for low, high, error, _ in REALTIME_LOW_PRELOAD_ERRORS:
        if low <= preload < high:
            return error
    raise AssertionError(f"{preload} N is in no band")


def _band_bound(preload: float) -> str:
    """The measured bound of ``preload``'s band as the note prints it."""
    return f"{100 * _band_error(preload):.3g} %"


@pytest.mark.parametrize("preload", [0.0, 12.0, 20.0, 60.0, 120.0])
def test_real_time_table_at_low_preload_carries_the_measured_bound(preload: float) -> None:
    """Where the packaged table was measured more than 1 % off the steady model, each output
    says by how much, on the step and the steady interface alike; where it was measured within
    1 %, no output carries a note."""
    noted = _band_error(preload) > REALTIME_TABLE_ACCURACY
    bound = _band_bound(preload)
    model = ValidatedModel(RealTimeModel(CONFIG), ENVELOPE)
    op = OperatingPoint(screw_speed=300 * RPM, temperature=293.15, preload=preload)
    for out in (model.step(op, 1e-3), model.step(op, 1e-3, contacts=False), model.evaluate(op)):
        notes = [n for n in out.notes if n.startswith("validity:")]
        if noted:
            assert len(notes) == 1 and bound in notes[0] and f"{preload:.4g} N" in notes[0]
        else:
            assert notes == []


def test_no_low_preload_note_above_150_n_or_for_other_models() -> None:
    realtime = ValidatedModel(RealTimeModel(CONFIG), ENVELOPE)
    op = OperatingPoint(screw_speed=300 * RPM, temperature=293.15, preload=150.0)
    assert not [n for n in realtime.step(op, 1e-3).notes if n.startswith("validity:")]
    catalog = ValidatedModel(CatalogModel(CONFIG), ENVELOPE)
    low = replace(op, preload=5.0)
    assert not [n for n in catalog.evaluate(low).notes if n.startswith("validity:")]


def test_a_table_of_another_screw_says_it_was_not_checked_at_low_preload() -> None:
    class OtherTable:
        fingerprint = "0" * 64

    class OtherScrew:
        name = "realtime_map"
        map = OtherTable()

    op = OperatingPoint(screw_speed=300 * RPM, temperature=293.15, preload=40.0)
    note = low_preload_note(OtherScrew(), op)
    assert note is not None and "not checked" in note and _band_bound(40.0) in note
