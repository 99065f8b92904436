"""Recorded bench bags generated from the twin, with sensor models and injected faults, and
their ground truth (the command: :mod:`ballscrew_twin.commands.bench_data`).

How a bag is made (:func:`generate`): the operating profile gives the true speed, temperature
and set preload; the steady-state model, with the fault state of each instant applied
(:mod:`~ballscrew_twin.health.fault_profiles`), gives the drag torque on a grid of spacing
``model_step`` plus every profile corner and fault onset (a step fault is evaluated just
before and at its onset), linearly interpolated to the torque meter's sampling instants;
defect ripple and the screw's inertia torque I_s dw/dt (with the drive's speed ripple) are
added at those instants; then each sensor model (:mod:`~ballscrew_twin.health.sensors`)
samples its own signal. One ``numpy`` generator seeded with the seed draws all noise in a
fixed order, and the bag starts at the fixed time :data:`START_NS`, so a seed reproduces a bag.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import ConfigError
from ..models.base import OperatingPoint
from ..params import TwinConfig, load_config
from .bench_scene import BenchScene
from .bench_units import BenchUnit, UnitTorqueTable, presliding_reference
from .duty_cycles import Trajectory
from .fault_profiles import (
    FaultedTwin,
    FaultSpec,
    FaultState,
    defect_frequencies,
    fault_state,
    faults_from_list,
    growth_fraction,
    ripple_torque,
)
from .sensors import (
    Encoder,
    SensorSet,
    cumulative_angle,
    measure,
    quantise,
    sample_times,
    speed_with_ripple,
)

FloatArray = NDArray[np.float64]

#: Log time of the first sample of every generated bag [ns] (2023-11-14 22:13:20 UTC).
START_NS = 1_700_000_000 * 10**9
#: A step fault is also evaluated this long before its onset [s], so that interpolation keeps
#: the step sharp.
STEP_EDGE = 1e-6
#: Names of the sample bags (scene ``config/bench_scenes/<name>.yaml``).
SAMPLE_NAMES = (
    "healthy",
    "preload_loss",
    "lubricant_degradation",
    "raceway_defect",
    "sphere_defect",
    "jam_onset",
)
REPO_ROOT = Path(__file__).resolve().parents[2]
SCENE_DIR = REPO_ROOT / "config" / "bench_scenes"
SAMPLE_DIR = REPO_ROOT / "data" / "samples"


@dataclass(frozen=True)
class BenchData:
    """A generated recording: the twin's truth on its grid and every sensor's samples (SI).

    Attributes:
        scene: the scene (None for a duty cycle of a drawn unit, :func:`generate_unit_data`).
        seed: seed of the noise.
        model_time: instants of the twin's evaluations [s].
        model_torque: drag torque of the (faulted) twin there, without ripple [N m].
        torque_time, torque: torque-meter samples [s], [N m].
        speed_time, speed, angle: encoder samples [s], [rad/s], [rad].
        temperature_time, temperature, temperature_variance: thermometer [s], [K], [K^2].
        preload_time, preload: load cell [s], [N].
        truth: the ground truth (JSON-ready).
    """

    scene: BenchScene | None
    seed: int
    model_time: FloatArray
    model_torque: FloatArray
    torque_time: FloatArray
    torque: FloatArray
    speed_time: FloatArray
    speed: FloatArray
    angle: FloatArray
    temperature_time: FloatArray
    temperature: FloatArray
    temperature_variance: FloatArray
    preload_time: FloatArray
    preload: FloatArray
    truth: dict[str, Any]

    @property
    def name(self) -> str:
        """Name of the recording (the scene's, or the truth's)."""
        return self.scene.name if self.scene is not None else str(self.truth.get("scene", ""))

    @property
    def duration(self) -> float:
        """Length of the recording [s]."""
        return float(self.truth["duration_s"])

    @property
    def faults(self) -> tuple[FaultSpec, ...]:
        """The injected faults."""
        if self.scene is not None:
            return self.scene.faults
        return faults_from_list(
            [
                {
                    "class": f["class"],
                    "onset": f["onset_s"],
                    "severity": f["severity"],
                    "growth": f["growth"],
                    "growth_time": f["growth_time_s"],
                }
                for f in self.truth["faults"]
            ],
            "truth",
        )


def model_grid(scene: BenchScene) -> FloatArray:
    """Instants [s] where the twin is evaluated: a regular grid of ``model_step``, the profile
    corners and fault ramp ends, and both sides of each step fault's onset."""
    regular = np.arange(0.0, scene.duration, scene.model_step)
    extra = [scene.breakpoints()]
    for spec in scene.faults:
        if spec.growth == "step" and spec.onset > STEP_EDGE:
            extra.append(np.array([spec.onset - STEP_EDGE]))
    return np.unique(np.concatenate([regular, *extra]))


def _check_nyquist(scene: BenchScene, config: TwinConfig) -> None:
    """ConfigError when a defect ripple is faster than half the torque meter's rate."""
    top_speed = max(abs(p.speed) for p in scene.profile)
    freqs = defect_frequencies(config, top_speed)
    key = {"raceway_defect": "nut_raceway", "sphere_defect": "sphere_spin"}
    nyquist = 0.5 * scene.sensors.torque.rate
    for spec in scene.faults:
        if spec.fault_class in key and freqs[key[spec.fault_class]] >= nyquist:
            raise ConfigError(
                f"{scene.source}: {spec.fault_class} ripple at {freqs[key[spec.fault_class]]:.4g}"
                f" Hz (speed {top_speed:.4g} rad/s) is not below half the torque meter's rate "
                f"({nyquist:.4g} Hz); raise sensors.torque.rate"
            )


#: Progress of a generation: (instants of the twin evaluated, of all) [-].
Progress = Callable[[int, int], None]


def _model_torque(
    scene: BenchScene, config: TwinConfig, grid: FloatArray, on_progress: Progress | None
) -> FloatArray:
    """Drag torque of the faulted twin at the instants of ``grid`` [N m]."""
    twin = FaultedTwin(config)
    speed, temperature, preload = scene.profile_at(grid)
    out = np.empty_like(grid)
    for i in range(len(grid)):
        op = OperatingPoint(
            screw_speed=float(speed[i]),
            temperature=float(temperature[i]),
            preload=float(preload[i]),
        )
        out[i] = twin.drag_torque(op, fault_state(scene.faults, float(grid[i])))
        if on_progress is not None:
            on_progress(i + 1, len(grid))
    return out


def _ripple_amplitudes(
    faults: tuple[FaultSpec, ...], time: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Relative ripple amplitudes s g(t) of raceway and sphere defects at ``time`` [-]."""
    raceway = np.zeros_like(time)
    sphere = np.zeros_like(time)
    for spec in faults:
        if spec.fault_class == "raceway_defect":
            raceway += spec.severity * growth_fraction(spec, time)
        elif spec.fault_class == "sphere_defect":
            sphere += spec.severity * growth_fraction(spec, time)
    return raceway, sphere


def _sample_times(sensors: SensorSet, duration: float) -> dict[str, FloatArray]:
    """Sampling instants [s] of every sensor over ``duration`` [s]."""
    return {
        name: sample_times(getattr(sensors, name).rate, duration)
        for name in ("torque", "speed", "temperature", "preload")
    }


def _drive(
    fine: FloatArray, nominal: FloatArray, encoder: Encoder
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The drive's true speed with its ripple [rad/s], the screw angle [rad] and the
    acceleration [rad/s^2] on the instants ``fine`` [s], from the ``nominal`` speed."""
    speed = speed_with_ripple(
        nominal, cumulative_angle(fine, nominal), encoder.ripple, encoder.ripple_order
    )
    angle = cumulative_angle(fine, speed)
    acceleration = np.gradient(speed, fine) if len(fine) > 1 else np.zeros_like(fine)
    return speed, angle, acceleration


def _slow_readings(
    sensors: SensorSet,
    times: dict[str, FloatArray],
    speed: FloatArray,
    angle: FloatArray,
    true_temperature: FloatArray,
    set_preload: FloatArray,
    rng: np.random.Generator,
) -> dict[str, FloatArray]:
    """Encoder, thermometer and load-cell readings (the :class:`BenchData` fields) from the
    true values at each sensor's instants; the noise is drawn in this order, after the torque
    meter's, so that a seed reproduces a bag."""
    enc, th, cell = sensors.speed, sensors.temperature, sensors.preload
    t_temp = times["temperature"]
    return {
        "speed_time": times["speed"],
        "speed": measure(speed, enc.noise, 0.0, 0.0, rng),
        "angle": quantise(angle, enc.angle_resolution),
        "temperature_time": t_temp,
        "temperature": measure(
            true_temperature + th.drift * t_temp, th.noise, 0.0, th.resolution, rng
        ),
        "temperature_variance": np.full_like(t_temp, th.noise**2),
        "preload_time": times["preload"],
        "preload": measure(set_preload, cell.noise, cell.bias, cell.resolution, rng),
    }


def generate(
    scene: BenchScene, seed: int | None = None, on_progress: Progress | None = None
) -> BenchData:
    """A recording of ``scene`` (see the module docstring); ``seed`` None: the scene's;
    ``on_progress`` is told how far the twin's evaluations are."""
    config = load_config(scene.config_path())
    _check_nyquist(scene, config)
    seed = scene.seed if seed is None else seed
    if seed < 0:
        raise ConfigError(f"seed = {seed} must be >= 0")
    rng = np.random.default_rng(seed)
    sensors = scene.sensors
    grid = model_grid(scene)
    grid_torque = _model_torque(scene, config, grid, on_progress)

    times = _sample_times(sensors, scene.duration)
    # The drive's true speed and angle on the union of the torque and encoder instants.
    fine = np.union1d(times["torque"], times["speed"])
    speed, angle, acceleration = _drive(fine, scene.profile_at(fine)[0], sensors.speed)

    # Torque meter: drag (interpolated) + defect ripple + inertia torque.
    tt = times["torque"]
    on_torque = np.searchsorted(fine, tt)
    drag = np.interp(tt, grid, grid_torque)
    raceway, sphere = _ripple_amplitudes(scene.faults, tt)
    ripple = ripple_torque(config, tt, speed[on_torque], drag, raceway, sphere)
    inertia = config.screw.screw_inertia * acceleration[on_torque]
    meter = sensors.torque
    torque = measure(drag + ripple + inertia, meter.noise, meter.bias, meter.resolution, rng)

    # Encoder, thermometer and load cell.
    on_speed = np.searchsorted(fine, times["speed"])
    slow = _slow_readings(
        sensors,
        times,
        speed[on_speed],
        angle[on_speed],
        scene.profile_at(times["temperature"])[1],
        scene.profile_at(times["preload"])[2],
        rng,
    )

    truth = {
        "seed": int(seed),
        "scene": scene.name,
        "scene_file": Path(scene.source).name if scene.source else "",
        "duration_s": scene.duration,
        "start_ns": START_NS,
        "model": "steady",
        "config": config.name,
        "sensors": sensors.to_dict(),
        "faults": [spec.to_truth() for spec in scene.faults],
    }
    return BenchData(
        scene=scene,
        seed=int(seed),
        model_time=grid,
        model_torque=grid_torque,
        torque_time=tt,
        torque=torque,
        **slow,
        truth=truth,
    )


#: Growth fractions g at which a unit's model-changing fault (viscosity loss, debris) is
#: tabulated; the torque is linear in g in between.
FAULT_GROWTH_NODES = (0.0, 0.25, 0.5, 0.75, 1.0)
#: Fault classes that change the unit's parameter set (the others act on the operating point
#: or add ripple).
MODEL_CHANGING = ("lubricant_degradation", "jam_onset")


def _node_states(faults: tuple[FaultSpec, ...]) -> tuple[FaultSpec | None, list[FaultState]]:
    """The one model-changing fault of ``faults`` and its state at each growth node."""
    changing = [f for f in faults if f.fault_class in MODEL_CHANGING]
    if len(changing) > 1:
        raise ConfigError("a unit recording takes at most one lubricant or jam fault")
    if not changing:
        return None, [FaultState()]
    spec = changing[0]
    states = []
    for g in FAULT_GROWTH_NODES:
        at_g = FaultSpec(
            fault_class=spec.fault_class,
            onset=0.0,
            severity=spec.severity,
            growth="ramp",
            growth_time=1.0,
            starvation=spec.starvation,
            roughness_increase=spec.roughness_increase,
        )
        states.append(fault_state((at_g,), g))
    return spec, states


def preload_factor(faults: tuple[FaultSpec, ...], time: FloatArray) -> FloatArray:
    """Contact preload over its healthy value at ``time`` [s] under preload-loss faults [-]."""
    out = np.ones_like(time)
    for spec in faults:
        if spec.fault_class == "preload_loss":
            out *= 1.0 - spec.severity * growth_fraction(spec, time)
    return out


def unit_table_for(
    config: TwinConfig,
    unit: BenchUnit,
    trajectory: Trajectory,
    faults: tuple[FaultSpec, ...] = (),
) -> UnitTorqueTable:
    """The torque table of ``unit`` covering ``trajectory`` (and the model changes of
    ``faults``)."""
    _, states = _node_states(faults)
    contact = unit.preload_scale * trajectory.preload
    low = float(np.min(contact)) * min(1.0, float(np.min(preload_factor(faults, trajectory.time))))
    return UnitTorqueTable(
        config,
        unit,
        (float(np.min(trajectory.temperature)), float(np.max(trajectory.temperature))),
        (low, float(np.max(contact))),
        tuple(states),
    )


def unit_drag_torque(
    table: UnitTorqueTable,
    time: FloatArray,
    speed: FloatArray,
    angle: FloatArray,
    temperature: FloatArray,
    set_preload: FloatArray,
    faults: tuple[FaultSpec, ...],
    compiled: bool = True,
) -> FloatArray:
    """Friction torque of a unit along a trajectory [N m]: its steady torque (own parameters,
    Stribeck rise, faults) lagged by its Dahl presliding over the screw ``angle`` [rad]."""
    unit = table.unit
    contact = unit.preload_scale * set_preload * preload_factor(faults, time)
    spec, states = _node_states(faults)
    if spec is None:
        steady = table.steady_torque(speed, temperature, contact)
    else:
        g = growth_fraction(spec, time)
        nodes = np.array(FAULT_GROWTH_NODES)
        per_node = np.stack(
            [table.steady_torque(speed, temperature, contact, [st] * len(time)) for st in states]
        )
        upper = np.clip(np.searchsorted(nodes, g, side="right"), 1, len(nodes) - 1)
        weight = (g - nodes[upper - 1]) / (nodes[upper] - nodes[upper - 1])
        cols = np.arange(len(time))
        steady = per_node[upper - 1, cols] * (1.0 - weight) + per_node[upper, cols] * weight
    if unit.presliding_angle <= 0.0:
        return steady
    if compiled:
        from ..kernels.presliding import presliding_lag

        return np.asarray(presliding_lag(steady, angle, unit.presliding_angle, float(steady[0])))
    return presliding_reference(steady, angle, unit.presliding_angle)


def generate_unit_data(
    config: TwinConfig,
    unit: BenchUnit,
    trajectory: Trajectory,
    *,
    faults: tuple[FaultSpec, ...] = (),
    sensors: SensorSet | None = None,
    seed: int = 0,
    table: UnitTorqueTable | None = None,
    name: str = "unit",
) -> BenchData:
    """A recording of ``unit`` (not the twin: :mod:`.units`) driven through ``trajectory``.

    The torque meter reads gain (drag + ripple + J_unit dw/dt) + bias + noise; the encoder,
    thermometer and load cell are those of ``sensors``; ``table`` reuses a unit table built by
    :func:`unit_table_for` (it must cover the trajectory and the faults).
    """
    sensors = sensors or SensorSet()
    for spec in faults:
        if spec.onset >= trajectory.duration:
            raise ConfigError(f"fault {spec.fault_class}: onset {spec.onset} s after the end")
    table = table or unit_table_for(config, unit, trajectory, faults)
    rng = np.random.default_rng(seed)
    duration = trajectory.duration
    times = _sample_times(sensors, duration)
    fine = trajectory.time
    speed, angle, acceleration = _drive(fine, trajectory.speed, sensors.speed)

    tt = times["torque"]
    w_t = np.interp(tt, fine, speed)
    a_t = np.interp(tt, fine, angle)
    temperature_t = np.interp(tt, fine, trajectory.temperature)
    preload_t = np.interp(tt, fine, trajectory.preload)
    drag = unit_drag_torque(table, tt, w_t, a_t, temperature_t, preload_t, faults)
    raceway, sphere = _ripple_amplitudes(faults, tt)
    ripple = ripple_torque(config, tt, w_t, drag, raceway, sphere)
    inertia = unit.inertia_scale * config.screw.screw_inertia * np.interp(tt, fine, acceleration)
    meter = sensors.torque
    torque = measure(
        unit.torque_gain * (drag + ripple + inertia),
        meter.noise,
        meter.bias + unit.torque_bias,
        meter.resolution,
        rng,
    )

    ts = times["speed"]
    slow = _slow_readings(
        sensors,
        times,
        np.interp(ts, fine, speed),
        np.interp(ts, fine, angle),
        np.interp(times["temperature"], fine, trajectory.temperature),
        np.interp(times["preload"], fine, trajectory.preload),
        rng,
    )
    truth = {
        "seed": int(seed),
        "scene": name,
        "scene_file": "",
        "duration_s": duration,
        "start_ns": START_NS,
        "model": "unit",
        "unit": unit.to_dict(),
        "duty_cycle": [list(seg) for seg in trajectory.segments],
        "config": config.name,
        "sensors": sensors.to_dict(),
        "faults": [spec.to_truth() for spec in faults],
    }
    return BenchData(
        scene=None,
        seed=int(seed),
        model_time=tt,
        model_torque=drag,
        torque_time=tt,
        torque=torque,
        **slow,
        truth=truth,
    )
