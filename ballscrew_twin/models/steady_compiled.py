"""The steady model's side of the compiled solver: its Newton call and its predicted start.

:func:`newton_compiled` runs :func:`ballscrew_twin.kernels.steady_solver.solve_compiled` from a
state, keeping the sphere Jacobian blocks of the last solve on the model for the next warm solve
(chord steps) and the kernel's inputs per scene and loads (:func:`kernel_inputs`: residual
scales and the scene parameters, those per temperature and speed, :func:`kernel_parameters`);
:func:`predicted_start` extrapolates a warm start from the model's
last two solutions. Units: SI (m, rad/s, N, K).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from ..errors import SolverError
from ..physics.contact_types import ContactScene
from .base import OperatingPoint
from .steady_problem import residual_scales
from .steady_types import BallSet, SteadyState, kept

if TYPE_CHECKING:
    from ..kernels.steady_solver import KernelSolution
    from .steady import SteadyStateModel

FloatArray = NDArray[np.float64]

#: Step of each operating quantity that counts as one unit when the warm start is extrapolated
#: from the last two solutions (:func:`predicted_start`): 1 % of the speed, 0.1 K, 1 % of the
#: preload (at least 0.1 N) and 1 % of the axial load (at least 0.1 N).
PREDICTOR_UNITS = (0.01, 0.1, 0.01, 0.01)
#: Extrapolation along the last two solutions is limited to this range of their step [-].
PREDICTOR_RANGE = (-1.0, 2.0)


def newton_compiled(
    model: SteadyStateModel,
    scene: ContactScene,
    balls: BallSet,
    state: SteadyState,
    loads: FloatArray,
    warm: bool,
    polished: bool,
    max_iterations: int,
    tolerance: float,
) -> tuple[SteadyState, KernelSolution, int, float]:
    """The iteration of :meth:`~ballscrew_twin.models.steady_reference.ReadableNewton.solve`,
    compiled, with exact per-sphere Jacobian blocks (:mod:`ballscrew_twin.kernels.steady_solver`):
    (converged state, the kernel's solution, iterations, worst scaled residual); SolverError
    when it does not converge. ``warm``: ``state`` is the last solution of ``model``, or near
    it, so the Jacobian blocks of the last solve are reused while they converge fast
    (refreshed when they do not); ``polished``: it is the polished solution of this very
    point (:attr:`SteadyState.polished`); ``tolerance``: the convergence limit of the worst
    scaled residual [-]."""
    solver = model._solver
    count = len(balls.nut)
    z = np.concatenate([state.ball_nb, state.kinematics], axis=1)
    nut_offset = state.nut_offset.copy()
    inputs = kernel_inputs(model, scene, loads)
    scales = inputs.scales
    stored = model._jacobian
    reuse = warm and stored is not None and stored[0].shape[0] == count
    if reuse and stored is not None:
        jacobian, old_scales = stored  # rescaled to ``scales`` in place by the kernel
    else:
        jacobian, old_scales = np.empty((count, 7, 7)), scales
    solved = solver.solve_compiled(
        z,
        nut_offset,
        jacobian,
        reuse,
        old_scales,
        reuse and polished,
        balls.nut,
        balls.weight,
        balls.gravity,
        loads,
        scales,
        model.inertial_terms,
        tolerance,
        inputs.parameters,
        max_iterations,
    )
    model._jacobian = (jacobian, scales) if solved.linearisations or reuse else None
    iterations, worst, status = solved.iterations, solved.residual, solved.status
    if status != solver.STATUS_CONVERGED:
        if status == solver.STATUS_SINGULAR:
            raise SolverError("steady state: singular sphere Jacobian")
        if status == solver.STATUS_NOT_FINITE:
            raise SolverError(
                "steady state: every line-search step gave a non-finite residual "
                f"(iteration {iterations + 1}, scaled residual {worst:.3g})"
            )
        raise SolverError(
            f"steady state did not converge in {max_iterations} iterations "
            f"(scaled residual {worst:.3g} > {tolerance:.1g})"
        )
    solved_state = SteadyState(z[:, :2], z[:, 2:], nut_offset, scene.screw_speed, reuse)
    return solved_state, solved, iterations, worst


@dataclass(frozen=True)
class KernelInputs:
    """What the kernel takes for one scene and pair of nut loads besides the state
    (:func:`kernel_inputs`).

    Attributes:
        scene: the contact scene; loads: (2,) force the spheres must exert on each nut [N].
        scales: residual row scales (force [N], moment [N m], nut row [N]) of
            :func:`~.steady_problem.residual_scales`, the nut row the force times the spheres
            per nut.
        parameters: ``scene_arrays(scene)`` as a float64 array.
    """

    scene: ContactScene
    loads: FloatArray
    scales: tuple[float, float, float]
    parameters: FloatArray


def kernel_inputs(model: SteadyStateModel, scene: ContactScene, loads: FloatArray) -> KernelInputs:
    """:class:`KernelInputs` of ``scene`` and ``loads``, kept on the model per pair of objects
    (the model's scenes and loads are kept objects, never written to; the entry holds both, so
    neither identity can pass to another object while it is kept): a warm solve at a point
    solved before computes none of them again. The scene parameters are kept per temperature
    and speed (:func:`kernel_parameters`)."""
    key = (id(scene), id(loads))
    known = model._kernel_inputs.get(key)
    if known is not None and known.scene is scene and known.loads is loads:
        return known
    force_scale, moment_scale = residual_scales(model.config, scene, loads)
    scales = (force_scale, moment_scale, force_scale * model.config.screw.balls_per_nut)
    inputs = KernelInputs(scene, loads, scales, kernel_parameters(model, scene))
    return kept(model._kernel_inputs, key, inputs)


def kernel_parameters(model: SteadyStateModel, scene: ContactScene) -> FloatArray:
    """``scene_arrays(scene)`` as the solver kernel takes it (float64 array), kept per
    temperature and speed like the scenes (they depend on nothing else for this model)."""
    key = (scene.temperature, scene.screw_speed)
    params = model._parameters.get(key)
    if params is None:
        from ..kernels.contacts import scene_arrays

        params = kept(model._parameters, key, np.array(scene_arrays(scene), dtype=np.float64))
    return params


def predicted_start(model: SteadyStateModel, op: OperatingPoint, count: int) -> SteadyState | None:
    """Warm start extrapolated from the last two solutions (compiled solver), or None.

    The operating quantities q = (speed, temperature, preload, axial load), each in units
    of :data:`PREDICTOR_UNITS`, moved by d between the two; the new point lies s d from the
    last one, s the projection of its own move on d (limited to PREDICTOR_RANGE). The
    offsets and the rates over the speed (the rolling pattern) move by s times their own
    change: exact while the solution is affine in q along d, as a warm start needs no more
    (the Newton iteration then finishes the solve). None when there are no two solutions of
    this mode, both at speeds of the sign of the new one (a start at a speed of other sign
    or at standstill is rescaled as before).
    """
    if len(model._history) < 2:
        return None
    (q0, old), (q1, last) = model._history
    speed = op.screw_speed
    if (
        old.ball_nb.shape[0] != count
        or last.ball_nb.shape[0] != count
        or not (speed * q0[0] > 0.0 and speed * q1[0] > 0.0)
    ):
        return None
    target = (speed, op.temperature, op.preload, op.axial_load)
    if target == q1:  # a point solved last or before: its own solution is the start
        return last
    if target == q0:
        return old
    u_speed = PREDICTOR_UNITS[0] * abs(q1[0])
    u_preload = PREDICTOR_UNITS[2] * max(q1[2], 10.0)
    u_load = PREDICTOR_UNITS[3] * max(abs(q1[3]), 10.0)
    moved = (
        (q1[0] - q0[0]) / u_speed,
        (q1[1] - q0[1]) / PREDICTOR_UNITS[1],
        (q1[2] - q0[2]) / u_preload,
        (q1[3] - q0[3]) / u_load,
    )
    norm = moved[0] ** 2 + moved[1] ** 2 + moved[2] ** 2 + moved[3] ** 2
    if norm == 0.0:
        return None
    s = (
        moved[0] * ((speed - q1[0]) / u_speed)
        + moved[1] * ((op.temperature - q1[1]) / PREDICTOR_UNITS[1])
        + moved[2] * ((op.preload - q1[2]) / u_preload)
        + moved[3] * ((op.axial_load - q1[3]) / u_load)
    ) / norm
    s = min(max(s, PREDICTOR_RANGE[0]), PREDICTOR_RANGE[1])
    start = SteadyState(np.empty((count, 2)), np.empty((count, 4)), np.empty(2), speed)
    model._solver.extrapolate(
        (old.ball_nb, old.kinematics, old.nut_offset, q0[0]),
        (last.ball_nb, last.kinematics, last.nut_offset, q1[0]),
        s,
        speed,
        start.ball_nb,
        start.kinematics,
        start.nut_offset,
    )
    return start
