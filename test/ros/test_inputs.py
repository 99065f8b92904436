"""Input validation and unit conversion of the twin node, and the health node's sample check
(pure Python)."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from ballscrew_twin.errors import ConfigError
from ballscrew_twin.ros.demo_commander import command_at
from ballscrew_twin.ros.inputs import (
    NS_PER_S,
    InputChannel,
    InputLimits,
    check_axial_load,
    check_preload,
    check_sample,
    check_screw_speed,
    check_stamp,
    check_temperature,
)
from ballscrew_twin.units import RPM, celsius_to_kelvin

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


def test_axial_load_limits() -> None:
    assert check_axial_load(-LIMITS.max_axial_load, LIMITS) is None
    assert check_axial_load(LIMITS.max_axial_load * 1.001, LIMITS) is not None
    assert check_axial_load(math.nan, LIMITS) is not None


def test_rpm_sent_as_rad_s_is_named() -> None:
    limits = InputLimits(max_screw_speed=1884.96)  # the paper screw's critical speed
    reason = check_screw_speed(3000.0, limits)  # 3000 rpm = 314 rad/s, sent as rad/s
    assert reason is not None and "rpm" in reason
    assert "rpm" not in (check_screw_speed(1.0e6, limits) or "")  # too big in any unit


def test_kelvin_sent_as_celsius_is_named() -> None:
    reason = check_temperature(celsius_to_kelvin(293.15), LIMITS)  # 20 C sent in kelvin
    assert reason is not None and "kelvin" in reason


def test_stamps() -> None:
    now = 100 * NS_PER_S
    age = NS_PER_S
    assert check_stamp(0, last_stamp_ns=now, now_ns=now, max_age_ns=age) is None  # unstamped
    assert check_stamp(now - 10, last_stamp_ns=now - 20, now_ns=now, max_age_ns=age) is None
    assert "out of order" in (
        check_stamp(now - 20, last_stamp_ns=now - 10, now_ns=now, max_age_ns=age) or ""
    )
    assert "stale" in (
        check_stamp(now - 2 * age, last_stamp_ns=None, now_ns=now, max_age_ns=age) or ""
    )
    assert "ahead" in (
        check_stamp(now + 2 * age, last_stamp_ns=None, now_ns=now, max_age_ns=age) or ""
    )
    assert check_stamp(now - 50 * age, last_stamp_ns=None, now_ns=now, max_age_ns=0) is None


def test_channel_keeps_last_good_value_and_knows_its_age() -> None:
    channel = InputChannel("preload", "N", 1500.0)
    assert channel.is_stale(0, 1.0) and channel.age(0) is None
    channel.accept(2000.0, now_ns=5 * NS_PER_S, stamp_ns=4 * NS_PER_S)
    channel.reject("bad")
    assert channel.value == 2000.0 and channel.rejected == 1 and channel.last_rejection == "bad"
    assert channel.age(6 * NS_PER_S) == pytest.approx(1.0)
    assert not channel.is_stale(5 * NS_PER_S + NS_PER_S // 2, 1.0)
    assert channel.is_stale(7 * NS_PER_S, 1.0)
    channel.forget_times()
    assert channel.last_stamp_ns is None and channel.age(7 * NS_PER_S) is None


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
    if check_axial_load(value, LIMITS) is None:
        assert math.isfinite(value) and abs(value) <= LIMITS.max_axial_load


@pytest.mark.parametrize(
    "kwargs",
    [
        {"max_screw_speed": 0.0},
        {"max_preload": -1.0},
        {"min_temperature": 400.0, "max_temperature": 300.0},
        {"max_preload": math.nan},
        {"max_axial_load": 0.0},
    ],
)
def test_bad_limits_raise(kwargs: dict[str, float]) -> None:
    with pytest.raises(ConfigError):
        InputLimits(**kwargs)


def test_demo_schedule() -> None:
    first, last = command_at(0.0), command_at(1.0)
    assert first.screw_speed == pytest.approx(100.0 * RPM)
    assert first.preload == 1500.0
    assert command_at(0.3).preload > first.preload
    assert last.screw_speed < 0.0
    for k in range(101):
        cmd = command_at(k / 100.0)
        assert check_screw_speed(cmd.screw_speed, LIMITS) is None
        assert check_preload(cmd.preload, LIMITS) is None
        assert check_temperature(celsius_to_kelvin(cmd.temperature_c), LIMITS) is None


def test_the_node_accepts_its_own_lower_temperature_limit_in_celsius() -> None:
    # -40 C, the documented limit, arrives as a Temperature message in Celsius; the node's
    # conversion must land exactly on 233.15 K (a naive -40 + 273.15 is 233.14999999999998).
    limits = InputLimits()
    assert check_temperature(celsius_to_kelvin(-40.0), limits) is None
    assert check_temperature(-40.0 + 273.15, limits) is not None  # the old conversion failed


@pytest.mark.parametrize(
    ("channel", "stamp", "value", "reason"),
    [
        ("torque", 1.5, math.nan, "torque sample at 1.5 s: value: nan is not a finite number "
         "(allowed range [-inf, inf] N m)"),
        ("speed", 2.0, -math.inf, "speed sample at 2.0 s: value: -inf is not a finite number "
         "(allowed range [-inf, inf] rad/s)"),
        ("temperature", math.inf, 300.0, "temperature sample at inf s: stamp: inf is not a "
         "finite number (allowed range [-inf, inf] s)"),
        ("preload", math.nan, 1500.0, "preload sample at nan s: stamp: nan is not a finite"),
    ],
)  # fmt: skip
def test_a_non_finite_health_sample_is_refused_naming_its_channel_unit_and_value(
    channel: str, stamp: float, value: float, reason: str
) -> None:
    refusal = check_sample(channel, stamp, value)
    assert refusal is not None and refusal.startswith(reason), refusal


@given(
    st.sampled_from(["torque", "speed", "temperature", "preload"]),
    st.floats(allow_nan=False, allow_infinity=False),
    st.floats(allow_nan=False, allow_infinity=False),
)
def test_every_finite_health_sample_is_kept(channel: str, stamp: float, value: float) -> None:
    assert check_sample(channel, stamp, value) is None
