"""How long the monitor refines the class of an alarm: a class two faults explain alike at one
operating point stays open until the operating point moves, up to the patience."""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np
import pytest

from ballscrew_twin.health.baseline import Baseline
from ballscrew_twin.health.bench_units import BenchUnit, unit_config
from ballscrew_twin.health.fault_profiles import FaultedTwin, FaultState
from ballscrew_twin.health.monitor import HealthMonitor, feed
from ballscrew_twin.health.monitor_settings import MonitorSettings
from ballscrew_twin.health.residuals import FAULT_CHANGES, UnitTwin, debris, thinner_lubricant
from ballscrew_twin.models.base import OperatingPoint
from ballscrew_twin.models.steady import SteadyStateModel
from ballscrew_twin.params import TwinConfig, load_config

from .synthetic import PRELOAD, TEMPERATURE, bench_channels

ONSET = 20.0  # s
MOVE = 32.0  # s, when the speed moves


def _steady_ratio(
    config: TwinConfig, fault: FaultState, speeds: np.ndarray, temperature: float, preload: float
) -> np.ndarray:
    """The steady model's drag with ``fault`` over its drag without, at each of ``speeds``
    [rad/s], at ``temperature`` [K] and ``preload`` [N]."""
    steady = FaultedTwin(config)
    out = []
    for speed in speeds:
        op = OperatingPoint(
            screw_speed=float(speed), temperature=temperature, preload=preload, axial_load=0.0
        )
        out.append(steady.drag_torque(op, fault) / steady.drag_torque(op, FaultState()))
    return np.array(out)


def _jam_then_a_speed_change():
    """A unit equal to the twin at 20 C / 1500 N, at 5 rad/s until MOVE, then 60 rad/s (a
    0.5 s ramp); from ONSET on a jam (mu_dry and roughness x1.5) changes its drag by the
    steady model's ratio at every speed of the way: +27 % at 5 rad/s, where a thinner oil
    also raises the torque (+27 % for a 79 % viscosity loss), and -6 % at 60 rad/s, where
    that loss raises it by 11 % (at 150 rad/s the two differ by 3 % only: -5 and -8 %).
    Torque meter 1 kHz, 0.2 mN m."""
    config = load_config(None)
    twin = UnitTwin(config)
    jam = FaultState(dry_friction_factor=1.5, roughness_factor=1.5)
    slow, fast = 5.0, 60.0
    t = np.arange(0.0, 50.0, 1e-3)
    w = slow + (fast - slow) * np.clip((t - MOVE) / 0.5, 0.0, 1.0)
    # the ratio on a fine grid of speeds: it is not monotonic in between (+1 % at 30 rad/s)
    speeds = np.geomspace(slow, fast, 40)
    change = np.interp(w, speeds, _steady_ratio(config, jam, speeds, TEMPERATURE, PRELOAD))
    drag = twin.drag(w, TEMPERATURE, PRELOAD) * np.where(t >= ONSET, change, 1.0)
    torque = drag + config.screw.screw_inertia * np.gradient(w, t)
    torque = torque + np.random.default_rng(3).normal(0.0, 2e-4, len(t))
    return config, twin, bench_channels(t, torque, w)


def test_an_unsure_class_is_refined_until_the_operating_point_moves() -> None:
    config, twin, channels = _jam_then_a_speed_change()
    monitor = HealthMonitor(config, MonitorSettings(), twin=twin)
    feed(monitor, channels)
    alarm = monitor.alarm
    assert alarm is not None and ONSET < alarm.time < ONSET + 1.0
    # at 5 rad/s a jam and a thinner oil fit alike: refined past the 8 s window ...
    unsure = [c for t, c in monitor.classifications if t < MOVE]
    assert unsure and all(c.confidence < 0.9 for c in unsure)
    # ... until 60 rad/s tells them apart
    assert alarm.final
    assert alarm.classification.fault_class == "jam_onset"
    assert alarm.classification.confidence >= 0.9
    # with no patience beyond the window the class is kept unsure
    hasty = HealthMonitor(config, MonitorSettings(classification_patience=8.0), twin=twin)
    feed(hasty, channels)
    assert hasty.alarm is not None and hasty.alarm.final
    assert hasty.alarm.classification.confidence < 0.9


#: Where :func:`_viscosity_loss_through_speed_steps` runs: the thermometer's temperature [K]
#: and the load cell's preload [N]; and the viscosity left after its loss [-].
VISCOSITY_RUN = (296.95, 760.0)
VISCOSITY_LEFT = 0.6


def _viscosity_loss_through_speed_steps(preload_scale: float = 1.0, shift: float = 0.0):
    """The twin's unit (its contact preload ``preload_scale`` x the load cell's, its
    temperature ``shift`` [K] above the thermometer's) at 23.8 C and 760 N by those, with,
    from ONSET on, 40 % of its viscosity lost (ramped in 1 s), at 29.3 rad/s for 4 s, then
    10, 68, 174 and 18.6 rad/s (3 s each, 0.3 s ramps; dev unit 8016's speeds). The
    response bends between severities: at 29.3 rad/s (no shift) a 30 % loss does not move
    the torque (-0.003 mN m) and a 40 % loss raises it by 0.08 mN m; at 18.6 rad/s they
    raise it by 0.26 and 0.42 mN m."""
    config = load_config(None)
    twin = UnitTwin(config)
    thinner = FaultState(viscosity_factor=VISCOSITY_LEFT)
    temperature, preload = VISCOSITY_RUN
    t = np.arange(0.0, 40.0, 1e-3)
    levels = [29.3, 10.0, 68.0, 174.0, 18.6]
    w = np.full(len(t), levels[0])
    for k, (before, after) in enumerate(itertools.pairwise(levels)):
        start = ONSET + 4.0 + 3.0 * k
        w = np.where(t >= start, before + (after - before) * np.clip((t - start) / 0.3, 0, 1), w)
    speeds = np.geomspace(10.0, 174.0, 40)
    grown = np.clip((t - ONSET) / 1.0, 0.0, 1.0)
    ratio = _steady_ratio(config, thinner, speeds, temperature + shift, preload * preload_scale)
    change = 1.0 + grown * (np.interp(w, speeds, ratio) - 1.0)
    drag = twin.adjusted(preload_scale, shift).drag(w, temperature, preload) * change
    torque = drag + config.screw.screw_inertia * np.gradient(w, t)
    torque = torque + np.random.default_rng(4).normal(0.0, 2e-4, len(t))
    channels = bench_channels(t, torque, w)
    stamps = channels["temperature"][0]
    channels["temperature"] = (stamps, np.full(len(stamps), temperature))
    stamps = channels["preload"][0]
    channels["preload"] = (stamps, np.full(len(stamps), preload))
    return config, twin, channels


def test_a_viscosity_loss_is_named_where_its_response_bends() -> None:
    config, twin, channels = _viscosity_loss_through_speed_steps()
    monitor = HealthMonitor(config, MonitorSettings(), twin=twin)
    feed(monitor, channels)
    alarm = monitor.alarm
    # found when the speed steps up (below, the change is within the twin's error)
    assert alarm is not None and alarm.time > ONSET
    # round 9's classifier (one secant per class, taken again near a first fit) named it
    # at 0.65 at best
    assert alarm.final
    assert alarm.classification.fault_class == "lubricant_degradation"
    assert alarm.classification.confidence >= 0.9
    assert alarm.classification.severities["lubricant_degradation"] == pytest.approx(0.4, rel=0.15)


def test_a_fault_is_judged_at_the_units_own_operating_point() -> None:
    # A unit with 30 % more contact preload and running 10 K warmer than its load cell and
    # thermometer say, as commissioning found it: the classes' responses are the twin's at
    # the unit's operating point, where its viscosity loss acts.
    config, twin, channels = _viscosity_loss_through_speed_steps(1.3, 10.0)
    unit = replace(Baseline.nominal(config), preload_scale=1.3, temperature_shift=10.0)
    monitor = HealthMonitor(config, MonitorSettings(), baseline=unit, twin=twin)
    feed(monitor, channels)
    alarm = monitor.alarm
    assert alarm is not None and alarm.final
    assert alarm.classification.fault_class == "lubricant_degradation"
    # judged at the load cell's preload and the thermometer's temperature: 0.22
    assert alarm.classification.severities["lubricant_degradation"] == pytest.approx(0.4, rel=0.15)


#: Plateau speeds of the tilted unit's duty cycle [rad/s], 2 s each, 0.2 s ramps, repeated.
TILTED_LEVELS = (10.0, 40.0, 130.0)


def _preload_loss_on_a_tilted_unit(onset: float):
    """A unit 3 % above the twin at 10 rad/s and 3 % below it at 130 rad/s (linear in log
    speed: a drag-speed curve flatter than the twin's, inside the nominal 3 % band) at 20 C /
    1500 N, cycling through :data:`TILTED_LEVELS`; from ``onset`` [s] 5 % of its preload is
    lost (ramped in 0.5 s), the drag changed by the steady model's ratio at every speed.
    Against the twin, the unit is then ~3 % low at 10 rad/s and ~7 % low at 130 rad/s.
    Torque meter 1 kHz, 0.2 mN m."""
    config = load_config(None)
    twin = UnitTwin(config)
    t = np.arange(0.0, 60.0, 1e-3)
    period = 2.2 * len(TILTED_LEVELS)
    phase = np.mod(t, period)
    w = np.full(len(t), TILTED_LEVELS[0])
    for k in range(1, len(TILTED_LEVELS)):
        before, after = TILTED_LEVELS[k - 1], TILTED_LEVELS[k]
        w = np.where(
            phase >= 2.2 * k, before + (after - before) * np.clip((phase - 2.2 * k) / 0.2, 0, 1), w
        )
    # back to the first level at the end of a period
    w = np.where(
        phase < 0.2, TILTED_LEVELS[-1] + (TILTED_LEVELS[0] - TILTED_LEVELS[-1]) * phase / 0.2, w
    )
    tilt = 1.0 - 0.03 * np.log(w / 36.0) / np.log(130.0 / 36.0)
    speeds = np.geomspace(8.0, 140.0, 30)
    lighter = _steady_ratio(config, FaultState(preload_factor=0.95), speeds, TEMPERATURE, PRELOAD)
    grown = np.clip((t - onset) / 0.5, 0.0, 1.0)
    change = 1.0 + grown * (np.interp(w, speeds, lighter) - 1.0)
    drag = twin.drag(w, TEMPERATURE, PRELOAD) * tilt * change
    torque = drag + config.screw.screw_inertia * np.gradient(w, t)
    torque = torque + np.random.default_rng(5).normal(0.0, 2e-4, len(t))
    return config, twin, bench_channels(t, torque, w)


def test_a_class_is_judged_on_the_change_since_the_runs_own_past() -> None:
    # After the onset each block is compared with what this run measured at the same
    # operating point before it (the local memory), not with the twin, whose error here
    # tilts with speed. Fitted to the residuals against the twin (the classifier before
    # this test), the same run was named preload_loss at 0.98 with a loss of 2.6 %.
    onset = 40.0
    config, twin, channels = _preload_loss_on_a_tilted_unit(onset)
    monitor = HealthMonitor(config, MonitorSettings(), twin=twin)
    feed(monitor, channels)
    alarm = monitor.alarm
    assert alarm is not None and onset < alarm.time < onset + 5.0
    assert alarm.final
    assert alarm.classification.fault_class == "preload_loss"
    assert alarm.classification.confidence >= 0.9
    assert alarm.classification.severities["preload_loss"] == pytest.approx(0.05, rel=0.2)


def test_a_fault_change_is_scaled_as_the_units_drag() -> None:
    # A unit whose drag falls off with speed faster than the twin's, as commissioning found
    # it (shape 1 - 0.6 log10(w / 30 rad/s): 1.12 x the twin at 18.6 rad/s, 0.54 x at
    # 174 rad/s, the plateaus the classified blocks lie on), loses 40 % of its viscosity: its
    # torque changes by the steady model's ratio at every speed, in its own measure. The
    # change the classifier expects of a 40 % loss at each block since the onset is that one
    # (oracle: the steady model's ratio at the block's speed x the unit's drag there), not the
    # twin's change unscaled (before round 18 of issue 13; its RMS error here was 0.74 of the
    # change's RMS, the scaled one's 0.017).
    config = load_config(None)
    twin = UnitTwin(config)
    shaped = replace(Baseline.nominal(config), shape_slope=-0.6)
    _, _, channels = _viscosity_loss_through_speed_steps()
    t, torque = channels["torque"]
    speed_t, speed = channels["speed"]
    w = np.interp(t, speed_t, speed)
    inertia = config.screw.screw_inertia * np.gradient(w, t)
    channels["torque"] = (t, (torque - inertia) * shaped.shape(w) + inertia)
    monitor = HealthMonitor(config, MonitorSettings(), baseline=shaped, twin=twin)
    feed(monitor, channels)
    alarm = monitor.alarm
    assert alarm is not None and alarm.final
    assert alarm.classification.fault_class == "lubricant_degradation"
    _, evaluated = FAULT_CHANGES["lubricant_degradation"]
    speeds, expected = [], []
    for (name, time), changes in monitor._fault_changes.items():
        if name != "lubricant_degradation" or time < ONSET + 1.5:
            continue
        inside = (t >= time - 0.05) & (t < time + 0.05)
        if np.ptp(w[inside]) > 0.0:  # a ramp: the block mean is not one speed's change
            continue
        speeds.append(float(w[inside][0]))
        expected.append(float(np.interp(1.0 - VISCOSITY_LEFT, evaluated, changes)))
    # the steady model once at each plateau speed (the blocks' speeds are the five levels)
    levels, block_level = np.unique(speeds, return_inverse=True)
    ratio = _steady_ratio(
        config, FaultState(viscosity_factor=VISCOSITY_LEFT), levels, *VISCOSITY_RUN
    )
    unit_drag = twin.drag(levels, *VISCOSITY_RUN) * shaped.shape(levels)
    true = (unit_drag * (ratio - 1.0))[block_level]
    assert len(true) > 50
    error = np.sqrt(np.mean((np.array(expected) - true) ** 2))
    assert error < 0.1 * np.sqrt(np.mean(np.square(true)))


@pytest.mark.parametrize(
    ("switches", "read_on_the_unit"),
    [
        ({"unit_friction_jam": False}, ()),
        ({"unit_friction_jam": True}, ("jam_onset",)),
        (
            {"unit_friction_responses": True, "unit_friction_jam": False},
            ("jam_onset", "lubricant_degradation"),
        ),
    ],
)
def test_the_fault_responses_may_be_read_on_the_units_commissioned_friction(
    switches: dict[str, bool], read_on_the_unit: tuple[str, ...]
) -> None:
    # Oracle: the steady model of the screw with the unit's friction as the bench units build
    # it (health/bench_units.unit_config), changed by the fault as the classifier's classes
    # say. A class read on the unit gets the change of the unit's screw (mu_dry x0.8, tau_0
    # x1.25); any other, that of the nominal screw, which differs from it.
    config = load_config(None)
    baseline = replace(Baseline.nominal(config), dry_friction_scale=0.8, eyring_scale=1.25)
    monitor = HealthMonitor(config, MonitorSettings(**switches), baseline=baseline)
    unit = unit_config(config, BenchUnit(dry_friction_scale=0.8, eyring_scale=1.25))
    op = OperatingPoint(screw_speed=4.5, temperature=270.0, preload=900.0)
    for name, change in (("jam_onset", debris), ("lubricant_degradation", thinner_lubricant)):
        predictor = monitor.fault_predictors[name]
        at = predictor._grid_point(predictor._key(op))  # where the predictor reads the change
        changes = {}
        for label, screw in (("unit", unit), ("nominal", config)):
            healthy = SteadyStateModel(screw).evaluate(at).drag_torque
            changes[label] = SteadyStateModel(change(screw, 0.3)).evaluate(at).drag_torque - healthy
        got = predictor.fault_change(name, op, 0.3)
        on_the_unit = name in read_on_the_unit
        expected = changes["unit" if on_the_unit else "nominal"]
        assert got == pytest.approx(expected, rel=1e-6), name
        assert abs(changes["unit"] - changes["nominal"]) > 0.1 * abs(expected), name
        assert (predictor is monitor.predictor) is not on_the_unit, name
