"""The steady model's centrifugal force and gyroscopic moment against the dynamic model at
speed (issue 15, item 3): ``ballscrew-twin report gaps --study dynamic``.

The steady model (section 7) adds each sphere's d'Alembert terms to its balance; they flip the
screw/nut friction order from 1000 rpm on. The dynamic model (section 10) integrates Newton-Euler
in the inertial frame and has no such terms to get wrong, so at steady rolling it is the check.
Its backward-Euler velocity step moves positions with the new velocities: the sphere centre's
velocity is the chord of its orbit, turned by half the orbital angle of a step from the tangent
the contacts are evaluated at. The resulting spurious approach rate (~ v w dt / 2) meets the
hysteresis damping (Eqs. 18-19) and shifts the screw/nut split of the normal force by a
first-order error in dt. Every quantity is therefore measured at several time steps and
extrapolated to dt -> 0 (Richardson, first order), with the observed order printed.

Quantities (master nut, loaded screw-side and nut-side contacts, means over the averaging
window and the nut's spheres): normal forces [N], contact angles [deg], friction coefficients
F_t / F_n [-], screw/nut - 1 of the friction coefficient (the friction order), and the drag
without the screw's inertia term and as dissipation over speed [N m] (the steady model's drag is
the latter by definition, section 7).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from typing import Any

from ..errors import ConfigError
from ..models.base import OperatingPoint
from ..models.scenario import Scenario
from ..models.simulation import build_config, simulate
from ..models.simulation_result import SimulationResult
from ..models.steady import SteadyStateModel
from ..params import TwinConfig, load_config
from ..units import RPM, celsius_to_kelvin
from .paper import MASTER_NUT, contact_side

#: The operating points of the check: 20 C, 1500 N (paper screw, all its spheres) [C, N, rpm].
CELSIUS = 20.0
PRELOAD = 1500.0
SPEEDS = (100.0, 1000.0, 3000.0)
#: Time steps of the dynamic runs, halving [s]; 2 us is the paper protocol's.
TIME_STEPS = (2e-6, 1e-6, 5e-7)

#: Compared quantities, in print order.
QUANTITIES = (
    "drag_Nm",
    "dissipation_drag_Nm",
    "screw_normal_force_N",
    "nut_normal_force_N",
    "normal_force_split_N",
    "screw_contact_angle_deg",
    "nut_contact_angle_deg",
    "angle_split_deg",
    "screw_friction_coefficient",
    "nut_friction_coefficient",
    "friction_order",
)


def check_scenario(
    celsius: float,
    rpm: float,
    preload: float,
    time_step: float,
    balls_per_nut: int | None = None,
    config: str | None = None,
) -> Scenario:
    """A run to steady rolling at ``celsius`` [C], ``rpm``, ``preload`` [N] with ``time_step``
    [s] (parameter file ``config``, default the shipped one): preload over 5 ms (the paper's
    ramp), speed over 5-15 ms, 40 ms in all, averages over the last 15 ms, contact states every
    0.1 ms."""
    return Scenario(
        name=f"dynamic_check_{rpm:g}rpm",
        config=config,
        balls_per_nut=balls_per_nut,
        temperature=celsius_to_kelvin(celsius),
        preload=preload,
        preload_ramp_end=5e-3,
        speed=rpm * RPM,
        speed_ramp_start=5e-3,
        speed_ramp_end=15e-3,
        duration=40e-3,
        average_window=15e-3,
        time_step=time_step,
        jacobian_interval=10,
        output_interval=1e-4,
        contact_output_interval=1e-4,
    )


def _pair(
    screw: tuple[float, float, float],
    nut: tuple[float, float, float],
    drag: float,
    dissipation_drag: float,
) -> dict[str, float]:
    """The compared quantities from (normal force [N], friction force [N], angle [rad]) of the
    loaded screw-side and nut-side contacts, the drag and the dissipated power over the speed
    [N m]."""
    mu_screw, mu_nut = screw[1] / screw[0], nut[1] / nut[0]
    return {
        "drag_Nm": drag,
        "dissipation_drag_Nm": dissipation_drag,
        "screw_normal_force_N": screw[0],
        "nut_normal_force_N": nut[0],
        "normal_force_split_N": nut[0] - screw[0],
        "screw_contact_angle_deg": math.degrees(screw[2]),
        "nut_contact_angle_deg": math.degrees(nut[2]),
        "angle_split_deg": math.degrees(screw[2] - nut[2]),
        "screw_friction_coefficient": mu_screw,
        "nut_friction_coefficient": mu_nut,
        "friction_order": mu_screw / mu_nut - 1.0,
    }


def dynamic_states(result: SimulationResult) -> dict[str, float]:
    """The compared quantities of a run: contact states averaged over the samples of the
    averaging window and the master nut's spheres (each side's loaded half groove: the larger
    mean normal force), F_t / F_n as the ratio of the means; the drag as the summary's (motor
    torque less gravity and I_s dOmega/dt) and as its mean dissipation over the mean speed
    (which leaves out the change of the stored energy, e.g. while the speed still creeps)."""
    sc = result.scenario
    window = result.contact_time >= sc.duration - sc.average_window - 0.5 * sc.time_step
    spheres = result.ball_nut == MASTER_NUT
    normal = result.normal_force[window][:, spheres].mean(axis=(0, 1))
    friction = result.friction_force[window][:, spheres].mean(axis=(0, 1))
    angle = result.contact_angle[window][:, spheres].mean(axis=(0, 1))
    sides = []
    for grooves in ((0, 1), (2, 3)):
        k = max(grooves, key=lambda j: float(normal[j]))
        sides.append((float(normal[k]), float(friction[k]), float(angle[k])))
    summary = result.summary
    return _pair(
        sides[0],
        sides[1],
        float(summary["drag_torque_Nm"]),
        float(summary["dissipation_drag_Nm"]),
    )


def steady_states(config: TwinConfig, op: OperatingPoint, inertial_terms: bool) -> dict[str, float]:
    """The compared quantities of the steady model (compiled backend, symmetric mode), with or
    without the spheres' centrifugal force and gyroscopic moment."""
    output = SteadyStateModel(config, inertial_terms=inertial_terms).evaluate(op)
    contacts = output.contacts
    assert contacts is not None
    sides = []
    for side in ("screw", "nut"):
        values = contact_side(contacts, MASTER_NUT, side)
        sides.append(
            (
                float(values[f"{side}_normal_force_N"]),
                float(values[f"{side}_friction_force_N"]),
                float(values[f"{side}_contact_angle_rad"]),
            )
        )
    return _pair(sides[0], sides[1], output.drag_torque, output.drag_torque)


def richardson(values: Sequence[float]) -> tuple[float, float]:
    """Limit dt -> 0 of values at halving steps (first-order Richardson on the two finest:
    2 f(h) - f(2h)) and the observed order log2((f(4h) - f(2h)) / (f(2h) - f(h))) (NaN with
    fewer than three steps or a non-monotone sequence) [-]."""
    if len(values) < 2:
        raise ConfigError("extrapolation needs at least two time steps")
    limit = 2.0 * values[-1] - values[-2]
    order = math.nan
    if len(values) >= 3:
        coarse, fine = values[-3] - values[-2], values[-2] - values[-1]
        if fine != 0.0 and coarse / fine > 0.0:
            order = math.log2(coarse / fine)
    return limit, order


def check_speed(
    celsius: float,
    rpm: float,
    preload: float,
    time_steps: Sequence[float] = TIME_STEPS,
    balls_per_nut: int | None = None,
    config_file: str | None = None,
) -> dict[str, Any]:
    """Dynamic runs at ``time_steps`` (halving) [s], their extrapolation to dt -> 0, and the
    steady model with and without inertial terms at one operating point (JSON-ready)."""
    runs = []
    for dt in time_steps:
        scenario = check_scenario(celsius, rpm, preload, dt, balls_per_nut, config_file)
        started = time.process_time()
        result = simulate(scenario)
        runs.append(
            {
                "time_step_s": dt,
                "cpu_s": time.process_time() - started,
                "settled": bool(result.summary["settled"]),
                "not_settled_because": result.summary["not_settled_because"],
                "unconverged_steps": int(result.summary["unconverged_steps"]),
                "states": dynamic_states(result),
            }
        )
    limits = {q: richardson([float(run["states"][q]) for run in runs]) for q in QUANTITIES}
    config = build_config(
        check_scenario(celsius, rpm, preload, time_steps[0], balls_per_nut, config_file)
    )
    op = OperatingPoint(
        screw_speed=rpm * RPM, temperature=celsius_to_kelvin(celsius), preload=preload
    )
    return {
        "temperature_C": celsius,
        "speed_rpm": rpm,
        "preload_N": preload,
        "balls_per_nut": config.screw.balls_per_nut,
        "dynamic": runs,
        "extrapolated": {q: value for q, (value, _) in limits.items()},
        "observed_order": {q: order for q, (_, order) in limits.items()},
        "steady": steady_states(config, op, inertial_terms=True),
        "steady_without_inertia": steady_states(config, op, inertial_terms=False),
    }


def _cell(quantity: str, value: float) -> str:
    if quantity.endswith("drag_Nm"):
        return f"{value * 1e3:10.4f}"
    if quantity in ("friction_order",):
        return f"{value:+10.2e}"
    if quantity.endswith("coefficient"):
        return f"{value:10.6f}"
    return f"{value:10.4f}"


def print_check(entry: dict[str, Any]) -> None:
    """One speed's table: a column per dynamic step, the extrapolation and its order, the steady
    model with and without inertial terms (drag in N mm)."""
    runs = entry["dynamic"]
    print(
        f"{entry['temperature_C']:g} C, {entry['speed_rpm']:g} rpm, {entry['preload_N']:g} N, "
        f"{entry['balls_per_nut']} spheres per nut; dynamic runs (CPU s, settled, unconverged "
        "steps): "
        + ", ".join(
            f"{run['time_step_s'] * 1e6:g} us ({run['cpu_s']:.0f}, {run['settled']}, "
            f"{run['unconverged_steps']})"
            for run in runs
        )
    )
    header = "".join(
        f"{'dyn ' + format(run['time_step_s'] * 1e6, 'g') + ' us':>11s}" for run in runs
    )
    print(
        f"  {'quantity':28s}{header}{'dt -> 0':>11s}{'order':>7s}{'steady':>11s}{'no inertia':>11s}"
    )
    for q in QUANTITIES:
        cells = "".join(" " + _cell(q, run["states"][q]) for run in runs)
        print(
            f"  {q:28s}{cells} {_cell(q, entry['extrapolated'][q])}"
            f"{entry['observed_order'][q]:7.2f} {_cell(q, entry['steady'][q])}"
            f" {_cell(q, entry['steady_without_inertia'][q])}"
        )


def run_dynamic(
    quick: bool, balls_per_nut: int | None = None, config_file: str | None = None
) -> list[dict[str, Any]]:
    """``--study dynamic``: :data:`SPEEDS` at :data:`CELSIUS` and :data:`PRELOAD` (``quick``:
    3000 rpm only, two steps); with ``balls_per_nut`` the preload is scaled to keep each
    sphere's load."""
    speeds = SPEEDS[-1:] if quick else SPEEDS
    steps = TIME_STEPS[:2] if quick else TIME_STEPS
    preload = PRELOAD
    if balls_per_nut is not None:
        preload = scaled_preload(load_config(config_file), balls_per_nut)
    report = []
    for rpm in speeds:
        entry = check_speed(CELSIUS, rpm, preload, steps, balls_per_nut, config_file)
        print_check(entry)
        report.append(entry)
    return report


def scaled_preload(config: TwinConfig, balls_per_nut: int, preload: float = PRELOAD) -> float:
    """The preload [N] that gives each of ``balls_per_nut`` spheres the load it carries in
    ``config``'s screw at ``preload`` [N]."""
    return preload * balls_per_nut / config.screw.balls_per_nut
