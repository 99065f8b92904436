"""The package's one check of a number against its field metadata (params.check_number) and of a
mapping against a dataclass (params.from_mapping): every error names the field, the unit and the
allowed range, and each loader (parameter sets, scenarios, scenes, sensors, bench scenes,
faults, the fidelity bounds with their grid and rows, sweep dimensions), the health settings
and the ROS nodes' parameters and inputs answer through them."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from ballscrew_twin.commands.sweep import parse_dimension
from ballscrew_twin.errors import ConfigError, FidelityError, SweepError
from ballscrew_twin.fidelity import load_bounds
from ballscrew_twin.health.bench_scene import bench_scene_from_mapping
from ballscrew_twin.health.monitor_settings import MonitorSettings
from ballscrew_twin.health.residuals import ResidualSettings
from ballscrew_twin.health.sensors import TorqueMeter, sensors_from_mapping
from ballscrew_twin.health.tracker import TrackerSettings
from ballscrew_twin.models.faults import SphereJam, faults_from_mapping
from ballscrew_twin.models.scenario import Scenario, scenario_from_mapping
from ballscrew_twin.params import (
    Orientation,
    check_number,
    from_mapping,
    limits,
    quantity,
    validate_fields,
)
from ballscrew_twin.ros.inputs import InputLimits, check_preload, check_screw_speed
from ballscrew_twin.ros.parameters import ParameterSpec
from ballscrew_twin.scene import scene_from_mapping

SPEED = limits("rad/s", -100.0, 100.0)
STEP = limits("s", 0.0, 1e-4, lo_open=True)
COUNT = limits("-", 1, 500, integer=True)


@pytest.mark.parametrize(
    ("raw", "meta", "message"),
    [
        ("fast", SPEED, "w: expected a number in rad/s within [-100, 100], got 'fast'"),
        ([1.0], SPEED, "w: expected a number in rad/s within [-100, 100], got [1.0]"),
        (True, SPEED, "w: expected a number in rad/s within [-100, 100], got True"),
        (float("nan"), SPEED, "w: nan is not a finite number (allowed range [-100, 100] rad/s)"),
        (2.5, COUNT, "w: expected a whole number, got 2.5 (allowed range [1, 500] -)"),
        (0.0, STEP, "w = 0.0 is outside the allowed range (0, 0.0001] s"),
        (-1.0, STEP, "w = -1.0 is outside the allowed range (0, 0.0001] s (must not be negative)"),
        (
            900.0,  # rpm: 94 rad/s
            SPEED,
            "w = 900.0 is outside the allowed range [-100, 100] rad/s "
            "(speeds are in rad/s, not rpm)",
        ),
        (
            20.0,
            limits("K", 139.0, 500.0),
            "w = 20.0 is outside the allowed range [139, 500] K "
            "(temperatures are in kelvin, not degrees Celsius)",
        ),
        (
            "8",
            limits("m", 1e-3, 0.5),
            "w = '8' is outside the allowed range [0.001, 0.5] m "
            "(given in milli-units? values are SI)",
        ),
        (0.6, limits("-", 0.0, 0.5, hint="between 0 and 0.5"), "(between 0 and 0.5)"),
        (
            210.0,  # GPa: 210e9 Pa
            limits("Pa", 1e9, 1e12),
            "w = 210.0 is outside the allowed range [1e+09, 1e+12] Pa "
            "(given in GPa? values are SI, Pa)",
        ),
        (
            200.0,  # a roughness in nm: 2e-7 m
            limits("m", 0.0, 5e-6),
            "w = 200.0 is outside the allowed range [0, 5e-06] m "
            "(given in nanometres? lengths are in m)",
        ),
    ],
)
def test_each_error_names_the_field_the_unit_and_the_range(
    raw: Any, meta: dict[str, Any], message: str
) -> None:
    with pytest.raises(ConfigError) as err:
        check_number(raw, meta, "w")
    assert message in str(err.value)


def test_a_hint_of_none_gives_no_hint_and_rates_get_no_milli_unit_hint() -> None:
    with pytest.raises(ConfigError) as err:
        check_number(-5.0, limits("m", 0.0, 10.0, hint=None), "w")
    assert str(err.value) == "w = -5.0 is outside the allowed range [0, 10] m"  # not negative
    with pytest.raises(ConfigError) as err:
        check_number(5000.0, limits("Hz", 1.0, 100.0), "w")
    assert str(err.value) == "w = 5000.0 is outside the allowed range [1, 100] Hz"
    with pytest.raises(ConfigError, match=re.escape("(given in milli-units? values are SI)")):
        check_number(5000.0, limits("s", 1.0, 100.0), "w")
    # a time step of 1 s against 1e-4 s at most: no unit slip explains it (it was "GPa?")
    with pytest.raises(ConfigError) as err:
        check_number(1.0, STEP, "w")
    assert str(err.value) == "w = 1.0 is outside the allowed range (0, 0.0001] s"


def test_valid_numbers_come_back_as_numbers() -> None:
    assert check_number("1e-6", STEP, "w") == 1e-6  # PyYAML reads 1e-6 as a string
    assert check_number(1e-4, STEP, "w") == 1e-4  # the closed end
    count = check_number("3", COUNT, "w")
    assert count == 3 and isinstance(count, int)
    with pytest.raises(ConfigError, match="expected a number"):
        check_number("1e-6", STEP, "w", text=False)


def test_validate_fields_checks_every_ranged_field_and_skips_an_unset_optional_one() -> None:
    @dataclass(frozen=True)
    class Thing:
        speed: float = quantity("rad/s", -100.0, 100.0, "a speed")
        count: int | None = quantity("-", 1, 500, "a count", default=None, integer=True)

    validate_fields(Thing(speed=1.0), "thing")
    with pytest.raises(ConfigError, match=re.escape("thing: count = 0 is outside")):
        validate_fields(Thing(speed=1.0, count=0), "thing", ": ")
    with pytest.raises(ConfigError, match=re.escape("thing.speed: expected a number in rad/s")):
        validate_fields(Thing(speed="1"), "thing")  # type: ignore[arg-type]


#: The same wrong value through every loader: the same words.
OUTSIDE = re.compile(r"= -5(\.0)? is outside the allowed range \[0, [0-9e+.]+\] N \(must not")


def test_every_loader_answers_through_the_one_check() -> None:
    scenario = {"name": "s", "temperature": 293.15, "preload": -5.0, "speed": 1.0}
    scene = {
        "name": "s",
        "duration": 1.0,
        "output_rate": 4.0,
        "commands": {"speed": 1.0, "temperature": 293.15, "preload": -5.0},
        "tolerance": {"drag_torque": 0.02},
    }
    bench = {"name": "b", "duration": 1.0, "profile": [{"time": 0.0, "speed": 1.0,
             "temperature": 293.15, "preload": -5.0}]}  # fmt: skip
    loaders = [
        lambda: scenario_from_mapping(scenario, "f"),
        lambda: Scenario(**scenario),
        lambda: scene_from_mapping(scene, "f"),
        lambda: bench_scene_from_mapping(bench, "f"),
    ]
    for load in loaders:
        with pytest.raises(ConfigError) as err:
            load()
        assert OUTSIDE.search(str(err.value)), str(err.value)
    with pytest.raises(ConfigError, match=re.escape("sensors.torque.noise = -1 is outside")):
        sensors_from_mapping({"torque": {"noise": -1}}, "sensors")
    with pytest.raises(ConfigError, match=re.escape("sensors.torque.rate = 0.5 is outside")):
        TorqueMeter(rate=0.5)
    # the ROS nodes: a parameter's value and a commanded input
    preload = ParameterSpec("initial_preload", 1500.0, "N", "Preload", 0.0, 1.0e6)
    assert OUTSIDE.search(preload.check(-5.0) or ""), preload.check(-5.0)
    assert OUTSIDE.search(check_preload(-5.0, InputLimits()) or ""), check_preload(
        -5.0, InputLimits()
    )


def test_faults_bounds_sweeps_and_node_limits_answer_through_the_one_check(
    tmp_path: Path,
) -> None:
    """The refusals of the other validators carry the one check's words: the field or input,
    its unit and its range (a private check would word them otherwise)."""
    with pytest.raises(ConfigError) as err:
        faults_from_mapping({"jams": [{"nut": 1, "index": 0, "start": -5.0}]}, 3, "f")
    assert str(err.value) == (
        "f.jams[0].start = -5.0 is outside the allowed range [0, 100] s (must not be negative)"
    )
    with pytest.raises(
        ConfigError, match=re.escape("index = 3 is outside the allowed range [0, 2] -")
    ):
        faults_from_mapping({"jams": [{"nut": 1, "index": 3, "start": 0.0}]}, 3, "f")
    with pytest.raises(ConfigError, match=re.escape("sphere jam.nut = 2 is outside the allowed")):
        SphereJam(nut=2, index=0, start=0.0)
    bounds = tmp_path / "bounds.yaml"
    bounds.write_text(
        "command: c\ngrid: {preload_N: [0], speed_rad_s: [1], temperature_K: [293]}\n"
        "columns: [preload_N]\nrows: [[0]]\nreference: {drag_torque: 0.1}\n"
        "dynamic: {step_cost_s: -5}\ncost: {catalog: 1e-6}\n"
    )
    infinite = tmp_path / "infinite.yaml"  # an error of a reference of 0: kept, rules it out
    infinite.write_text(bounds.read_text().replace("step_cost_s: -5", "drag_torque: .inf"))
    assert load_bounds(infinite).dynamic == {"drag_torque": float("inf")}
    with pytest.raises(FidelityError) as fidelity:
        load_bounds(bounds)
    assert str(fidelity.value) == (
        f"{bounds}: dynamic.step_cost_s = -5 is outside the allowed range [0, inf] s "
        "(must not be negative)"
    )
    with pytest.raises(SweepError) as sweep:
        parse_dimension("screw_speed", "10,fast", "rad/s", float, "rpm")
    assert str(sweep.value) == (
        "sweep dimension screw_speed = '10,fast': expected a number in rpm within [-inf, inf], "
        "got 'fast'"
    )
    reason = check_screw_speed(3000.0, InputLimits(max_screw_speed=1884.96))
    assert reason is not None and reason.startswith(
        "screw speed = 3000.0 is outside the allowed range [-1884.96, 1884.96] rad/s (was it sent "
        "in rpm?"
    )
    with pytest.raises(ConfigError, match=re.escape("limits.max_preload = -5.0 is outside the")):
        InputLimits(max_preload=-5.0)


def test_from_mapping_builds_a_dataclass_naming_every_refusal() -> None:
    @dataclass(frozen=True, kw_only=True)
    class Part:
        kind: str
        length: float = quantity("m", 0.0, 1.0, "a length")
        orientation: Orientation = "vertical"
        count: int = quantity("-", 1, 9, "a count", default=1, integer=True)

        def __post_init__(self) -> None:
            if self.kind == "bad":
                raise ConfigError("kind bad")

    part = from_mapping(Part, {"length": "0.5", "orientation": "horizontal"}, "p", kind="k")
    assert part == Part(kind="k", length=0.5, orientation="horizontal")
    refusals = [
        ([1.0], {}, "p: expected a mapping, got list"),
        ({"length": 0.5, "size": 1}, {}, "p: unknown key(s) ['size']; allowed: ['count', "),
        ({}, {}, "p.length: missing"),
        ({"length": 2.0}, {}, "p.length = 2.0 is outside the allowed range [0, 1] m"),
        ({"length": 0.5, "orientation": "up"}, {}, "p.orientation: 'up' is not one of"),
        ({"length": 0.5, "count": 1.5}, {}, "p.count: expected a whole number"),
        ({"length": 0.5}, {"kind": "bad"}, "p: kind bad"),
    ]
    for data, extra, message in refusals:
        with pytest.raises(ConfigError) as err:
            from_mapping(Part, data, "p", **{"kind": "k", **extra})
        assert message in str(err.value)


def test_an_open_upper_end_refuses_the_end_and_shows_it_open() -> None:
    fraction = limits("-", 0.0, 1.0, lo_open=True, hi_open=True)
    assert check_number(0.999, fraction, "w") == 0.999
    for end in (0.0, 1.0):
        with pytest.raises(ConfigError) as err:
            check_number(end, fraction, "w")
        assert str(err.value) == f"w = {end!r} is outside the allowed range (0, 1) -"


@pytest.mark.parametrize(
    ("setting", "message"),
    [
        ({"warmup": -1.0}, "warmup = -1.0 is outside the allowed range (0, inf] s (must not"),
        ({"spectral_period": 0.0}, "spectral_period = 0.0 is outside the allowed range (0, inf] s"),
        ({"cusum_shift": math.inf}, "cusum_shift: inf is not a finite number"),
        ({"drift_error_time": math.nan}, "drift_error_time: nan is not a finite number"),
        ({"min_revolutions": 0}, "min_revolutions = 0 is outside the allowed range (0, inf] -"),
        ({"confident_class": 1.5}, "confident_class = 1.5 is outside the allowed range (0, 1] -"),
        ({"warn_fraction": 1.0}, "warn_fraction = 1.0 is outside the allowed range (0, 1) -"),
        ({"chi_square_window": 1}, "chi_square_window = 1 is outside the allowed range [2, inf] -"),
        ({"chi_square_window": 2.5}, "chi_square_window: expected a whole number, got 2.5"),
        ({"inertia_gate": -2.0}, "inertia_gate = -2.0 is outside the allowed range (0, inf] -"),
        (
            {"settling_lag_angles": 0.0},
            "settling_lag_angles = 0.0 is outside the allowed range (0, inf] -",
        ),
        ({"local_settling": -1.0}, "local_settling = -1.0 is outside the allowed range [0, inf] -"),
        (
            {"standstill_shift": -0.1},
            "standstill_shift = -0.1 is outside the allowed range [0, inf] rad/s",
        ),
        (
            {"presliding_remainder": -0.5},
            "presliding_remainder = -0.5 is outside the allowed range [0, inf] -",
        ),
        (
            {"lowest_neighbour_order": -1.0},
            "lowest_neighbour_order = -1.0 is outside the allowed range [0, inf] -",
        ),
        ({"lowest_neighbour_order": math.nan}, "lowest_neighbour_order: nan is not a finite"),
    ],
)
def test_a_health_setting_out_of_range_is_refused_naming_it_its_unit_and_range(
    setting: dict[str, float], message: str
) -> None:
    with pytest.raises(ConfigError) as err:
        MonitorSettings(**setting)  # type: ignore[arg-type]
    assert str(err.value).startswith(f"health settings: {message}"), str(err.value)


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (
            lambda: ResidualSettings(block_duration=0.0),
            "health settings: block_duration = 0.0 is outside the allowed range (0, inf] s",
        ),
        (
            lambda: ResidualSettings(gate_angle=-1.0),
            "health settings: gate_angle = -1.0 is outside the allowed range [0, inf] rad",
        ),
        (
            lambda: ResidualSettings(sensor_noise=0.0),
            "health settings: sensor_noise = 0.0 is outside the allowed range (0, inf] N m",
        ),
        (
            lambda: ResidualSettings(temperature_step=math.nan),
            "health settings: temperature_step: nan is not a finite number",
        ),
        (
            lambda: TrackerSettings(scale_drift=-1.0),
            "tracker settings: scale_drift = -1.0 is outside the allowed range (0, inf] 1/sqrt(s)",
        ),
        (
            lambda: TrackerSettings(preload_prior=math.inf),
            "tracker settings: preload_prior: inf is not a finite number",
        ),
    ],
)
def test_residual_and_tracker_settings_are_refused_naming_the_setting_unit_and_range(
    make: Any, message: str
) -> None:
    with pytest.raises(ConfigError) as err:
        make()
    assert str(err.value).startswith(message), str(err.value)


def test_residual_settings_at_their_ends_are_accepted() -> None:
    """Zero where a setting may be zero (no wait, no gate, no model error floor); None for a
    sensor noise to be learnt."""
    settings = ResidualSettings(
        max_wait=0.0, gate_speed=0.0, gate_angle=0.0, model_error_absolute=0.0, sensor_noise=None
    )
    assert (settings.max_wait, settings.gate_angle, settings.sensor_noise) == (0.0, 0.0, None)


def test_health_settings_at_their_ends_are_accepted() -> None:
    settings = MonitorSettings(
        confident_class=1.0, chi_square_window=2, warn_fraction=0.99, bin_agreement=math.inf
    )
    assert (settings.confident_class, settings.chi_square_window) == (1.0, 2)
    assert MonitorSettings(warmup=1e-9).warmup == 1e-9
    assert MonitorSettings(standstill_shift=0.0).standstill_shift == 0.0
    assert MonitorSettings(presliding_remainder=0.0).presliding_remainder == 0.0


def test_the_bounds_grid_and_rows_answer_through_the_one_check(tmp_path: Path) -> None:
    """A grid node or a row's number that is no number >= 0 is refused naming the file, the
    row and the column with the column's unit; a null cell (not measured) is kept as NaN."""
    text = (
        "command: c\ngrid: {preload_N: [0], speed_rad_s: [1], temperature_K: [293]}\n"
        "columns: [preload_N, speed_rad_s, temperature_K, catalog_vertical.drag_torque]\n"
        "rows: [[0, 1, 293, null], [0, 1, 293, 0.25]]\nreference: {drag_torque: 0.1}\n"
        "dynamic: {step_cost_s: 1e-6}\ncost: {catalog: 1e-6}\n"
    )
    good = tmp_path / "good.yaml"
    good.write_text(text)
    bounds = load_bounds(good)
    assert bounds.grid == {"preload_N": (0.0,), "speed_rad_s": (1.0,), "temperature_K": (293.0,)}
    drag = bounds.column("catalog_vertical.drag_torque")
    assert math.isnan(drag[0]) and drag[1] == 0.25
    refusals = [
        ("[0, 1, 293, 0.25]]", "[0, -1, 293, 0.25]]", "rows[1].speed_rad_s = -1 is outside "
         "the allowed range [0, inf] rad/s (must not be negative)"),
        ("[0, 1, 293, 0.25]]", "[0, 1, 293, much]]", "rows[1].catalog_vertical.drag_torque: "
         "expected a number in - within [0, inf], got 'much'"),
        ("[0, 1, 293, 0.25]]", "[0, 1, .nan, 0.25]]", "rows[1].temperature_K: nan is not a "
         "finite number (allowed range [0, inf] K)"),
        ("temperature_K: [293]", "temperature_K: [-20]", "grid.temperature_K[0] = -20 is "
         "outside the allowed range [0, inf] K"),
        ("preload_N: [0]", "preload_N: [0, -5]", "grid.preload_N[1] = -5 is outside the "
         "allowed range [0, inf] N (must not be negative)"),
        ("[0, 1, 293, 0.25]]", "[0, 1, 293]]", "every row must have 4 values"),
        ("rows: [[0, 1, 293, null], [0, 1, 293, 0.25]]", "rows: []", "every row must have 4"),
    ]  # fmt: skip
    for old, new, message in refusals:
        bad = tmp_path / "bad.yaml"
        bad.write_text(text.replace(old, new))
        with pytest.raises(FidelityError) as err:
            load_bounds(bad)
        assert str(err.value).startswith(f"{bad}: {message}"), str(err.value)
