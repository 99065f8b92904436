"""The steady model's outputs: a solved state turned into a :class:`SteadySolution`.

:func:`assemble` sums the contacts of the readable backends in numpy (mechanism powers over the
speed, nut torques, the direct moment on the screw, gravity's power, :func:`contact_states`);
:func:`assemble_compiled` takes the same sums from the compiled solver, which took them in its
call, and makes the per-contact states views of its rows when a caller first reads one
(:func:`ballscrew_twin.models.base.contact_states_from_rows`). The notes depend on the mode, the
temperature and whether the screw stands, and are kept (:func:`fixed_notes`). Units: SI (N m,
W).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from ..physics import geometry
from ..physics.contact_types import ContactEvaluation, ContactScene
from .base import (
    MECHANISMS,
    ContactStates,
    OperatingPoint,
    TorqueBreakdown,
    TwinOutput,
    contact_states_from_rows,
    filled,
)
from .steady_problem import nut_gravity_power, potential_energy_rate, spacing_notes
from .steady_types import BallSet, ContactSource, SteadySolution, SteadyState, kept

if TYPE_CHECKING:
    from ..kernels.steady_solver import KernelSolution
    from .steady import SteadyStateModel

FloatArray = NDArray[np.float64]


def assemble(
    model: SteadyStateModel,
    op: OperatingPoint,
    mode: str,
    scene: ContactScene,
    balls: BallSet,
    state: SteadyState,
    ev: ContactSource,
    iterations: int,
    residual: float,
) -> SteadySolution:
    if not isinstance(ev, ContactEvaluation):
        return assemble_compiled(model, op, mode, scene, balls, state, ev, iterations, residual)
    weight = balls.weight[:, None]
    speed = op.screw_speed
    power = {m: float(np.sum(ev.dissipation[m] * weight)) for m in MECHANISMS}
    sphere_power = np.sum([ev.dissipation[m] for m in MECHANISMS], axis=(0, 2)) * balls.weight
    per_nut_power = [float(np.sum(sphere_power[balls.nut == k])) for k in (0, 1)]
    if speed == 0.0:
        breakdown = TorqueBreakdown()
        nut_torque = (0.0, 0.0)
        total = 0.0
    else:
        breakdown = TorqueBreakdown(**{m: power[m] / speed for m in MECHANISMS})
        nut_torque = (per_nut_power[0] / speed, per_nut_power[1] / speed)
        total = breakdown.total
    screw_side = ~geometry.IS_NUT[None, :]
    direct = -float(np.sum(np.where(screw_side, ev.groove_moment_z, 0.0) * weight))
    lift_power = potential_energy_rate(model.config, scene, balls, state)
    gravity_torque = lift_power / speed if speed != 0.0 else 0.0
    contacts = contact_states(balls.nut, ev)
    output = TwinOutput(
        drag_torque=total,
        nut_torque=nut_torque,
        breakdown=breakdown,
        fidelity=f"{model.name}-{mode}",
        operating_point=op,
        contacts=contacts,
        notes=fixed_notes(model, mode, scene, len(balls.nut)),
    )
    return SteadySolution(
        output=output,
        state=state,
        balls=balls,
        contact_source=ev,
        screw_torque_direct=direct,
        gravity_torque=gravity_torque,
        iterations=iterations,
        residual=residual,
    )


def assemble_compiled(
    model: SteadyStateModel,
    op: OperatingPoint,
    mode: str,
    scene: ContactScene,
    balls: BallSet,
    state: SteadyState,
    solved: KernelSolution,
    iterations: int,
    residual: float,
) -> SteadySolution:
    """:func:`assemble` from the compiled solver's own summary of the solution (the same
    sums, taken in the kernel) and its per-contact states (views of one array)."""
    results = model._results  # kernels.steady_results, imported with the compiled solver
    summary = solved.summary.tolist()
    speed = op.screw_speed
    # The kernel divided the powers by the speed (zero at standstill), as assemble does,
    # and summed the mechanisms in their order, as TorqueBreakdown.total does.
    torque = results.SUMMARY_TORQUE
    breakdown = filled(
        TorqueBreakdown,
        lubricant_shear=summary[torque],
        dry_contact=summary[torque + 1],
        rolling_resistance=summary[torque + 2],
        hysteresis=summary[torque + 3],
        curvature=summary[torque + 4],
        spin=summary[torque + 5],
    )
    nut = results.SUMMARY_NUT_TORQUE
    lift_power = -(summary[results.SUMMARY_BALLS_POWER] + nut_gravity_power(model.config, scene))
    output = filled(
        TwinOutput,
        drag_torque=summary[results.SUMMARY_DRAG],
        nut_torque=(summary[nut], summary[nut + 1]),
        breakdown=breakdown,
        fidelity=f"{model.name}-{mode}",
        operating_point=op,
        contacts=kernel_contact_states(model, mode, balls, solved),
        notes=fixed_notes(model, mode, scene, len(balls.nut)),
    )
    return filled(
        SteadySolution,
        output=output,
        state=state,
        balls=balls,
        contact_source=solved,
        screw_torque_direct=summary[results.SUMMARY_DIRECT],
        gravity_torque=lift_power / speed if speed != 0.0 else 0.0,
        iterations=iterations,
        residual=residual,
    )


def kernel_contact_states(
    model: SteadyStateModel, mode: str, balls: BallSet, solved: KernelSolution
) -> ContactStates:
    """:func:`contact_states` of the compiled solver's state rows (no copies; the index
    arrays, the same for every solve of a mode, are shared and read-only)."""
    index = model._contact_index.get(mode)
    if index is None:
        count = len(balls.nut)
        index = (
            np.repeat(np.arange(count), 4),
            np.repeat(balls.nut, 4),
            np.tile(np.arange(4), count),
        )
        for array in index:
            array.flags.writeable = False
        model._contact_index[mode] = index
    sphere, nut, half_groove = index
    in_contact = solved.active.reshape(-1)
    rows = model._results.STATE_ROWS
    return contact_states_from_rows(sphere, nut, half_groove, in_contact, solved.states, rows)


def fixed_notes(
    model: SteadyStateModel, mode: str, scene: ContactScene, count: int
) -> tuple[str, ...]:
    """The notes of :func:`assemble` (they depend on the mode, the temperature and
    whether the screw stands), kept per temperature."""
    key = (mode, scene.temperature, scene.screw_speed == 0.0)
    notes = model._notes.get(key)
    if notes is None:
        lines = [f"steady state, {mode} mode ({count} spheres solved)"]
        if not model.inertial_terms:
            lines.append("centrifugal force and gyroscopic moment of the spheres dropped")
        if scene.screw_speed == 0.0:
            lines.append("zero speed: nothing slides, drag torque 0 (breakaway not modelled)")
        lines.extend(spacing_notes(model.config, scene))
        notes = kept(model._notes, key, tuple(lines))
    return notes


def contact_states(ball_nut: NDArray[np.int64], ev: ContactEvaluation) -> ContactStates:
    """Flatten (B, 4) contact arrays into one row per sphere and half groove (``ball_nut``:
    each sphere's nut, 0 master or 1 slave; what no contact carries is 0). The steady and the
    dynamic model both report their contacts through it."""
    count = len(ball_nut)
    rows = count * 4
    friction = ev.friction_lubricant + ev.friction_dry
    safe = np.where(friction > 0.0, friction, 1.0)
    lub_share = np.where(friction > 0.0, ev.friction_lubricant / safe, 0.0)
    hc = ev.hertz
    active = ev.active

    def flat(a: FloatArray) -> FloatArray:
        return np.asarray(np.where(active, a, 0.0).reshape(rows), dtype=np.float64)

    return ContactStates(
        sphere=np.repeat(np.arange(count), 4),
        nut=np.repeat(ball_nut, 4),
        half_groove=np.tile(np.arange(4), count),
        in_contact=active.reshape(rows),
        normal_force=flat(hc.stiffness * np.maximum(ev.approach, 0.0) ** 1.5),
        friction_force=flat(friction),
        contact_angle=np.asarray(ev.contact_angle.reshape(rows)),
        approach=flat(ev.approach),
        stiffness=np.asarray(hc.stiffness.reshape(rows)),
        max_pressure=flat(hc.max_pressure),
        semi_axis_x=flat(hc.semi_axis_x),
        semi_axis_y=flat(hc.semi_axis_y),
        film_thickness=flat(ev.film_total),
        tallian_parameter=flat(ev.tallian),
        load_share=flat(ev.load_share),
        shear_stress=flat(ev.shear_stress),
        lubricant_share=flat(lub_share),
        dry_share=flat(np.where(friction > 0.0, 1.0 - lub_share, 0.0)),
        slip_speed=flat(ev.slip),
    )
