"""Input validation and unit conversion of the twin node (pure Python)."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from ballscrew_twin.ros.demo_commander import RPM_TO_RAD_S, command_at
from ballscrew_twin.ros.inputs import (
    InputLimits,
    celsius_to_kelvin,
    check_preload,
    check_screw_speed,
    check_temperature,
)

LIMITS = InputLimits()


def test_celsius_to_kelvin() -> None:
    assert celsius_to_kelvin(0.0) == 273.15
    assert celsius_to_kelvin(-273.15) == 0.0
    assert celsius_to_kelvin(20.0) == pytest.approx(293.15)


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_non_finite_rejected(value: float) -> None:
    assert check_screw_speed(value, LIMITS) is not None
    assert check_temperature(value, LIMITS) is not None
    assert check_preload(value, LIMITS) is not None


def test_limits() -> None:
    assert check_preload(-1.0e-9, LIMITS) is not None
    assert check_preload(0.0, LIMITS) is None
    assert check_preload(LIMITS.max_preload, LIMITS) is None
    assert check_preload(LIMITS.max_preload * 1.001, LIMITS) is not None
    assert check_screw_speed(-LIMITS.max_screw_speed, LIMITS) is None
    assert check_screw_speed(LIMITS.max_screw_speed * 1.001, LIMITS) is not None
    assert check_temperature(LIMITS.min_temperature - 0.01, LIMITS) is not None
    assert check_temperature(LIMITS.max_temperature + 0.01, LIMITS) is not None
    assert check_temperature(293.15, LIMITS) is None


@given(st.floats(allow_nan=True, allow_infinity=True))
def test_accepted_values_are_finite_and_in_range(value: float) -> None:
    if check_screw_speed(value, LIMITS) is None:
        assert math.isfinite(value) and abs(value) <= LIMITS.max_screw_speed
    if check_preload(value, LIMITS) is None:
        assert math.isfinite(value) and 0.0 <= value <= LIMITS.max_preload
    if check_temperature(value, LIMITS) is None:
        assert LIMITS.min_temperature <= value <= LIMITS.max_temperature


@pytest.mark.parametrize(
    "kwargs",
    [
        {"max_screw_speed": 0.0},
        {"max_preload": -1.0},
        {"min_temperature": 400.0, "max_temperature": 300.0},
        {"max_preload": math.nan},
    ],
)
def test_bad_limits_raise(kwargs: dict[str, float]) -> None:
    with pytest.raises(ValueError):
        InputLimits(**kwargs)


def test_demo_schedule() -> None:
    first, last = command_at(0.0), command_at(1.0)
    assert first.screw_speed == pytest.approx(100.0 * RPM_TO_RAD_S)
    assert first.preload == 1500.0
    assert command_at(0.3).preload > first.preload
    assert last.screw_speed < 0.0
    for k in range(101):
        cmd = command_at(k / 100.0)
        assert check_screw_speed(cmd.screw_speed, LIMITS) is None
        assert check_preload(cmd.preload, LIMITS) is None
        assert check_temperature(celsius_to_kelvin(cmd.temperature_c), LIMITS) is None
