"""The summary of a run of the dynamic model: the paper's averages over the last window, the
energy balance that closes the torque breakdown, whether the run settled, and the steps whose
Newton iterations did not converge (SI units, JSON-ready).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..kernels.solver_settings import STEP_TOLERANCE
from ..params import TwinConfig
from .scenario import Scenario
from .simulation_result import MECHANISMS, STANDSTILL_SPEED, SimulationResult

FloatArray = NDArray[np.float64]

#: The run has settled once |screw speed - command| stays within this fraction of the command
#: [-] (with the commands no longer ramping) ...
SETTLED_SPEED = 0.01
#: ... and the mean drag of the averaging window's two halves differ by at most this fraction
#: of the window's mean drag [-].
SETTLED_DRIFT = 0.02
#: Unconverged steps listed one by one in the summary (the rest are only counted).
LISTED_UNCONVERGED = 10


def run_summary(
    result: SimulationResult,
    window: dict[str, float],
    mechanisms: FloatArray,
    nuts: FloatArray,
    abs_input_energy: float,
    wall: float,
    steps: int,
    config: TwinConfig,
) -> dict[str, Any]:
    """The paper's averages over the last window plus run statistics (SI, JSON-ready).

    drag = mean motor torque - gravity torque - I_s (Omega_end - Omega_start) / T: the mean of
    I_s dOmega/dt over the window's steps telescopes to the speed change over the window. The
    breakdown closes on it through the energy balance of everything but the screw (see
    :func:`_closure`).
    """
    sc = result.scenario
    dt = sc.time_step
    count = max(int(window["count"]), 1)
    motor = float(window["motor"]) / count
    speed = float(window["speed"]) / count
    gravity_power = float(window["gravity"]) / count
    moving = abs(speed) > STANDSTILL_SPEED
    gravity_torque = gravity_power / speed if moving else 0.0
    span = count * dt  # s: the window's steps, from the state before its first one
    start, end = sc.duration - span, sc.duration
    speeds = np.interp([start, end], result.time, result.screw_speed)
    inertia_torque = result.screw_inertia * float(speeds[1] - speeds[0]) / span
    drag = motor - gravity_torque - inertia_torque
    breakdown = {
        name: (float(value) / count / speed if moving else 0.0)
        for name, value in zip(MECHANISMS, mechanisms, strict=True)
    }
    dissipation_drag = float(sum(breakdown.values()))
    closure = _closure(result, start, end, speed if moving else math.inf)
    closure["remainder"] = drag - dissipation_drag - sum(closure.values())
    breakdown.update(closure)
    settling = _settling(result, start)
    final_error = float(result.power_balance_error[-1])
    abs_input_energy = float(abs_input_energy)
    return {
        "window_start_s": sc.duration - sc.average_window,
        "window_end_s": sc.duration,
        "mean_screw_speed_rad_s": speed,
        "mean_motor_torque_Nm": motor,
        "mean_gravitational_power_W": gravity_power,
        "gravity_torque_Nm": float(gravity_torque),
        "inertia_torque_Nm": inertia_torque,
        "drag_torque_Nm": drag,
        "dissipation_drag_Nm": dissipation_drag,
        **settling,
        "breakdown_Nm": breakdown,
        "breakdown_total_Nm": float(sum(breakdown.values())),
        "nut_torque_Nm": {
            "master": float(nuts[0]) / count / speed if moving else 0.0,
            "slave": float(nuts[1]) / count / speed if moving else 0.0,
        },
        "mean_dissipation_W": float(mechanisms.sum()) / count,
        "power_balance_error_J": final_error,
        "input_energy_J": float(result.input_energy[-1]),
        "gross_input_energy_J": abs_input_energy,
        "dissipated_energy_J": float(result.dissipated_energy[-1]),
        "power_balance_error_relative": (
            final_error / abs_input_energy if abs_input_energy > 0.0 else 0.0
        ),
        "wall_time_s": wall,
        "real_time_factor": sc.duration / wall if wall > 0.0 else math.inf,
        "steps": steps,
        "step_cost_s": wall / max(steps, 1),
        "balls_per_nut": config.screw.balls_per_nut,
        "config": config.source,
    }


def _closure(result: SimulationResult, start: float, end: float, speed: float) -> dict[str, float]:
    """The non-dissipative terms of the drag over [start, end] [s], as torques [N m].

    Energy balance of the nuts, spheres and contacts (everything but the screw): the spheres'
    torque on the screw times its speed equals the dissipation, plus the rate of their stored
    energy (kinetic energy without the screw's, elastic energy), plus the gravitational power,
    minus the preload's power F_p (v_master - v_slave). Divided by the mean speed ``speed``:
    ``stored_energy`` = change of that energy / duration / speed and ``preload_work`` = -(work
    of the preload) / duration / speed; the rest of the drag beyond these and the mechanisms
    (numerical balance error, speed fluctuation within the window) is the caller's
    ``remainder``. Values between recorded samples are interpolated linearly.
    """
    inside = (result.time > start) & (result.time < end)
    times = np.concatenate([[start], result.time[inside], [end]])

    def at(values: FloatArray) -> FloatArray:
        return np.asarray(np.interp(times, result.time, values))

    screw_kinetic = 0.5 * result.screw_inertia * result.screw_speed**2
    stored = at(result.kinetic_energy - screw_kinetic + result.elastic_energy)
    separation = at(result.nut_position[:, 0] - result.nut_position[:, 1])
    preload = at(result.preload_command)
    preload_work = float(np.sum(0.5 * (preload[1:] + preload[:-1]) * np.diff(separation)))
    duration = end - start
    return {
        "stored_energy": float(stored[-1] - stored[0]) / duration / speed,
        "preload_work": -preload_work / duration / speed,
    }


def _settling(result: SimulationResult, start: float) -> dict[str, Any]:
    """Whether the run has settled by the averaging window's ``start`` [s], since when, and the
    drag's standard deviation over the settled part of the window (recorded samples).

    Settled: the commands have stopped ramping, |screw speed - command| has stayed within
    SETTLED_SPEED of the command since ``settled_since_s``, which is before the window, and the
    mean drag of the window's two halves differ by at most SETTLED_DRIFT of the window mean.
    """
    sc = result.scenario
    t, drag = result.time, result.drag_torque
    reasons: list[str] = []
    ramps_end = max(sc.speed_ramp_end, sc.preload_ramp_end)
    tolerance = SETTLED_SPEED * max(abs(sc.speed), STANDSTILL_SPEED)
    off = (np.abs(result.screw_speed - result.speed_command) > tolerance) | (t < ramps_end)
    since: float | None = None
    if not off[-1]:
        last_off = np.flatnonzero(off)
        since = float(t[last_off[-1] + 1]) if len(last_off) else float(t[0])
    if ramps_end > start:
        reasons.append(f"the commands ramp until {ramps_end:.6g} s, inside the window")
    if since is None:
        deviation = float(np.abs(result.screw_speed - result.speed_command)[-1])
        reasons.append(
            f"the screw speed ends {deviation:.3g} rad/s from its command "
            f"(tolerance {tolerance:.3g} rad/s)"
        )
    elif since > start + 0.5 * sc.time_step:
        reasons.append(
            f"the screw speed stays within {SETTLED_SPEED:.0%} of its command only from "
            f"{since:.6g} s, inside the window"
        )
    in_window = t >= start - 0.5 * sc.time_step
    window_drag = drag[in_window]
    halves = np.array_split(window_drag, 2) if len(window_drag) >= 2 else []
    drift = abs(float(np.mean(halves[1]) - np.mean(halves[0]))) if halves else 0.0
    level = abs(float(np.mean(window_drag))) if len(window_drag) else 0.0
    if drift > SETTLED_DRIFT * level:
        reasons.append(
            f"the mean drag of the window's halves differ by {drift:.3g} N m, more than "
            f"{SETTLED_DRIFT:.0%} of its mean {level:.3g} N m"
        )
    settled_from = start if since is None else max(start, since)
    settled = t >= settled_from - 0.5 * sc.time_step
    samples = drag[settled] if settled.any() else window_drag
    return {
        "settled": not reasons,
        "settled_since_s": since,
        "not_settled_because": reasons,
        "drag_torque_std_window_s": [settled_from, sc.duration],
        "drag_torque_std_Nm": float(np.std(samples)) if len(samples) else 0.0,
        "window_drift_Nm": drift,
    }


def unconverged_summary(
    unconverged: list[tuple[int, float]], total: int, steps: int, scenario: Scenario
) -> dict[str, Any]:
    """Where the Newton iterations of a step ended above STEP_TOLERANCE (JSON-ready, SI):
    ``unconverged`` lists (step index, final scaled residual) of every such step."""
    dt = scenario.time_step
    window_first = steps - scenario.steps_per(scenario.average_window)
    return {
        "count": total,
        "steps": steps + 1,
        "in_window": sum(step >= window_first for step, _ in unconverged),
        "tolerance": STEP_TOLERANCE,
        "largest_residual": max((r for _, r in unconverged), default=0.0),
        "listed": [
            {"step": step, "time_s": step * dt, "residual": r}
            for step, r in unconverged[:LISTED_UNCONVERGED]
        ],
        "unlisted": max(len(unconverged) - LISTED_UNCONVERGED, 0),
    }
