"""Scenario files: validation messages, the smooth step, the shipped scenarios."""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import given
from hypothesis import strategies as st

from ballscrew_twin.errors import ConfigError
from ballscrew_twin.models.dynamic_state import SpeedController
from ballscrew_twin.models.profile import smooth_step
from ballscrew_twin.models.scenario import Scenario, load_scenario

SCENARIOS = Path(__file__).resolve().parents[2] / "config" / "scenarios"
BASE: dict[str, Any] = {"name": "t", "temperature": 293.15, "preload": 100.0, "speed": 10.0}


def write(tmp_path: Path, **changes: Any) -> Path:
    data = {**BASE, **changes}
    data = {k: v for k, v in data.items() if v is not ...}
    path = tmp_path / "scenario.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return path


def test_defaults_are_the_paper_protocol(tmp_path: Path) -> None:
    sc = load_scenario(write(tmp_path))
    assert (sc.preload_ramp_end, sc.speed_ramp_start, sc.speed_ramp_end) == (5e-3, 0.05, 0.1)
    assert (sc.duration, sc.average_window, sc.time_step) == (0.6, 0.2, 1e-6)
    assert sc.controller == SpeedController()
    assert sc.backend == "compiled" and sc.balls_per_nut is None and sc.config is None
    assert sc.steps == 600_000 and sc.source == str(tmp_path / "scenario.yaml")


@pytest.mark.parametrize(
    ("changes", "fragment"),
    [
        ({"preload": float("nan")}, "preload: nan is not a finite number"),
        ({"preload": -1.0}, "preload = -1.0 is outside"),
        ({"temperature": 20.0}, "kelvin"),
        ({"speed": "fast"}, "speed: expected a number in rad/s"),
        ({"bogus": 1}, "unknown key(s) ['bogus']"),
        ({"speed": ...}, "speed: missing"),
        ({"speed_ramp_start": 0.2, "speed_ramp_end": 0.1}, "speed_ramp_end = 0.1 s is before"),
        ({"average_window": 0.7}, "duration = 0.6 s is shorter than average_window"),
        ({"speed_ramp_end": 0.45}, "speed_ramp_end = 0.45 s is inside the averaging window"),
        ({"time_step": 0.0}, "time_step = 0.0 is outside the allowed range (0, 0.0001]"),
        ({"time_step": 2e-4}, "time_step = 0.0002 is outside"),
        ({"balls_per_nut": 0}, "balls_per_nut = 0 is outside"),
        ({"balls_per_nut": 2.5}, "balls_per_nut: expected a whole number"),
        ({"jacobian_interval": 0}, "jacobian_interval = 0 is outside"),
        ({"output_interval": 1.5e-6}, "output_interval = 1.5e-06 s is not a whole number"),
        ({"backend": "gpu"}, "backend = 'gpu' is not one of"),
        ({"sphere_contacts": "yes"}, "sphere_contacts must be true or false, got 'yes'"),
        ({"implicit_positions": 1}, "implicit_positions must be true or false, got 1"),
        ({"fine_until": 0.01}, "fine_until = 0.01 s needs fine_time_step"),
        (
            {"time_step": 5e-6, "fine_time_step": 2e-6, "fine_until": 0.01},
            "time_step = 5e-06 s is not a whole number of 2e-06 s",
        ),
        (
            {"time_step": 1e-5, "fine_time_step": 2e-6, "fine_until": 1.5e-5},
            "fine_until = 1.5e-05 s is not a whole number of 1e-05 s",
        ),
        (
            {"time_step": 1e-5, "fine_time_step": 2e-6, "fine_until": 0.5},
            "fine_until = 0.5 s is inside the averaging window",
        ),
        ({"faults": {"jams": [{"nut": 0, "index": 1}]}}, "faults.jams[0].start: missing"),
        ({"controller_integral": -5.0}, "controller_integral = -5.0 is outside"),
        ({"duration": True}, "duration: expected a number in s"),
    ],
)
def test_invalid_fields_are_named_with_the_file(
    tmp_path: Path, changes: dict[str, Any], fragment: str
) -> None:
    path = write(tmp_path, **changes)
    with pytest.raises(ConfigError) as info:
        load_scenario(path)
    message = str(info.value)
    assert str(path) in message
    assert fragment in message


def test_not_a_mapping_and_missing_file(tmp_path: Path) -> None:
    path = tmp_path / "list.yaml"
    path.write_text("- 1\n- 2\n", encoding="utf-8")
    with pytest.raises(ConfigError, match="top level must be a mapping"):
        load_scenario(path)
    with pytest.raises(ConfigError, match="cannot read scenario file"):
        load_scenario(tmp_path / "absent.yaml")


def test_numbers_written_as_strings_are_read(tmp_path: Path) -> None:
    path = tmp_path / "s.yaml"
    # PyYAML (YAML 1.1) reads 1e-6 without a dot as a string.
    path.write_text(
        "name: s\ntemperature: 300\npreload: 1e3\nspeed: 5\ntime_step: 1e-6\n", encoding="utf-8"
    )
    sc = load_scenario(path)
    assert sc.preload == 1000.0 and sc.time_step == 1e-6


def test_programmatic_construction_is_validated() -> None:
    with pytest.raises(ConfigError, match=re.escape("<scenario>: preload = -2.0")):
        Scenario(name="x", temperature=300.0, preload=-2.0, speed=1.0)


def test_config_is_resolved_against_the_scenario_file(tmp_path: Path) -> None:
    sc = load_scenario(write(tmp_path, config="params/screw.yaml"))
    assert sc.config_path() == (tmp_path / "params" / "screw.yaml").resolve()


def test_commands_follow_the_ramps(tmp_path: Path) -> None:
    sc = load_scenario(write(tmp_path))
    assert sc.commands_at(0.0).preload == 0.0
    assert sc.commands_at(2.5e-3).preload == pytest.approx(50.0)
    assert sc.commands_at(5e-3).preload == 100.0
    assert sc.commands_at(0.05).screw_speed == 0.0
    assert sc.commands_at(0.075).screw_speed == pytest.approx(5.0)
    assert sc.commands_at(0.3).screw_speed == 10.0


@given(
    st.floats(-10.0, 10.0),
    st.floats(-5.0, 5.0),
    st.floats(1e-6, 5.0),
)
def test_smooth_step_properties(t: float, t0: float, width: float) -> None:
    t1 = t0 + width
    value = smooth_step(t, t0, t1)
    assert 0.0 <= value <= 1.0
    if t <= t0:
        assert value == 0.0
    if t >= t1:
        assert value == 1.0
    # Monotone, and symmetric about the midpoint: s(t0 + x) + s(t1 - x) = 1.
    assert smooth_step(t + 0.01 * width, t0, t1) >= value
    x = min(max(t - t0, 0.0), width)
    assert smooth_step(t0 + x, t0, t1) + smooth_step(t1 - x, t0, t1) == pytest.approx(1.0)


def test_smooth_step_values_and_slopes() -> None:
    assert smooth_step(0.5, 0.0, 1.0) == 0.5
    assert smooth_step(0.25, 0.0, 1.0) == pytest.approx(3 * 0.0625 - 2 * 0.015625)
    h = 1e-7
    assert smooth_step(h, 0.0, 1.0) / h < 1e-5  # zero slope at both ends
    assert (1.0 - smooth_step(1.0 - h, 0.0, 1.0)) / h < 1e-5
    assert smooth_step(1.0, 1.0, 1.0) == 1.0 and smooth_step(0.999, 1.0, 1.0) == 0.0


@pytest.mark.parametrize("name", [p.stem for p in sorted(SCENARIOS.glob("*.yaml"))])
def test_shipped_scenarios_load(name: str) -> None:
    sc = load_scenario(SCENARIOS / f"{name}.yaml")
    assert sc.name == name and sc.temperature == 293.15
    assert math.isclose(sc.speed, 100.0 * 2.0 * math.pi / 60.0)


def test_paper_protocol_is_the_papers() -> None:
    sc = load_scenario(SCENARIOS / "paper_protocol.yaml")
    assert sc.preload == 1500.0 and sc.balls_per_nut is None
    assert (sc.preload_ramp_end, sc.speed_ramp_start, sc.speed_ramp_end) == (5e-3, 0.05, 0.1)
    assert (sc.duration, sc.average_window) == (0.6, 0.2)
