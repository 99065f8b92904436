"""The one command-profile type: a profile evaluated at many times gives, bit for bit, what it
gives at each time; each user (scenario ramps, scene files, bench scenes) gets from it the values
of its own formula, written out here as the oracle."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ballscrew_twin.models.profile import Profile, SmoothStep, smooth_step
from ballscrew_twin.models.scenario import Scenario
from ballscrew_twin.scene import scene_from_mapping

TIMES = np.linspace(-0.5, 3.0, 701)
finite = st.floats(-1e3, 1e3, allow_nan=False)


@st.composite
def profiles(draw: st.DrawFn) -> Profile:
    times = sorted(set(draw(st.lists(st.floats(0.0, 2.0), max_size=4))))
    values = [draw(finite) for _ in times]
    steps = []
    for _ in range(draw(st.integers(0, 3))):
        start = draw(st.floats(0.0, 2.0))
        end = start + draw(st.sampled_from([0.0, draw(st.floats(1e-3, 1.0))]))
        steps.append(SmoothStep(start, end, draw(finite)))
    return Profile(tuple(times), tuple(values), tuple(steps))


@settings(max_examples=60, deadline=None)
@given(profiles())
def test_at_many_times_is_the_value_at_each(profile: Profile) -> None:
    many = profile.at(TIMES)
    each = np.array([profile(float(t)) for t in TIMES])
    assert many.tobytes() == each.tobytes()


def test_the_value_is_the_interpolation_plus_the_steps() -> None:
    profile = Profile((1.0, 2.0), (10.0, 20.0), (SmoothStep(0.5, 1.5, -4.0),))
    for t in (0.0, 0.75, 1.25, 3.0):
        base = 10.0 if t <= 1.0 else (20.0 if t >= 2.0 else 10.0 + 10.0 * (t - 1.0))
        assert profile(t) == pytest.approx(base - 4.0 * smooth_step(t, 0.5, 1.5), abs=1e-12)
    assert Profile()(1.0) == 0.0 and not Profile(steps=(SmoothStep(1, 1, 2.0),)).is_constant()
    hard = Profile(steps=(SmoothStep(1.0, 1.0, 2.0),))
    assert (hard(0.999), hard(1.0)) == (0.0, 2.0)


@pytest.mark.parametrize("speed", [10.0, -10.0])
def test_scenario_commands_are_its_ramps(speed: float) -> None:
    scenario = Scenario(
        name="s",
        temperature=293.15,
        preload=400.0,
        speed=speed,
        preload_ramp_end=1e-3,
        speed_ramp_start=2e-3,
        speed_ramp_end=5e-3,
        duration=0.02,
        average_window=0.01,
    )
    times = np.linspace(0.0, 6e-3, 61)
    for t in times:
        commands = scenario.commands_at(float(t))
        want_speed = speed * smooth_step(float(t), 2e-3, 5e-3)  # signed zero included
        assert np.float64(commands.screw_speed).tobytes() == np.float64(want_speed).tobytes()
        assert commands.preload == 400.0 * smooth_step(float(t), 0.0, 1e-3)
    assert (
        scenario.speed_profile.at(times).tobytes()
        == np.array([scenario.commands_at(float(t)).screw_speed for t in times]).tobytes()
    )


def test_scene_steps_alone_start_from_zero() -> None:
    scene = scene_from_mapping(
        {
            "name": "s",
            "duration": 1.0,
            "output_rate": 10.0,
            "commands": {
                "speed": {"steps": [{"time": 0.5, "duration": 0.2, "change": -20.0}]},
                "temperature": 293.15,
                "preload": 1000.0,
            },
            "tolerance": {"drag_torque": 0.05},
        }
    )
    assert scene.speed(0.0) == 0.0 and not np.signbit(scene.speed(0.0))  # +0, as before
    assert scene.speed(0.6) == pytest.approx(-20.0 * smooth_step(0.6, 0.5, 0.7))
    assert scene.speed(1.0) == -20.0 and scene.range("speed") == (-20.0, 0.0)
