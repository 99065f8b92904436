"""Cold solves of the steady model: the fixed paths that pick its one branch.

A solve with no usable warm start follows a path fixed by the operating point alone
(docs/model.md, "One branch"): the start-up path (:func:`startup_continuation`, the speed
raised from :data:`STARTUP_SPEED` in steps that stay on one state), where it fails the static
equilibrium and then the speed (:func:`speed_continuation`), where that fails too the preload
lowered from a heavier point (:func:`preload_continuation`). With the compiled solver and more
than one sphere per nut, the averaged two-sphere problem is solved first and spread over the
spheres (:func:`solve_from_averaged`). A static equilibrium that does not converge is kept
on the model and raised again without a solve (:func:`static_solve`). Each function takes the
model whose Newton iteration, scenes and warm-start rescaling it uses. Units: SI (rad/s, N).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from ..errors import SolverError
from ..kernels.solver_settings import NEWTON_MAX_ITER
from ..units import RPM
from .base import OperatingPoint
from .steady_fold import follow_fold
from .steady_problem import initial_state
from .steady_types import (
    BRANCH_JUMP,
    BallSet,
    ContactSource,
    SteadyState,
    kept,
    rate_change,
    secant_start,
)

if TYPE_CHECKING:
    from .steady import SteadyStateModel

FloatArray = NDArray[np.float64]
#: A converged solve: (state, its contacts, Newton iterations, worst scaled residual [-]).
Solve = tuple[SteadyState, ContactSource, int, float]

#: speed fractions of a cold start: straight to the speed, then ever finer continuation
CONTINUATION_SCHEDULES = (
    (1.0,),
    (0.05, 0.2, 0.5, 1.0),
    (0.02, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0),
)
#: Start-up path of a cold solve (docs/model.md, "One branch"): the steady state is the one
#: reached by raising the speed quasi-statically from this speed [rad/s] (1 rpm), where the
#: direct cold solve is the start-up branch (measured on 80 lines, -40..100 C, 0..2000 N).
STARTUP_SPEED = 1.0 * RPM
#: Largest and smallest speed ratio of one step of the start-up path [-]; the ratio grows by
#: STARTUP_GROWTH after an accepted step and is halved (its excess over 1) after a rejected one.
STARTUP_MAX_RATIO = 2.0
STARTUP_MIN_RATIO = 1.001
STARTUP_GROWTH = 1.5
#: A step of the start-up path that needs more Newton iterations is retried shorter [-].
STARTUP_MAX_ITER = 20
#: Convergence limit of the start-up path's solves (worst scaled residual) [-], whatever the
#: model's tolerance: which state the path reaches where there are several must not depend on
#: it (docs/model.md 7a; measured before: -20 C / 1350 rpm / 2 N gave 0.45 mN m at 1e-6, 1e-8
#: and 1e-11, 0.51 at 1e-9 and 0.22 at 1e-10). The state reached is then solved to the
#: model's tolerance where that is tighter. The model's default, so its answers are unchanged.
STARTUP_TOLERANCE = 1e-10
#: A cold solve whose speed continuation fails at the preload continues along the preload:
#: from a point this much heavier [N], solved cold, down to the preload in
#: PRELOAD_CONTINUATION_STEPS steps uniform in sqrt(preload) (docs/model.md, "One branch").
PRELOAD_CONTINUATION_LIFT = 300.0
PRELOAD_CONTINUATION_STEPS = 40


def cold_solve(
    model: SteadyStateModel, op: OperatingPoint, balls: BallSet, loads: FloatArray
) -> Solve:
    """Solve from no warm start: :func:`cold_solve_direct`, or, with the compiled solver
    and more than one sphere per nut, from the averaged problem first
    (:func:`solve_from_averaged`) and directly when that fails."""
    if model.backend == "compiled" and len(balls.nut) > 2:
        try:
            return solve_from_averaged(model, op, balls, loads)
        except SolverError:
            pass  # the averaged solution is no start for this problem: solve it directly
    return cold_solve_direct(model, op, balls, loads)


def solve_from_averaged(
    model: SteadyStateModel, op: OperatingPoint, balls: BallSet, loads: FloatArray
) -> Solve:
    """Cold solve of the averaged problem (``model._averaged_balls``, two spheres), then every
    sphere warm-started from its nut's sphere, with that sphere's Jacobian block (its nut
    row scaled to the one sphere it now stands for): the cost of a cold solve of two spheres
    and a warm solve of all (compiled solver only)."""
    averaged = model._averaged_balls(balls)
    state, _, iterations, _ = cold_solve_direct(model, op, averaged, loads)
    assert model._jacobian is not None  # a cold solve computes the blocks
    blocks, scales = model._jacobian
    spread = blocks[balls.nut]  # a copy
    spread[:, 6, :] *= (balls.weight / averaged.weight[balls.nut])[:, None]
    model._jacobian = (spread, scales)
    start = SteadyState(
        state.ball_nb[balls.nut],
        state.kinematics[balls.nut],
        state.nut_offset.copy(),
        state.screw_speed,
    )
    scene = model.scene(op.temperature, op.screw_speed)
    solved, ev, more, residual = model._newton(scene, balls, start, loads, warm=True)
    return solved, ev, iterations + more, residual


def cold_solve_direct(
    model: SteadyStateModel, op: OperatingPoint, balls: BallSet, loads: FloatArray
) -> Solve:
    """The start-up path (:func:`startup_continuation`); where it fails, the static
    equilibrium and then the speed (:func:`speed_continuation`); where that fails too,
    along the preload from a heavier point (:func:`preload_continuation`). All are fixed
    paths: the result depends on the operating point alone, not on the model's tolerance
    (:data:`STARTUP_TOLERANCE`): where the state the start-up path reaches does not converge
    to a tighter tolerance, the solve fails instead of taking another path."""
    try:
        solve = startup_continuation(model, op, balls, loads)
    except SolverError:
        pass
    else:
        return to_model_tolerance(model, op, balls, loads, solve)
    try:
        return speed_continuation(model, op, balls, loads)
    except SolverError as err:
        if op.screw_speed == 0.0:
            raise
        try:
            return preload_continuation(model, op, balls, loads)
        except SolverError:
            raise err from None


def startup_continuation(
    model: SteadyStateModel, op: OperatingPoint, balls: BallSet, loads: FloatArray
) -> Solve:
    """The steady state reached by quasi-static start-up: solved cold at
    :data:`STARTUP_SPEED` (of ``op``'s sign), then the speed raised in steps to ``op``'s,
    each warm-started from the last with the rates scaled by the speed. A step whose rates
    over the speed move by more than :data:`BRANCH_JUMP` (:func:`rate_change`) or that does
    not converge is retried shorter (:func:`startup_step`). Where none down to
    :data:`STARTUP_MIN_RATIO` does, longer steps are tried (ratio excess times 4 each) and
    the first that converges is taken (the last at :data:`STARTUP_MAX_RATIO` itself): to
    where the branch ends (a real screw jumps there too).
    A longer step that would end past the target speed, where the state the path was on
    ends just below it, solves past it and follows the state reached back down to the
    target (:func:`startup_return`; the target itself lies in the basin of the ended
    state and does not converge). Raises SolverError when no step up to
    :data:`STARTUP_MAX_RATIO` converges. At or below the start-up speed:
    :func:`speed_continuation`. Every solve of the path converges to
    :data:`STARTUP_TOLERANCE` (:func:`to_model_tolerance` takes the state reached on)."""
    target = abs(op.screw_speed)
    if target <= STARTUP_SPEED:
        return speed_continuation(model, op, balls, loads)
    sign = math.copysign(1.0, op.screw_speed)
    path = startup_path(model, op, balls, loads)
    if path.stop is not None and path.stop[0] < target:  # it stops below the target
        raise SolverError(f"steady state: start-up path stopped at {sign * path.stop[1]:.6g} rad/s")
    if path.starts:  # at least one step follows a kept start: it returns that step's solve
        (previous, state, total, speed, ratio), tried = path.resume(model, target)
    else:
        state, _, total, _ = speed_continuation(
            model, replace(op, screw_speed=sign * STARTUP_SPEED), balls, loads, STARTUP_TOLERANCE
        )
        speed, ratio, tried, previous = STARTUP_SPEED, STARTUP_MAX_RATIO, 0.0, None
    solve: Solve | None = None
    while speed < target:
        if tried < target:  # no step so far reached the target: a start of higher targets too
            path.record(model, (previous, state, total, speed, ratio), tried)
        tried = max(tried, speed * ratio)
        step = startup_step(model, op, balls, loads, (previous, state), speed, ratio)
        if step is None:  # no step converges on the branch: the longest converged one
            ratio = STARTUP_MIN_RATIO
            while step is None:
                if ratio >= STARTUP_MAX_RATIO:
                    if tried < target:  # a stop on the path to every target above ``tried``
                        path.stop = (tried, speed)
                    raise SolverError(
                        f"steady state: start-up path stopped at {sign * speed:.6g} rad/s"
                    )
                ratio = min(1.0 + 4.0 * (ratio - 1.0), STARTUP_MAX_RATIO)
                tried = max(tried, speed * ratio)
                step = startup_step(
                    model, op, balls, loads, (previous, state), speed, ratio, jump=True
                )
            if (
                model.follow_folds
                and rate_change(state, step[0][0]) > BRANCH_JUMP
                and (past := fold_step(model, op, balls, loads, path, state))
            ):
                # The jump reached another state: where the curve of steady states through
                # the ended one goes past its fold instead (a screw leaves a fold along it).
                total += step[0][2] + past[0][2]
                previous, state, speed, ratio = None, past[0][0], past[1], STARTUP_MIN_RATIO
                solve, tried = past[0], max(tried, speed)
                continue
        solve = step[0]
        total += solve[2]
        previous, state, speed, ratio = state, solve[0], step[1], step[2]
        ratio = min(1.0 + STARTUP_GROWTH * (ratio - 1.0), STARTUP_MAX_RATIO)
    assert solve is not None  # speed < target at the start (1 rpm or a kept start)
    return state, solve[1], total, solve[3]


def to_model_tolerance(
    model: SteadyStateModel, op: OperatingPoint, balls: BallSet, loads: FloatArray, solve: Solve
) -> Solve:
    """``solve``, converged to :data:`STARTUP_TOLERANCE` at ``op``, solved on to the model's
    tolerance where that is tighter (a Newton solve from it: the same state); SolverError
    when that does not converge."""
    if model.tolerance >= STARTUP_TOLERANCE:
        return solve
    scene = model.scene(op.temperature, op.screw_speed)
    state, ev, more, residual = model._newton(scene, balls, solve[0], loads, warm=True)
    return state, ev, solve[2] + more, residual


#: The start of a step of the start-up path: (state before the last, last state, Newton
#: iterations so far, |speed| [rad/s], speed ratio [-]).
PathStart = tuple[SteadyState | None, SteadyState, int, float, float]


@dataclass
class StartupPath:
    """The starts of the steps of the last start-up path a model followed
    (:func:`startup_continuation`), so that the next path of the same temperature, speed sign,
    loads and spheres begins at the last start both share instead of at :data:`STARTUP_SPEED`.

    A step from |speed| tries speeds ``speed * ratio`` (ratio <= :data:`STARTUP_MAX_RATIO`);
    the target enters a step only where one of them reaches it (the step is shortened to the
    target, or jumps past it). The path to any target above every speed tried before a start
    therefore passes through that start, with the same Newton solver state (the sphere
    Jacobian blocks kept between the path's solves, saved with each start): a path resumed
    there is the one followed from :data:`STARTUP_SPEED`, to the last bit. The table build's
    lines solve their nodes at ascending speeds: a node solved cold resumes at the start of
    the last step of the node below instead of climbing from 1 rpm again. Likewise a path
    that stops (no step converges) after trying only speeds below the target stops there for
    every higher target: such a cold solve goes to its fallbacks at once.

    Attributes:
        key: (temperature [K], speed sign, axial loads [N] as bytes) of the path.
        balls: the spheres solved.
        starts: (start, the highest |speed| tried before it [rad/s], Jacobian blocks and their
            residual scales or None), in the path's order.
        stop: where the path stops (no step converges) for every target above the highest
            |speed| tried until then: (that speed, the |speed| it stops at) [rad/s], or None.
        folds: the state :func:`follow_fold` reached past each fold of the path (None: it
            reached none), by the |speed| [rad/s] of the path's state at the fold: a path
            resumed before a fold passes it again in the same state.
    """

    key: tuple[float, float, bytes]
    balls: BallSet
    starts: list[tuple[PathStart, float, tuple[FloatArray, tuple[float, float, float]] | None]] = (
        field(default_factory=list)
    )
    stop: tuple[float, float] | None = None
    folds: dict[float, SteadyState | None] = field(default_factory=dict)

    def record(self, model: SteadyStateModel, start: PathStart, tried: float) -> None:
        """Keep ``start`` (reached after speeds up to ``tried`` [rad/s]) with a copy of
        ``model``'s Jacobian blocks."""
        jacobian = model._jacobian
        blocks = None if jacobian is None else (jacobian[0].copy(), jacobian[1])
        self.starts.append((start, tried, blocks))

    def resume(self, model: SteadyStateModel, target: float) -> tuple[PathStart, float]:
        """The last kept start on the path to |``target``| [rad/s] (every speed tried before it
        below the target) and the highest speed tried before it [rad/s]; ``model``'s Jacobian
        blocks are set to those saved with it and the starts after it are dropped."""
        count = 1  # the first start, at STARTUP_SPEED, is on every path
        for k, (_, tried, _) in enumerate(self.starts):
            if tried < target:
                count = k + 1
        del self.starts[count:]
        start, tried, blocks = self.starts.pop()  # recorded again as the path passes it
        model._jacobian = None if blocks is None else (blocks[0].copy(), blocks[1])
        return start, tried


def fold_step(
    model: SteadyStateModel,
    op: OperatingPoint,
    balls: BallSet,
    loads: FloatArray,
    path: StartupPath,
    state: SteadyState,
) -> tuple[Solve, float] | None:
    """Past the fold where the start-up ``path``'s ``state`` ends (:func:`follow_fold`, once
    per fold of the path: :attr:`StartupPath.folds`), solved to :data:`STARTUP_TOLERANCE`
    there, or followed back down to ``op``'s speed (:func:`startup_return`) where it lies past
    it: (solve, |speed| reached) or None."""
    at = abs(state.screw_speed)
    if at not in path.folds:
        path.folds[at] = follow_fold(model, op, balls, loads, state)
    landed = path.folds[at]
    if landed is None:
        return None
    scene = model.scene(op.temperature, landed.screw_speed)
    try:
        solve = model._newton(
            scene,
            balls,
            landed,
            loads,
            max_iterations=STARTUP_MAX_ITER,
            tolerance=STARTUP_TOLERANCE,
        )
    except SolverError:
        return None
    reached = abs(landed.screw_speed)
    target = abs(op.screw_speed)
    if reached <= target:
        return solve, reached
    returned = startup_return(model, op, balls, loads, solve, reached)
    return None if returned is None else (returned, target)


def startup_path(
    model: SteadyStateModel, op: OperatingPoint, balls: BallSet, loads: FloatArray
) -> StartupPath:
    """``model``'s kept start-up path when it is one of ``op``'s temperature, speed sign,
    ``loads`` [N] and ``balls``; otherwise a new empty one, kept in its place."""
    key = (op.temperature, math.copysign(1.0, op.screw_speed), np.asarray(loads).tobytes())
    path = model.startup_path
    if path is None or path.key != key or path.balls is not balls:
        path = model.startup_path = StartupPath(key, balls)
    return path


def startup_step(
    model: SteadyStateModel,
    op: OperatingPoint,
    balls: BallSet,
    loads: FloatArray,
    path: tuple[SteadyState | None, SteadyState],
    speed: float,
    ratio: float,
    jump: bool = False,
) -> tuple[Solve, float, float] | None:
    """One step of :func:`startup_continuation` from the last state of ``path`` (the one
    before it, or None, and the last) at |speed| [rad/s]: the longest speed ratio from
    ``ratio`` down (its excess halved each time) to :data:`STARTUP_MIN_RATIO` whose solve,
    started from :func:`secant_start`, converges with a :func:`rate_change` within
    :data:`BRANCH_JUMP` (``jump``: ``ratio`` alone, any rate change, and past the target
    when the step to the target does not converge). Returns (solve, |speed| reached,
    ratio) or None."""
    target = abs(op.screw_speed)
    while True:
        step_speed = min(speed * ratio, target)
        solve = startup_solve(model, op, balls, loads, path, step_speed, jump)
        if solve is not None and (jump or rate_change(path[1], solve[0]) <= BRANCH_JUMP):
            return solve, step_speed, ratio
        if jump and solve is None and speed * ratio > target:
            # The jump ends past the target: the state it reaches, followed back down.
            solve = startup_solve(model, op, balls, loads, path, speed * ratio, jump)
            if solve is not None:
                solve = startup_return(model, op, balls, loads, solve, speed * ratio)
            return None if solve is None else (solve, target, ratio)
        if jump or ratio <= STARTUP_MIN_RATIO:
            return None
        ratio = max(1.0 + 0.5 * (ratio - 1.0), STARTUP_MIN_RATIO)


def startup_solve(
    model: SteadyStateModel,
    op: OperatingPoint,
    balls: BallSet,
    loads: FloatArray,
    path: tuple[SteadyState | None, SteadyState],
    speed: float,
    jump: bool = False,
) -> Solve | None:
    """Newton solve at |speed| [rad/s] (``op``'s sign, temperature and ``loads``) started
    from the last state of ``path`` (on the secant through both when the first is not
    None) with at most :data:`STARTUP_MAX_ITER` iterations (``jump``, a step to another
    state: :data:`NEWTON_MAX_ITER`); None when it does not converge."""
    signed = math.copysign(speed, op.screw_speed)
    scene = model.scene(op.temperature, signed)
    previous, state = path
    if previous is None:
        start = model._rescaled(state, scene, balls, signed)
    else:
        start = secant_start(previous, state, signed)
    try:
        return model._newton(
            scene,
            balls,
            start,
            loads,
            warm=True,
            max_iterations=NEWTON_MAX_ITER if jump else STARTUP_MAX_ITER,
            tolerance=STARTUP_TOLERANCE,
        )
    except SolverError:
        return None


def startup_return(
    model: SteadyStateModel,
    op: OperatingPoint,
    balls: BallSet,
    loads: FloatArray,
    solve: Solve,
    speed: float,
) -> Solve | None:
    """From ``solve``, solved at |speed| [rad/s] above ``op``'s, down to ``op``'s speed
    along its state: steps in speed ratio as on the way up (the whole way first, the
    excess halved after a step that does not converge or moves a rate by more than
    :data:`BRANCH_JUMP`, grown by :data:`STARTUP_GROWTH` after one that does). Returns the
    solve at ``op``'s speed (iterations summed over the steps), or None where no step
    down to :data:`STARTUP_MIN_RATIO` stays on the state."""
    target = abs(op.screw_speed)
    previous: SteadyState | None = None
    total = solve[2]
    ratio = speed / target
    while speed > target:
        step_speed = max(speed / ratio, target)
        step = startup_solve(model, op, balls, loads, (previous, solve[0]), step_speed)
        if step is not None and rate_change(solve[0], step[0]) <= BRANCH_JUMP:
            previous, solve, speed = solve[0], step, step_speed
            total += step[2]
            ratio = min(1.0 + STARTUP_GROWTH * (ratio - 1.0), STARTUP_MAX_RATIO)
        elif ratio <= STARTUP_MIN_RATIO:
            return None
        else:
            ratio = max(1.0 + 0.5 * (ratio - 1.0), STARTUP_MIN_RATIO)
    return solve[0], solve[1], total, solve[3]


def preload_continuation(
    model: SteadyStateModel, op: OperatingPoint, balls: BallSet, loads: FloatArray
) -> Solve:
    """Cold solve at ``op`` with :data:`PRELOAD_CONTINUATION_LIFT` more preload [N]
    (:func:`speed_continuation`), then down to ``op``'s preload in
    :data:`PRELOAD_CONTINUATION_STEPS` steps uniform in sqrt(preload), each warm-started
    from the previous one (same speed and temperature) and, where that fails, solved by
    :func:`speed_continuation`; ``loads`` are ``op``'s."""
    heavy = replace(op, preload=op.preload + PRELOAD_CONTINUATION_LIFT)
    state, ev, total, residual = speed_continuation(
        model, heavy, balls, model.nut_axial_loads(heavy)
    )
    scene = model.scene(op.temperature, op.screw_speed)
    roots = np.linspace(
        math.sqrt(heavy.preload), math.sqrt(op.preload), PRELOAD_CONTINUATION_STEPS + 1
    )
    for k, root in enumerate(roots[1:].tolist()):
        last = k == PRELOAD_CONTINUATION_STEPS - 1
        step_op = op if last else replace(op, preload=root * root)
        step_loads = loads if last else model.nut_axial_loads(step_op)
        try:
            state, ev, iterations, residual = model._newton(scene, balls, state, step_loads)
        except SolverError:
            state, ev, iterations, residual = speed_continuation(model, step_op, balls, step_loads)
        total += iterations
    return state, ev, total, residual


def speed_continuation(
    model: SteadyStateModel,
    op: OperatingPoint,
    balls: BallSet,
    loads: FloatArray,
    tolerance: float | None = None,
) -> Solve:
    """Static equilibrium first (robust: smooth Hertz only), then the speed.

    If the direct step to full speed fails, the speed is raised in stages (continuation,
    :data:`CONTINUATION_SCHEDULES`), each stage warm-started from the previous one. Each
    solve converges to ``tolerance`` (None: the model's).
    """
    state, ev, total, residual = static_solve(model, op.temperature, balls, loads, tolerance)
    if op.screw_speed == 0.0:
        return state, ev, total, residual
    last_error: SolverError | None = None
    for attempt in CONTINUATION_SCHEDULES:
        current = state
        try:
            for fraction in attempt:
                speed = op.screw_speed * fraction
                scene = model.scene(op.temperature, speed)
                current = model._rescaled(current, scene, balls, speed)
                current, ev, iterations, residual = model._newton(
                    scene, balls, current, loads, tolerance=tolerance
                )
                total += iterations
            return current, ev, total, residual
        except SolverError as err:
            last_error = err
    assert last_error is not None
    raise last_error


@dataclass(frozen=True)
class StaticFailure:
    """A static equilibrium the Newton iteration missed from its Hertz start
    (:func:`static_solve`): the solver's message and the sphere Jacobian blocks it left on
    the model (with their residual scales), or None."""

    message: str
    blocks: tuple[FloatArray, tuple[float, float, float]] | None


def static_solve(
    model: SteadyStateModel,
    temperature: float,
    balls: BallSet,
    loads: FloatArray,
    tolerance: float | None = None,
) -> Solve:
    """Static equilibrium of ``balls`` at ``temperature`` [K] under ``loads`` [N], from the
    Hertz estimate (:func:`initial_state`), converged to ``tolerance`` (None: the model's).

    The solve is a function of these alone, so a failure is kept on the model
    (``model.failed_statics``) and raised again, with the same Jacobian blocks left on the
    model, without the 80 iterations: a table line near the preload that balances a nut's
    weight fails here at every node and at every step of its preload continuation (measured
    on the 32 mm screw at 9 N: 29 % of the line's time).
    """
    limit = model.tolerance if tolerance is None else tolerance
    key = (temperature, np.asarray(loads).tobytes(), len(balls.nut), limit)
    known = model.failed_statics.get(key)
    if known is not None and known[0] is balls:
        blocks = known[1].blocks
        model._jacobian = None if blocks is None else (blocks[0].copy(), blocks[1])
        raise SolverError(known[1].message)
    scene = model.scene(temperature, 0.0)
    state = initial_state(model.config, scene, balls, loads)
    try:
        return model._newton(scene, balls, state, loads, tolerance=limit)
    except SolverError as err:
        jacobian = model._jacobian
        blocks = None if jacobian is None else (jacobian[0].copy(), jacobian[1])
        kept(model.failed_statics, key, (balls, StaticFailure(str(err), blocks)))
        raise
