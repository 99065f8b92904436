"""Injected faults: growth profiles, combined state, model changes, defect kinematics, ripple."""

from __future__ import annotations

import math
import re
from dataclasses import replace

import numpy as np
import pytest

from ballscrew_twin.errors import ConfigError
from ballscrew_twin.health.fault_profiles import (
    FaultedTwin,
    FaultSpec,
    FaultState,
    apply_to_config,
    defect_frequencies,
    fault_state,
    faults_from_list,
    growth_fraction,
    ripple_torque,
)
from ballscrew_twin.models.base import OperatingPoint
from ballscrew_twin.models.steady import SteadyStateModel
from ballscrew_twin.params import load_config

CONFIG = load_config()
OP = OperatingPoint(screw_speed=10.471975511965978, temperature=293.15, preload=1500.0)


def test_growth_profiles_follow_their_closed_forms() -> None:
    t = np.array([0.0, 4.999, 5.0, 6.0, 7.0, 9.0, 100.0])
    step = FaultSpec(fault_class="raceway_defect", onset=5.0, severity=0.1, growth="step")
    np.testing.assert_array_equal(growth_fraction(step, t), [0, 0, 1, 1, 1, 1, 1])
    ramp = FaultSpec(
        fault_class="preload_loss", onset=5.0, severity=0.2, growth="ramp", growth_time=2.0
    )
    np.testing.assert_allclose(growth_fraction(ramp, t), [0, 0, 0, 0.5, 1, 1, 1])
    expo = FaultSpec(
        fault_class="jam_onset", onset=5.0, severity=4.0, growth="exponential", growth_time=2.0
    )
    expected = [0, 0, 0] + [1.0 - math.exp(-(x - 5.0) / 2.0) for x in (6.0, 7.0, 9.0, 100.0)]
    np.testing.assert_allclose(growth_fraction(expo, t), expected, rtol=1e-12)


def test_fault_state_combines_classes_and_is_healthy_before_onsets() -> None:
    faults = faults_from_list(
        [
            {"class": "preload_loss", "onset": 1.0, "severity": 0.2, "growth": "step"},
            {"class": "preload_loss", "onset": 2.0, "severity": 0.5, "growth": "step"},
            {
                "class": "lubricant_degradation",
                "onset": 1.0,
                "severity": 0.3,
                "growth": "ramp",
                "growth_time": 2.0,
                "starvation": 0.5,
                "roughness_increase": 1.0,
            },
            {"class": "jam_onset", "onset": 1.0, "severity": 4.0, "growth": "step"},
            {"class": "raceway_defect", "onset": 1.0, "severity": 0.1},
            {"class": "sphere_defect", "onset": 1.0, "severity": 0.05},
        ],
        "test",
    )
    assert fault_state(faults, 0.5) == FaultState()
    s = fault_state(faults, 2.0)  # lubricant ramp half way
    assert s.preload_factor == pytest.approx(0.8 * 0.5)
    assert s.viscosity_factor == pytest.approx(1.0 - 0.15)
    assert s.residual_layer_factor == pytest.approx(1.0 - 0.25)
    assert s.roughness_factor == pytest.approx(1.5 * 5.0)  # lubricant half way, jam
    assert s.dry_friction_factor == pytest.approx(5.0)
    assert (s.raceway_ripple, s.sphere_ripple) == pytest.approx((0.1, 0.05))


def test_apply_to_config_changes_only_the_faulted_parameters() -> None:
    state = FaultState(
        viscosity_factor=0.7,
        residual_layer_factor=0.5,
        roughness_factor=2.0,
        dry_friction_factor=3.0,
    )
    c = apply_to_config(CONFIG, state)
    lub, lub0 = c.lubricant, CONFIG.lubricant
    assert lub.viscosity_reference == pytest.approx(0.7 * lub0.viscosity_reference)
    assert lub.viscosity_second == pytest.approx(0.7 * lub0.viscosity_second)
    assert lub.residual_layer == pytest.approx(0.5 * lub0.residual_layer)
    assert c.composite_roughness == pytest.approx(2.0 * CONFIG.composite_roughness)
    assert c.contact.dry_friction_coefficient == pytest.approx(
        3.0 * CONFIG.contact.dry_friction_coefficient
    )
    assert c.screw.pitch_radius == CONFIG.screw.pitch_radius
    assert lub.eyring_stress == lub0.eyring_stress
    assert replace(apply_to_config(CONFIG, FaultState()), name=CONFIG.name) == CONFIG


def test_orbital_speed_matches_the_steady_models_solved_orbit() -> None:
    # Independent oracle: the steady model solves each sphere's orbital rate from its force and
    # moment balance (with spin and slip); pure rolling at the nominal angle is within 2 %.
    solution = SteadyStateModel(CONFIG).solve(OP)
    solved = OP.screw_speed + solution.state.kinematics[:, 0]  # absolute orbital rate [rad/s]
    f = defect_frequencies(CONFIG, OP.screw_speed)
    np.testing.assert_allclose(solved, 2.0 * math.pi * f["orbit"], rtol=0.02)


def test_defect_frequencies_from_rolling_without_slip() -> None:
    s = CONFIG.screw
    w = 20.0
    f = defect_frequencies(CONFIG, -w)  # magnitudes, either direction
    # Contact-point derivation: centre speed w_c r_m; at the nut contact (radius
    # r_m + r_b cos a from the axis) the sphere surface is at rest, so the spin is
    # w_b = w_c (r_m + r_b cos a) / r_b; at the screw contact the surface speed matches
    # the screw: (w - w_c)(r_m - r_b cos a) = w_b r_b.
    c = s.ball_radius * math.cos(s.nominal_contact_angle)
    w_c = w * (s.pitch_radius - c) / (2.0 * s.pitch_radius)  # from equating both w_b
    w_b = w_c * (s.pitch_radius + c) / s.ball_radius
    assert (w - w_c) * (s.pitch_radius - c) == pytest.approx(w_b * s.ball_radius)
    per_turn = s.balls_per_nut / s.loaded_turns
    assert f["orbit"] == pytest.approx(w_c / (2 * math.pi))
    assert f["nut_raceway"] == pytest.approx(per_turn * w_c / (2 * math.pi))
    assert f["screw_raceway"] == pytest.approx(per_turn * (w - w_c) / (2 * math.pi))
    assert f["sphere_spin"] == pytest.approx(2 * w_b / (2 * math.pi))
    assert f["nut_raceway"] / f["circulation"] == pytest.approx(s.balls_total_per_nut)
    # bearing identity: the two raceway pass frequencies add up to Z / n_t times the turn rate
    assert f["nut_raceway"] + f["screw_raceway"] == pytest.approx(per_turn * w / (2 * math.pi))


def test_raceway_ripple_is_a_line_at_the_nut_raceway_frequency() -> None:
    rate, duration, w, torque = 1000.0, 4.0, 10.0, 0.02
    t = np.arange(int(rate * duration)) / rate
    ripple = ripple_torque(
        CONFIG, t, np.full_like(t, w), np.full_like(t, torque), np.full_like(t, 0.1), 0 * t
    )
    # raised cosine of peak 0.1 |T|: mean and fundamental amplitude 0.05 |T|, never negative
    assert ripple.min() >= -1e-15
    assert ripple.max() == pytest.approx(0.1 * torque, rel=1e-3)
    assert ripple.mean() == pytest.approx(0.05 * torque, rel=0.02)
    spectrum = np.abs(np.fft.rfft(ripple - ripple.mean())) * 2.0 / len(t)
    freqs = np.fft.rfftfreq(len(t), 1.0 / rate)
    peak = freqs[np.argmax(spectrum)]
    expected = defect_frequencies(CONFIG, w)["nut_raceway"]
    assert abs(peak - expected) <= 1.0 / duration
    # negative speed: ripple opposes like the drag torque (sign of the speed)
    reverse = ripple_torque(CONFIG, t, -np.full_like(t, w), np.full_like(t, torque), 0.1, 0.0)
    np.testing.assert_allclose(reverse, -ripple)


def test_ripple_is_a_function_of_the_screw_angle_through_reversals() -> None:
    # a reversing sine of speed: the screw goes forward and back over the same angles, and a
    # sphere rolling back over a defect meets it at the same place
    rate, w_peak, frequency = 4000.0, 30.0, 0.5
    t = np.arange(int(rate / frequency)) / rate
    speed = w_peak * np.cos(2 * math.pi * frequency * t)
    angle = np.concatenate(([0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) / rate)))
    torque = 0.02 * np.sign(speed)
    for raceway, sphere in ((0.1, 0.0), (0.0, 0.1)):
        ripple = ripple_torque(CONFIG, t, speed, torque, raceway, sphere)
        relative = ripple / torque  # the raised cosine of the phase, without the drag's sign
        forward = (t > 0.05) & (t < 0.45)  # away from the reversals at 0.5 and 1.5 s
        back = (t > 0.55) & (t < 0.95)
        # at the same screw angle the ripple is the same on the way back
        on_back = np.interp(angle[forward], angle[back][::-1], relative[back][::-1])
        np.testing.assert_allclose(on_back, relative[forward], atol=0.1 * 0.02)


def test_sphere_ripple_only_while_the_sphere_is_loaded() -> None:
    rate, w = 2000.0, 20.0
    f = defect_frequencies(CONFIG, w)
    duration = 2.0 / f["circulation"]  # two trips round the circuit
    t = np.arange(int(rate * duration)) / rate
    ripple = ripple_torque(CONFIG, t, np.full_like(t, w), np.full_like(t, 0.02), 0.0, 0.1)
    loaded = ripple > 1e-12
    share = CONFIG.screw.balls_per_nut / CONFIG.screw.balls_total_per_nut
    # the spin ripple is zero only at isolated instants while loaded: the share of instants
    # with ripple is the loaded share of the circuit
    assert np.mean(loaded) == pytest.approx(share, abs=0.02)


def test_faulted_twin_equals_the_steady_model_of_the_changed_screw_and_caches() -> None:
    twin = FaultedTwin(CONFIG)
    state = FaultState(preload_factor=0.8, viscosity_factor=0.7)
    got = twin.drag_torque(OP, state)
    lub = CONFIG.lubricant
    changed = replace(
        CONFIG,
        lubricant=replace(
            lub,
            viscosity_reference=0.7 * lub.viscosity_reference,
            viscosity_second=0.7 * lub.viscosity_second,
        ),
    )
    expected = SteadyStateModel(changed).evaluate(replace(OP, preload=0.8 * OP.preload))
    assert got == pytest.approx(expected.drag_torque, rel=1e-6)
    assert twin.drag_torque(OP, state) == got
    assert twin.evaluations == 1
    healthy = twin.drag_torque(OP, FaultState())
    assert healthy == pytest.approx(SteadyStateModel(CONFIG).evaluate(OP).drag_torque, rel=1e-6)
    assert twin.evaluations == 2


@pytest.mark.parametrize(
    ("item", "match"),
    [
        ({"class": "wear", "onset": 1.0, "severity": 0.1}, r"class = 'wear' is not one of"),
        (
            {"class": "preload_loss", "onset": 1.0, "severity": 1.5, "growth": "step"},
            r"severity = 1.5 is outside the range of preload_loss",
        ),
        ({"class": "preload_loss", "onset": -1.0, "severity": 0.1}, r"onset = -1.0 is outside"),
        (
            {"class": "preload_loss", "onset": 1.0, "severity": 0.1, "growth": "ramp"},
            r"growth_time must be > 0 s",
        ),
        (
            {"class": "jam_onset", "onset": 1.0, "severity": 1.0, "growth": "sudden"},
            r"growth = 'sudden' is not one of",
        ),
        (
            {
                "class": "jam_onset",
                "onset": 1.0,
                "severity": 1.0,
                "growth": "step",
                "starvation": 0.5,
            },
            r"starvation and roughness_increase belong to lubricant_degradation",
        ),
        ({"class": "jam_onset", "onset": 1.0, "severity": 1.0, "size": 2}, r"unknown key"),
        ({"class": "jam_onset", "severity": 1.0}, r"onset"),
    ],
)
def test_fault_validation_names_file_and_field(item: dict[str, object], match: str) -> None:
    with pytest.raises(ConfigError, match=match) as err:
        faults_from_list([item], "scene.yaml: faults")
    assert "scene.yaml: faults[0]" in str(err.value)


@pytest.mark.parametrize(
    ("cls", "severity", "expected"),
    [
        ("lubricant_degradation", -0.2, "(0, 0.95]"),
        ("preload_loss", 1.5, "(0, 0.95]"),
        ("jam_onset", 12.0, "(0, 10]"),
    ],
)
def test_a_severity_outside_the_class_range_names_that_range(
    cls: str, severity: float, expected: str
) -> None:
    with pytest.raises(ConfigError, match=re.escape(expected)) as err:
        faults_from_list([{"class": cls, "onset": 1.0, "severity": severity}], "scene: faults")
    assert cls in str(err.value) and "[0, 10]" not in str(err.value)
