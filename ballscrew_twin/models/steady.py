"""Steady-state (quasi-static) model: equilibrium of every loaded sphere at constant speed.

For each sphere the unknowns are its centre offset (n, b) from the ideal helix, its orbital rate
along the thread and its angular velocity (6 per sphere); for each nut, the axial offset of its
groove. The equations are the sphere's force and moment balance including centrifugal force,
gyroscopic moment and gravity (6 per sphere), and the axial balance of each nut under preload,
nut weight and external load (docs/model.md, section "Steady state").

The drag torque is the dissipated power divided by the screw speed, so the torque of lifting the
nut against gravity is removed as the paper does; the direct sum of the moments on the screw is
kept as ``screw_torque_direct`` for the power balance check.

Where the equations have several solutions (light preload, cold or fast: a sphere can roll,
skid or travel with one groove), the model returns the start-up state, reached by raising the
speed slowly from rest at the point's temperature and loads, whatever was solved before
(``branch="start-up"``; docs/model.md section 7a).

When all spheres of a nut are equivalent (vertical screw, no per-sphere difference) one sphere
stands for all of them (symmetric mode); otherwise every sphere is solved (full mode) with one
Newton iteration over all of them at once.

Two reductions serve the fidelity selection (``ballscrew_twin/fidelity.py``): the centrifugal
force and gyroscopic moment can be dropped (``inertial_terms=False``; their drag error against
speed is measured by ``ballscrew-twin bench skips``), and the lubricant and material state of a
temperature (:func:`make_scene` at zero speed) is computed once per temperature and reused while
the temperature does not change (exact: the same numbers).

This module holds the model (its caches, the warm-started solve and the branch rule); its parts
are modules of their own: the solved state and solution types (``steady_types``), the problem
set-up (``steady_problem``), the readable Newton (``steady_reference``), the compiled solver's
Newton call and predictor (``steady_compiled``), the cold-start paths (``steady_continuation``)
and the outputs (``steady_output``).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from ..errors import ConfigError, SolverError
from ..kernels.solver_settings import NEWTON_MAX_ITER
from ..params import TwinConfig
from ..physics.contact_types import ContactScene
from .base import MECHANISMS, OperatingPoint, TwinOutput
from .contact_forces import evaluate_contacts, make_scene
from .steady_compiled import KernelInputs, newton_compiled, predicted_start
from .steady_continuation import StartupPath, StaticFailure, cold_solve
from .steady_output import assemble
from .steady_problem import (
    averaged_ball_set,
    inertial_actions,
    make_ball_set,
    nut_axial_loads,
    rolling_kinematics,
    unloaded_nut,
)
from .steady_reference import ReadableNewton
from .steady_types import (
    BallSet,
    ContactSource,
    SteadySolution,
    SteadyState,
    along_line,
    continues_branch,
    kept,
    rate_change,
    secant_start,
)

__all__ = [
    "MECHANISMS",
    "STANDSTILL_SPEED",
    "Backend",
    "BallSet",
    "Branch",
    "Mode",
    "SteadySolution",
    "SteadyState",
    "SteadyStateModel",
    "along_line",
    "continues_branch",
    "inertial_actions",
    "rate_change",
    "secant_start",
]

FloatArray = NDArray[np.float64]
Mode = Literal["auto", "symmetric", "full"]
Backend = Literal["compiled", "newton", "reference"]
Branch = Literal["start-up", "path"]

#: Speeds below this are solved as standstill [rad/s] (1e-5 rpm: no ball screw runs there, and
#: the film laws' groups underflow as the entrainment speed goes to zero).
STANDSTILL_SPEED = 1e-6


class SteadyStateModel:
    """Quasi-static equilibrium of all loaded spheres of both nuts.

    Args:
        config: parameter set.
        mode: ``"symmetric"`` (one sphere per nut), ``"full"`` (every sphere) or ``"auto"``
            (symmetric whenever the spheres of a nut are equivalent: vertical screw).
        tolerance: convergence limit of the scaled residual (force / load scale) [-].
        backend: ``"compiled"`` (default: the structured compiled solver,
            :mod:`ballscrew_twin.kernels.steady_solver`, one numba call per Newton solve),
            ``"newton"`` (the readable Newton iteration,
            :class:`~ballscrew_twin.models.steady_reference.ReadableNewton`, over the compiled
            contact laws: the previous solver, kept for comparison) or ``"reference"`` (the readable
            Newton iteration over the numpy contact laws, the definition the others are tested
            against); all give the same solution.
        inertial_terms: keep the centrifugal force and the gyroscopic moment of each sphere in
            its balance (default). ``False`` drops both (:func:`inertial_actions`): a reduction
            whose drag error grows with the speed, measured by ``ballscrew-twin bench skips``.
        branch: which steady state a warm-started solve returns where there are several
            (docs/model.md, "One branch"). ``"start-up"`` (default): always the cold solve's,
            the state reached by starting up from rest at the point's temperature and loads
            (:func:`~ballscrew_twin.models.steady_continuation.startup_continuation`), whatever
            was solved before; a warm solve is kept only when it is a step of that start-up
            (same temperature and loads, speed of the same sign and not lower,
            :func:`continues_branch`), otherwise the point is solved cold. ``"path"``: a warm
            solve keeps the branch of its start while it moves continuously
            (:func:`continues_branch`; otherwise cold): the quasi-static history of the
            commanded path, which can differ from the start-up state (hysteresis).
        follow_folds: where the start-up path's jump from the end of its state lands on
            another state, take the state the curve of steady states reaches past that fold
            instead (:func:`~ballscrew_twin.models.steady_fold.follow_fold`; docs/model.md 7a,
            "Past a fold"). Default True; False is the rule before it (cheaper: the preview
            table).
    """

    def __init__(
        self,
        config: TwinConfig,
        mode: Mode = "auto",
        tolerance: float = 1e-10,
        backend: Backend = "compiled",
        inertial_terms: bool = True,
        branch: Branch = "start-up",
        follow_folds: bool = True,
    ) -> None:
        self.follow_folds = follow_folds
        if branch not in ("start-up", "path"):
            raise ConfigError(f"branch = {branch!r} must be start-up or path")
        self.branch = branch
        if mode not in ("auto", "symmetric", "full"):
            raise ConfigError(f"mode = {mode!r} must be auto, symmetric or full")
        if backend not in ("compiled", "newton", "reference"):
            raise ConfigError(f"backend = {backend!r} must be compiled, newton or reference")
        self.backend = backend
        self._evaluate = evaluate_contacts
        if backend != "reference":
            from ..kernels.contacts import evaluate_contacts_compiled

            self._evaluate = evaluate_contacts_compiled
        if backend == "compiled":
            from ..kernels import steady_results, steady_solver

            self._solver = steady_solver
            self._results = steady_results
        if not 0.0 < tolerance < 1e-2:
            raise ConfigError(f"tolerance = {tolerance!r} must be in (0, 1e-2)")
        self.config = config
        self.mode = mode
        self.tolerance = tolerance
        self.inertial_terms = bool(inertial_terms)
        self.name = "steady" if self.inertial_terms else "steady-no-inertia"
        self._reference = ReadableNewton(config, self._evaluate, self.inertial_terms, tolerance)
        self._warm: SteadyState | None = None
        # The operating quantities of _warm (temperature [K], preload [N], axial load [N]).
        self._warm_loads: tuple[float, float, float] | None = None
        # The last two solutions of the compiled solver with their operating quantities (speed
        # [rad/s], temperature [K], preload [N], axial load [N]), oldest first: the predictor.
        self._history: list[tuple[tuple[float, float, float, float], SteadyState]] = []
        self._notes: dict[tuple[str, float, bool], tuple[str, ...]] = {}
        self._contact_index: dict[str, tuple[NDArray[np.int64], ...]] = {}
        # Sphere Jacobian blocks of the compiled solver's last solve, with their residual scales.
        self._jacobian: tuple[FloatArray, tuple[float, float, float]] | None = None
        # The last start-up path a cold solve followed, which the next one resumes where both
        # share it (steady_continuation.StartupPath).
        self.startup_path: StartupPath | None = None
        # Static equilibria the Newton iteration missed, by (temperature [K], loads [N] as
        # bytes, spheres, tolerance), with the spheres solved (steady_continuation.static_solve).
        self.failed_statics: dict[tuple[float, bytes, int, float], tuple[BallSet, StaticFailure]]
        self.failed_statics = {}
        self._scenes: dict[float, ContactScene] = {}
        # The scenes at a temperature and a speed (the last ones used), as scene() returns them.
        self._moving_scenes: dict[tuple[float, float], ContactScene] = {}
        self._ball_sets: dict[str, BallSet] = {}
        self._parameters: dict[tuple[float, float], FloatArray] = {}
        # steady_compiled.kernel_inputs per (id(scene), id(loads)).
        self._kernel_inputs: dict[tuple[int, int], KernelInputs] = {}
        # nut_axial_loads per (preload [N], axial load [N]) for the solves (never written to).
        self._loads: dict[tuple[float, float], FloatArray] = {}
        self.scene_cache_hits = 0  # solves that reused the lubricant state of their temperature

    def scene(self, temperature: float, screw_speed: float) -> ContactScene:
        """Contact-law constants at ``temperature`` [K] and ``screw_speed`` [rad/s].

        The temperature-dependent part (thermally expanded geometry, lubricant viscosity, Hertz
        moduli) is computed once per temperature and reused: identical to :func:`make_scene`.
        """
        moving = self._moving_scenes.get((temperature, screw_speed))
        if moving is not None:
            self.scene_cache_hits += 1
            return moving
        base = self._scenes.get(temperature)
        if base is None:
            base = kept(self._scenes, temperature, make_scene(self.config, temperature, 0.0))
        else:
            self.scene_cache_hits += 1
        if screw_speed == 0.0:
            return base
        moving = kept(
            self._moving_scenes, (temperature, screw_speed), replace(base, screw_speed=screw_speed)
        )
        return moving

    # ------------------------------------------------------------------ set-up

    def resolved_mode(self) -> Literal["symmetric", "full"]:
        """The mode used: symmetric needs gravity to act alike on every sphere (vertical screw)."""
        if self.mode != "auto":
            return self.mode
        return "symmetric" if self.config.screw.orientation == "vertical" else "full"

    def ball_set(self, mode: Literal["symmetric", "full"]) -> BallSet:
        """Spheres to solve, their azimuths and gravity in their Frenet frames (computed once
        per mode: they depend on the parameters only)."""
        balls = self._ball_sets.get(mode)
        if balls is None:
            balls = self._ball_sets[mode] = make_ball_set(self.config, mode)
        return balls

    def nut_axial_loads(self, op: OperatingPoint) -> FloatArray:
        """Force the spheres must exert on each nut along +z [N] (master, slave):
        :func:`~ballscrew_twin.models.steady_problem.nut_axial_loads`."""
        return nut_axial_loads(self.config, op)

    def _averaged_balls(self, balls: BallSet) -> BallSet:
        """:func:`~ballscrew_twin.models.steady_problem.averaged_ball_set` of ``balls``, kept."""
        key = f"averaged {len(balls.nut)}"
        averaged = self._ball_sets.get(key)
        if averaged is None:
            averaged = self._ball_sets[key] = averaged_ball_set(balls)
        return averaged

    # ------------------------------------------------------------------ solve

    def _newton(
        self,
        scene: ContactScene,
        balls: BallSet,
        state: SteadyState,
        loads: FloatArray,
        warm: bool = False,
        polished: bool = False,
        max_iterations: int = NEWTON_MAX_ITER,
        tolerance: float | None = None,
    ) -> tuple[SteadyState, ContactSource, int, float]:
        """Newton iteration from ``state``: (converged state, its contacts, iterations, worst
        scaled residual); SolverError when it does not converge in ``max_iterations``.
        ``warm``: ``state`` comes from the last solution (the compiled solver may then reuse its
        Jacobian); ``polished``: it is the polished solution of this very point
        (:attr:`SteadyState.polished`); ``tolerance``: the convergence limit of the worst scaled
        residual [-] (None: :attr:`tolerance`; the start-up path's steps use their own)."""
        limit = self.tolerance if tolerance is None else tolerance
        if self.backend == "compiled":
            return newton_compiled(
                self, scene, balls, state, loads, warm, polished, max_iterations, limit
            )
        return self._reference.solve(scene, balls, state, loads, max_iterations, limit)

    def solve(self, op: OperatingPoint, warm_start: SteadyState | None = None) -> SteadySolution:
        """Solve the steady state at ``op`` (warm-started from ``warm_start`` or the last one);
        SolverError when it fails, naming a nearly unloaded nut (:func:`unloaded_nut`)."""
        op.validate()
        try:
            return self._solve(op, warm_start)
        except SolverError as err:
            hint = unloaded_nut(self.config, op)
            if not hint:
                raise
            raise SolverError(f"{err}; {hint}") from err

    def _solve(self, op: OperatingPoint, warm_start: SteadyState | None) -> SteadySolution:
        requested = op
        if 0.0 < abs(op.screw_speed) < STANDSTILL_SPEED:
            op = replace(op, screw_speed=0.0)
        mode = self.resolved_mode()
        try:
            solution = self._solve_in_mode(op, mode, warm_start)
        except SolverError as err:
            if self.mode != "auto" or mode != "symmetric":
                raise
            # Measured (bench stability): where the one-sphere reduction stalls (zero preload
            # at high speed), solving every sphere still converges.
            solution = self._solve_in_mode(op, "full", None)
            note = f"symmetric mode did not converge ({err}): every sphere solved (full mode)"
            output = replace(solution.output, notes=(*solution.output.notes, note))
            solution = replace(solution, output=output)
        if requested is op:
            return solution
        note = (
            f"speed {requested.screw_speed:.3g} rad/s is below {STANDSTILL_SPEED:g} rad/s: "
            "solved as standstill"
        )
        output = replace(
            solution.output, operating_point=requested, notes=(*solution.output.notes, note)
        )
        return replace(solution, output=output)

    def _solve_in_mode(
        self, op: OperatingPoint, mode: Literal["symmetric", "full"], warm_start: SteadyState | None
    ) -> SteadySolution:
        """Solve ``op`` with the spheres of ``mode``, warm-started when the shapes match."""
        scene = self.scene(op.temperature, op.screw_speed)
        balls = self.ball_set(mode)
        loads = self._loads.get((op.preload, op.axial_load))
        if loads is None:
            loads = kept(self._loads, (op.preload, op.axial_load), self.nut_axial_loads(op))
        previous = warm_start if warm_start is not None else self._warm
        count = len(balls.nut)
        if previous is not None and previous.ball_nb.shape[0] == count:
            predicted = predicted_start(self, op, count) if warm_start is None else None
            # A point among the last two solved starts from its own solution (polished or not):
            # predicted_start returns that very solution (the history holds two when it returns
            # any).
            own = predicted is not None and (
                predicted is self._history[0][1] or predicted is self._history[1][1]
            )
            start = previous
            if predicted is not None:
                start = predicted
            elif start.screw_speed != op.screw_speed:
                start = self._rescaled(start, scene, balls, op.screw_speed)
            ev: ContactSource
            try:
                if self.backend == "compiled":  # its Newton call without _newton's defaults
                    state, ev, iterations, residual = newton_compiled(
                        self,
                        scene,
                        balls,
                        start,
                        loads,
                        True,
                        own and start.polished,
                        NEWTON_MAX_ITER,
                        self.tolerance,
                    )
                else:
                    state, ev, iterations, residual = self._newton(scene, balls, start, loads)
            except SolverError:
                state = previous  # not a solution of op: solved cold below
            # One branch (docs/model.md): a warm solve that failed or left the model's branch
            # is replaced by the cold solve (the start-up path); a point solved again from its
            # own solution stays where it was solved.
            if state is previous or not (
                own or self._keeps_branch(op, previous, state, warm_start)
            ):
                state, ev, iterations, residual = cold_solve(self, op, balls, loads)
        else:
            state, ev, iterations, residual = cold_solve(self, op, balls, loads)
        self._warm = state
        self._warm_loads = (op.temperature, op.preload, op.axial_load)
        if self.backend == "compiled":
            quantities = (op.screw_speed, op.temperature, op.preload, op.axial_load)
            self._history = [*self._history[-1:], (quantities, state)]
        return assemble(self, op, mode, scene, balls, state, ev, iterations, residual)

    def _keeps_branch(
        self,
        op: OperatingPoint,
        previous: SteadyState,
        solved: SteadyState,
        warm_start: SteadyState | None,
    ) -> bool:
        """A warm solve ``solved`` at ``op`` from ``previous`` is on the model's branch
        (:attr:`branch`): continuous (:func:`continues_branch`) and, for ``"start-up"``, a step
        of the start-up path (standstill, or the temperature and loads of ``previous``, the last
        solution, at a speed of its sign and not lower; a caller's ``warm_start`` is not)."""
        if not continues_branch(previous, solved):
            return False
        if self.branch == "path" or op.screw_speed == 0.0:
            return True
        return (
            warm_start is None
            and self._warm_loads == (op.temperature, op.preload, op.axial_load)
            and abs(op.screw_speed) >= abs(previous.screw_speed)
        )

    def _rescaled(
        self, start: SteadyState, scene: ContactScene, balls: BallSet, speed: float
    ) -> SteadyState:
        """Warm start at another speed: rates scale with the speed (same rolling pattern)."""
        if start.screw_speed != 0.0 and speed != 0.0:
            kin = start.kinematics * (speed / start.screw_speed)
        elif speed != 0.0:
            kin = rolling_kinematics(scene, balls, start.ball_nb, start.nut_offset)
        else:
            kin = np.zeros_like(start.kinematics)
        return SteadyState(start.ball_nb.copy(), kin, start.nut_offset.copy(), speed)

    def forget_warm_start(self) -> None:
        """Make the next solve start cold (used by benchmarks and after a scene change)."""
        self._warm = None
        self._warm_loads = None
        self._jacobian = None
        self._history = []

    def forget_startup_path(self) -> None:
        """Drop the kept start-up path: the next cold solve climbs from 1 rpm (the same result;
        ``bench steady`` times a cold solve so)."""
        self.startup_path = None

    def evaluate(self, op: OperatingPoint) -> TwinOutput:
        """Drag torque and contact states at ``op`` (warm-started from the previous call)."""
        return self.solve(op).output
