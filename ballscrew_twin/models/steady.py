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
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property
from typing import TYPE_CHECKING, Literal, Union

import numpy as np
from numpy.typing import NDArray

from ..errors import ConfigError, SolverError
from ..kernels.solver_settings import DIAGONAL_SHIFT, LINE_SEARCH_STEPS, MIN_STEP, NEWTON_MAX_ITER
from ..params import TwinConfig
from ..physics import geometry, hertz
from ..physics.contact_types import ContactEvaluation, ContactScene
from ..units import RPM
from .base import (
    MECHANISMS,
    ContactStates,
    OperatingPoint,
    TorqueBreakdown,
    TwinOutput,
    contact_states_from_rows,
    filled,
)
from .contact_forces import evaluate_contacts, make_scene

if TYPE_CHECKING:
    from ..kernels.steady_solver import KernelSolution

FloatArray = NDArray[np.float64]
Mode = Literal["auto", "symmetric", "full"]
Backend = Literal["compiled", "newton", "reference"]
Branch = Literal["start-up", "path"]

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
#: A step of the start-up path is rejected when any rate of a sphere over the screw speed
#: changes by more than this, relative to 1 + its size (a jump to another branch) [-].
BRANCH_JUMP = 0.05
#: A step of the start-up path that needs more Newton iterations is retried shorter [-].
STARTUP_MAX_ITER = 20
#: A cold solve whose speed continuation fails at the preload continues along the preload:
#: from a point this much heavier [N], solved cold, down to the preload in
#: PRELOAD_CONTINUATION_STEPS steps uniform in sqrt(preload) (docs/model.md, "One branch").
PRELOAD_CONTINUATION_LIFT = 300.0
PRELOAD_CONTINUATION_STEPS = 40
POSITION_STEP = 1e-10  # m, finite-difference step of the ball and nut offsets
KINEMATIC_STEP_REL = 1e-7  # finite-difference step of the rates, relative to the screw speed
#: Speeds below this are solved as standstill [rad/s] (1e-5 rpm: no ball screw runs there, and
#: the film laws' groups underflow as the entrainment speed goes to zero).
STANDSTILL_SPEED = 1e-6
#: Temperatures whose lubricant/material state is kept (oldest dropped beyond) [-].
SCENE_CACHE_SIZE = 64
#: Step of each operating quantity that counts as one unit when the warm start is extrapolated
#: from the last two solutions (:meth:`SteadyStateModel._predicted`): 1 % of the speed, 0.1 K,
#: 1 % of the preload (at least 0.1 N) and 1 % of the axial load (at least 0.1 N).
PREDICTOR_UNITS = (0.01, 0.1, 0.01, 0.01)
#: Extrapolation along the last two solutions is limited to this range of their step [-].
PREDICTOR_RANGE = (-1.0, 2.0)

#: Contacts of a solve: the numpy evaluation (readable backends) or the compiled solver's result.
ContactSource = Union[ContactEvaluation, "KernelSolution"]


@dataclass(frozen=True)
class BallSet:
    """The spheres solved: their nut, azimuth and how many physical spheres each stands for."""

    nut: NDArray[np.int64]  # (B,) 0 master, 1 slave
    azimuth: FloatArray  # (B,) rad
    weight: FloatArray  # (B,) physical spheres represented
    gravity: FloatArray  # (B, 3) m/s^2 in Frenet components


@dataclass
class SteadyState:
    """Solved unknowns, reusable as a warm start."""

    ball_nb: FloatArray  # (B, 2) m
    kinematics: FloatArray  # (B, 4) rad/s
    nut_offset: FloatArray  # (2,) m
    screw_speed: float  # rad/s at which it was solved
    #: returned by a warm solve of the compiled solver, polished until a step with old Jacobian
    #: blocks no longer cut its residual: as the start of its own point it needs no polishing
    polished: bool = False


@dataclass(frozen=True)
class SteadySolution:
    """A converged steady state with what it implies (``contacts``: every contact quantity at
    the solution, built on first use from ``contact_source``)."""

    output: TwinOutput
    state: SteadyState
    balls: BallSet
    contact_source: ContactSource
    screw_torque_direct: float  # N m, sum of moments of the spheres on the screw (with gravity)
    gravity_torque: float  # N m, the part of the direct torque that lifts nuts and spheres
    iterations: int
    residual: float  # max scaled residual at convergence

    @cached_property
    def contacts(self) -> ContactEvaluation:
        """Forces, moments, states and dissipation of every contact at the solution."""
        source = self.contact_source
        if isinstance(source, ContactEvaluation):
            return source
        from ..kernels.contacts import evaluation_from_buffer

        return evaluation_from_buffer(source.active, source.buffer)


class SteadyStateModel:
    """Quasi-static equilibrium of all loaded spheres of both nuts.

    Args:
        config: parameter set.
        mode: ``"symmetric"`` (one sphere per nut), ``"full"`` (every sphere) or ``"auto"``
            (symmetric whenever the spheres of a nut are equivalent: vertical screw).
        tolerance: convergence limit of the scaled residual (force / load scale) [-].
        backend: ``"compiled"`` (default: the structured compiled solver,
            :mod:`ballscrew_twin.kernels.steady_solver`, one numba call per Newton solve),
            ``"newton"`` (the readable Newton iteration of this class over the compiled contact
            laws: the previous solver, kept for comparison) or ``"reference"`` (the readable
            Newton iteration over the numpy contact laws, the definition the others are tested
            against); all give the same solution.
        inertial_terms: keep the centrifugal force and the gyroscopic moment of each sphere in
            its balance (default). ``False`` drops both (:func:`inertial_actions`): a reduction
            whose drag error grows with the speed, measured by ``ballscrew-twin bench skips``.
        branch: which steady state a warm-started solve returns where there are several
            (docs/model.md, "One branch"). ``"start-up"`` (default): always the cold solve's,
            the state reached by starting up from rest at the point's temperature and loads
            (:meth:`_startup_continuation`), whatever was solved before; a warm solve is kept
            only when it is a step of that start-up (same temperature and loads, speed of the
            same sign and not lower, :func:`continues_branch`), otherwise the point is solved
            cold. ``"path"``: a warm solve keeps the branch of its start while it moves
            continuously (:func:`continues_branch`; otherwise cold): the quasi-static history
            of the commanded path, which can differ from the start-up state (hysteresis).
    """

    def __init__(
        self,
        config: TwinConfig,
        mode: Mode = "auto",
        tolerance: float = 1e-10,
        backend: Backend = "compiled",
        inertial_terms: bool = True,
        branch: Branch = "start-up",
    ) -> None:
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
            from ..kernels import steady_solver

            self._solver = steady_solver
        if not 0.0 < tolerance < 1e-2:
            raise ConfigError(f"tolerance = {tolerance!r} must be in (0, 1e-2)")
        self.config = config
        self.mode = mode
        self.tolerance = tolerance
        self.inertial_terms = bool(inertial_terms)
        self.name = "steady" if self.inertial_terms else "steady-no-inertia"
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
        self._scenes: dict[float, ContactScene] = {}
        # The scenes at a temperature and a speed (the last ones used), as scene() returns them.
        self._moving_scenes: dict[tuple[float, float], ContactScene] = {}
        self._ball_sets: dict[str, BallSet] = {}
        self._parameters: dict[tuple[float, float], FloatArray] = {}
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
            if len(self._scenes) >= SCENE_CACHE_SIZE:
                self._scenes.pop(next(iter(self._scenes)))
            base = make_scene(self.config, temperature, 0.0)
            self._scenes[temperature] = base
        else:
            self.scene_cache_hits += 1
        if screw_speed == 0.0:
            return base
        if len(self._moving_scenes) >= SCENE_CACHE_SIZE:
            self._moving_scenes.pop(next(iter(self._moving_scenes)))
        moving = self._moving_scenes[(temperature, screw_speed)] = replace(
            base, screw_speed=screw_speed
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
            balls = self._ball_sets[mode] = self._make_ball_set(mode)
        return balls

    def _make_ball_set(self, mode: Literal["symmetric", "full"]) -> BallSet:
        screw = self.config.screw
        g = self.config.environment.gravity
        z_count = screw.balls_per_nut
        if mode == "symmetric":
            nut = np.array([0, 1])
            azimuth = np.zeros(2)
            weight = np.full(2, float(z_count))
        else:
            spacing = 2.0 * math.pi * screw.loaded_turns / z_count
            per_nut = np.arange(z_count) * spacing
            nut = np.repeat(np.array([0, 1]), z_count)
            azimuth = np.concatenate([per_nut, per_nut])
            weight = np.ones(2 * z_count)
        frames = geometry.frenet_frame(azimuth, screw.helix_angle)  # (B, 3, 3) rows t, n, b
        if screw.orientation == "vertical":
            g_world = np.array([0.0, 0.0, -g])  # screw axis z points up
        else:
            g_world = np.array([0.0, -g, 0.0])  # horizontal axis, gravity along -y
        gravity = np.einsum("bij,j->bi", frames, g_world)
        return BallSet(nut=nut, azimuth=azimuth, weight=weight, gravity=gravity)

    def nut_axial_loads(self, op: OperatingPoint) -> FloatArray:
        """Force the spheres must exert on each nut along +z [N] (master, slave).

        The preload pushes the master nut up and the slave nut down (paper: preload force between
        the nuts); each nut's weight pulls it down on a vertical screw; the external axial load
        acts on the master nut.
        """
        weight = self.config.screw.nut_mass * self.config.environment.gravity
        if self.config.screw.orientation != "vertical":
            weight = 0.0
        master = -(op.preload - weight + op.axial_load)
        slave = -(-op.preload - weight)
        return np.array([master, slave])

    # ------------------------------------------------------------------ solve

    def _initial_state(self, scene: ContactScene, balls: BallSet, loads: FloatArray) -> SteadyState:
        """Hertz estimate of the offsets and the pure-rolling estimate of the rates."""
        geom = scene.geometry
        r_b, r_s = geom.ball_radius, geom.groove_radius
        clearance = r_s - r_b
        b_touch = math.sqrt(max(clearance**2 - geom.centre_offset**2, 0.0)) - geom.ogival_offset
        alpha = geom.free_contact_angle
        per_ball = np.abs(loads) / self.config.screw.balls_per_nut
        q = per_ball / (math.sin(alpha) * math.cos(geom.helix_angle))
        k_roll, k_trans = geometry.principal_curvatures(geom, np.array([alpha]), np.array([0]))
        rx, ry = geometry.reduced_radii(r_b, k_roll, k_trans)
        stiffness = float(hertz.hertz_stiffness(rx, ry, scene.e_star)[0])
        delta = (q / stiffness) ** (2.0 / 3.0)
        # Nut pushed down by its spheres (load < 0) bears on S2/N1: ball and nut go +b.
        sign = np.where(loads < 0.0, 1.0, -1.0)
        ball_b = sign * (b_touch + delta / math.sin(alpha))
        nut_offset = sign * 2.0 * (b_touch + delta / math.sin(alpha))
        ball_nb = np.stack([np.zeros(len(balls.nut)), ball_b[balls.nut]], axis=-1)
        kin = np.zeros((len(balls.nut), 4))
        if scene.screw_speed != 0.0:
            kin = self._rolling_kinematics(scene, balls, ball_nb, nut_offset)
        return SteadyState(ball_nb, kin, nut_offset, scene.screw_speed)

    def _rolling_kinematics(
        self, scene: ContactScene, balls: BallSet, ball_nb: FloatArray, nut_offset: FloatArray
    ) -> FloatArray:
        """Rates that minimise the slips at the loaded contacts (least squares, per sphere)."""
        count = len(balls.nut)
        e_ball = nut_offset[balls.nut]
        geom = scene.geometry
        ratio = (geom.pitch_radius + geom.ball_radius * math.cos(geom.free_contact_angle)) / (
            2.0 * geom.pitch_radius
        )
        w_ball = -scene.screw_speed * ratio
        kin = np.zeros((count, 4))
        kin[:, 0] = w_ball
        # Rolling about the in-plane axis perpendicular to the contact line, no spin on the screw.
        alpha = geom.free_contact_angle
        speed = w_ball * geom.pitch_radius / math.cos(geom.helix_angle)
        # Pure rolling on the fixed screw: omega x (r_b d) = -v_centre t, i.e. omega =
        # (s, 0, 0) x d with s = speed / r_b and d = (0, cos a, +-sin a) (sign of e_ball).
        sign_b = np.where(e_ball > 0.0, 1.0, -1.0)
        spin_rate = speed / geom.ball_radius
        kin[:, 2] = -(spin_rate * (sign_b * math.sin(alpha)))
        kin[:, 3] = spin_rate * math.cos(alpha)
        return kin

    def _residual(
        self, scene: ContactScene, balls: BallSet, state: SteadyState, loads: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray, ContactEvaluation]:
        """Scaled residuals: (B, 6) sphere balance, (B,) each sphere's axial push on its nut
        (times the spheres it stands for) and (2,) nut axial balance."""
        e_ball = state.nut_offset[balls.nut]
        # Trial states of the line search may be absurd (huge pressure): their non-finite
        # residuals are rejected by the solver, so numpy's overflow warnings are not news.
        with np.errstate(over="ignore", invalid="ignore"):
            ev = self._evaluate(scene, state.ball_nb, state.kinematics, e_ball, balls.gravity)
        force_scale, moment_scale = self._scales(scene, loads)
        force, moment = ev.force, ev.moment
        if not self.inertial_terms:
            centrifugal, gyroscopic = inertial_actions(scene, state.ball_nb, state.kinematics)
            force, moment = force - centrifugal, moment + gyroscopic
        # Rows ordered like the unknowns: (F_n, F_b) ~ (n, b) offsets, F_t ~ orbital rate.
        ball_res = np.concatenate(
            [force[:, [1, 2, 0]] / force_scale, moment / moment_scale], axis=1
        )
        zhat = geometry.axis_direction(scene.geometry.helix_angle)
        on_nut = np.where(geometry.IS_NUT[None, :, None], ev.groove_force, 0.0).sum(axis=1)
        nut_scale = force_scale * self.config.screw.balls_per_nut
        axial = np.einsum("bi,i->b", on_nut, zhat) * balls.weight / nut_scale
        nut_sum = np.array([axial[balls.nut == k].sum() for k in (0, 1)])
        return ball_res, axial, nut_sum - loads / nut_scale, ev

    def _scales(self, scene: ContactScene, loads: FloatArray) -> tuple[float, float]:
        master, slave = loads.tolist()
        per_ball = max(abs(master), abs(slave)) / self.config.screw.balls_per_nut
        force = max(per_ball, scene.ball_mass * self.config.environment.gravity, 1e-6)
        return force, force * scene.geometry.ball_radius

    def _unknown_mask(self, scene: ContactScene, count: int) -> NDArray[np.bool_]:
        """Which of the 6 unknowns per sphere are solved: the rates are frozen at zero speed."""
        mask = np.ones((count, 6), dtype=bool)
        if scene.screw_speed == 0.0:
            mask[:, 2:] = False
        return mask

    def _newton(
        self,
        scene: ContactScene,
        balls: BallSet,
        state: SteadyState,
        loads: FloatArray,
        warm: bool = False,
        polished: bool = False,
        max_iterations: int = NEWTON_MAX_ITER,
    ) -> tuple[SteadyState, ContactSource, int, float]:
        """Newton iteration from ``state``: (converged state, its contacts, iterations, worst
        scaled residual); SolverError when it does not converge in ``max_iterations``.
        ``warm``: ``state`` comes from the last solution (the compiled solver may then reuse its
        Jacobian); ``polished``: it is the polished solution of this very point
        (:attr:`SteadyState.polished`)."""
        if self.backend == "compiled":
            return self._newton_compiled(scene, balls, state, loads, warm, polished, max_iterations)
        return self._newton_readable(scene, balls, state, loads, max_iterations)

    def _kernel_parameters(self, scene: ContactScene) -> FloatArray:
        """``scene_arrays(scene)`` as the solver kernel takes it (float64 array), kept per
        temperature and speed like the scenes (they depend on nothing else for this model)."""
        key = (scene.temperature, scene.screw_speed)
        params = self._parameters.get(key)
        if params is None:
            from ..kernels.contacts import scene_arrays

            if len(self._parameters) >= SCENE_CACHE_SIZE:
                self._parameters.pop(next(iter(self._parameters)))
            params = self._parameters[key] = np.array(scene_arrays(scene), dtype=np.float64)
        return params

    def _newton_compiled(
        self,
        scene: ContactScene,
        balls: BallSet,
        state: SteadyState,
        loads: FloatArray,
        warm: bool,
        polished: bool,
        max_iterations: int,
    ) -> tuple[SteadyState, KernelSolution, int, float]:
        """The iteration of :meth:`_newton_readable`, compiled, with exact per-sphere Jacobian
        blocks (:mod:`ballscrew_twin.kernels.steady_solver`). ``warm``: ``state`` is the last
        solution of this model, or near it, so the Jacobian blocks of the last solve are reused
        while they converge fast (refreshed when they do not)."""
        solver = self._solver
        count = len(balls.nut)
        z = np.concatenate([state.ball_nb, state.kinematics], axis=1)
        nut_offset = state.nut_offset.copy()
        force_scale, moment_scale = self._scales(scene, loads)
        scales = (force_scale, moment_scale, force_scale * self.config.screw.balls_per_nut)
        stored = self._jacobian
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
            self.inertial_terms,
            self.tolerance,
            self._kernel_parameters(scene),
            max_iterations,
        )
        self._jacobian = (jacobian, scales) if solved.linearisations or reuse else None
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
                f"(scaled residual {worst:.3g} > {self.tolerance:.1g})"
            )
        solved_state = SteadyState(z[:, :2], z[:, 2:], nut_offset, scene.screw_speed, reuse)
        return solved_state, solved, iterations, worst

    def _newton_readable(
        self,
        scene: ContactScene,
        balls: BallSet,
        state: SteadyState,
        loads: FloatArray,
        max_iterations: int,
    ) -> tuple[SteadyState, ContactSource, int, float]:
        count = len(balls.nut)
        mask = self._unknown_mask(scene, count)
        ball_res, _, nut_res, ev = self._residual(scene, balls, state, loads)
        speed_scale = max(abs(scene.screw_speed), 1.0)
        steps = np.array([POSITION_STEP, POSITION_STEP] + [KINEMATIC_STEP_REL * speed_scale] * 4)

        def pack(s: SteadyState) -> FloatArray:
            return np.concatenate([s.ball_nb, s.kinematics], axis=1)

        def unpack(z: FloatArray, e: FloatArray) -> SteadyState:
            return SteadyState(z[:, :2].copy(), z[:, 2:].copy(), e.copy(), scene.screw_speed)

        def merit(b: FloatArray, n: FloatArray) -> float:
            with np.errstate(over="ignore"):  # an absurd trial state squares to inf: rejected
                return float(np.sum(np.where(mask, b, 0.0) ** 2) + np.sum(n**2))

        z = pack(state)
        e = state.nut_offset.copy()
        for iteration in range(1, max_iterations + 1):
            res_b = np.where(mask, ball_res, 0.0)
            worst = float(max(np.max(np.abs(res_b)), np.max(np.abs(nut_res))))
            if worst < self.tolerance:
                return unpack(z, e), ev, iteration - 1, worst
            # Finite-difference Jacobian: spheres are independent given their nut's offset.
            jac = np.zeros((count, 6, 6))
            jac_nut_z = np.zeros((count, 6))
            # Central differences: contact switching makes one-sided slopes unreliable.
            for j in range(6):
                if not mask[:, j].any():  # frozen everywhere: the column becomes identity below
                    continue
                zp, zm = z.copy(), z.copy()
                zp[:, j] += steps[j]
                zm[:, j] -= steps[j]
                rb_p, ax_p, _, _ = self._residual(scene, balls, unpack(zp, e), loads)
                rb_m, ax_m, _, _ = self._residual(scene, balls, unpack(zm, e), loads)
                jac[:, :, j] = (rb_p - rb_m) / (2.0 * steps[j])
                jac_nut_z[:, j] = (ax_p - ax_m) / (2.0 * steps[j])  # sphere i on its own nut
            rb_p, _, rn_p, _ = self._residual(scene, balls, unpack(z, e + POSITION_STEP), loads)
            rb_m, _, rn_m, _ = self._residual(scene, balls, unpack(z, e - POSITION_STEP), loads)
            jac_z_e = (rb_p - rb_m) / (2.0 * POSITION_STEP)  # (B, 6)
            jac_e_e = (rn_p - rn_m) / (2.0 * POSITION_STEP)  # (2,)
            # Frozen unknowns: identity rows/columns.
            frozen = ~mask
            jac = np.where(frozen[:, :, None] | frozen[:, None, :], 0.0, jac)
            idx = np.nonzero(frozen)
            jac[idx[0], idx[1], idx[1]] = 1.0
            jac_z_e = np.where(frozen, 0.0, jac_z_e)
            jac_nut_z = np.where(frozen, 0.0, jac_nut_z)
            # Newton step with a backtracking line search on the squared residual; a step
            # that does not decrease it is still taken once it is short (leaves flat spots).
            diag = np.abs(np.einsum("bii->bi", jac)) + 1e-30
            dz, de = self._damped_step(
                jac, jac_z_e, jac_nut_z, jac_e_e, res_b, nut_res, diag, DIAGONAL_SHIFT, balls
            )
            dz = np.where(mask, dz, 0.0)
            base = merit(ball_res, nut_res)
            step = 1.0
            for _ in range(LINE_SEARCH_STEPS):
                trial = unpack(z + step * dz, e + step * de)
                rb, _, rn, ev_t = self._residual(scene, balls, trial, loads)
                finite = bool(np.isfinite(rb).all() and np.isfinite(rn).all())
                if finite and (merit(rb, rn) < base or step < MIN_STEP):
                    break
                step *= 0.5
            else:  # no trial step gave a finite residual
                raise SolverError(
                    "steady state: every line-search step gave a non-finite residual "
                    f"(iteration {iteration}, scaled residual {base**0.5:.3g})"
                )
            z, e = z + step * dz, e + step * de
            ball_res, nut_res, ev = rb, rn, ev_t
        worst = float(max(np.max(np.abs(np.where(mask, ball_res, 0.0))), np.max(np.abs(nut_res))))
        if worst < self.tolerance:  # the last update converged
            return unpack(z, e), ev, max_iterations, worst
        raise SolverError(
            f"steady state did not converge in {max_iterations} iterations "
            f"(scaled residual {worst:.3g} > {self.tolerance:.1g})"
        )

    @staticmethod
    def _damped_step(
        jac: FloatArray,
        jac_z_e: FloatArray,
        jac_nut_z: FloatArray,
        jac_e_e: FloatArray,
        res_b: FloatArray,
        nut_res: FloatArray,
        diag: FloatArray,
        damping: float,
        balls: BallSet,
    ) -> tuple[FloatArray, FloatArray]:
        """Damped Newton step of the bordered system (sphere blocks + one offset per nut).

        Sphere blocks J_i dz_i + J_ie de = -r_i, nut rows sum_i J_ei dz_i + J_ee de = -g; the
        blocks are eliminated (Schur complement) so the cost is linear in the sphere count.
        """
        damped = jac + damping * diag[:, :, None] * np.eye(6)
        try:
            inv_r = np.linalg.solve(damped, res_b[..., None])[..., 0]
            inv_e = np.linalg.solve(damped, jac_z_e[..., None])[..., 0]
        except np.linalg.LinAlgError as err:
            raise SolverError(f"steady state: singular sphere Jacobian ({err})") from err
        de = np.zeros(2)
        with np.errstate(over="ignore", invalid="ignore"):  # absurd iterates: checked below
            for k in (0, 1):
                members = balls.nut == k
                schur = jac_e_e[k] * (1.0 + damping) - np.sum(jac_nut_z[members] * inv_e[members])
                rhs = -nut_res[k] + np.sum(jac_nut_z[members] * inv_r[members])
                de[k] = rhs / schur if schur != 0.0 else 0.0
        if not (np.isfinite(de).all() and np.isfinite(inv_r).all()):
            raise SolverError("steady state: the Newton step is not finite (diverging iterate)")
        return -(inv_r + inv_e * de[balls.nut][:, None]), de

    def solve(self, op: OperatingPoint, warm_start: SteadyState | None = None) -> SteadySolution:
        """Solve the steady state at ``op`` (warm-started from ``warm_start`` or the last one)."""
        op.validate()
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
            if len(self._loads) >= SCENE_CACHE_SIZE:
                self._loads.pop(next(iter(self._loads)))
            loads = self._loads[(op.preload, op.axial_load)] = self.nut_axial_loads(op)
        previous = warm_start if warm_start is not None else self._warm
        count = len(balls.nut)
        if previous is not None and previous.ball_nb.shape[0] == count:
            predicted = self._predicted(op, count) if warm_start is None else None
            # A point among the last two solved starts from its own solution (polished or not).
            own = predicted is not None and any([predicted is s for _, s in self._history])
            start = previous
            if predicted is not None:
                start = predicted
            elif start.screw_speed != op.screw_speed:
                start = self._rescaled(start, scene, balls, op.screw_speed)
            try:
                state, ev, iterations, residual = self._newton(
                    scene, balls, start, loads, warm=True, polished=own and start.polished
                )
            except SolverError:
                state = previous  # not a solution of op: solved cold below
            # One branch (docs/model.md): a warm solve that failed or left the model's branch
            # is replaced by the cold solve (the start-up path); a point solved again from its
            # own solution stays where it was solved.
            if state is previous or not (
                own or self._keeps_branch(op, previous, state, warm_start)
            ):
                state, ev, iterations, residual = self._cold_solve(op, balls, loads)
        else:
            state, ev, iterations, residual = self._cold_solve(op, balls, loads)
        self._warm = state
        self._warm_loads = (op.temperature, op.preload, op.axial_load)
        if self.backend == "compiled":
            quantities = (op.screw_speed, op.temperature, op.preload, op.axial_load)
            self._history = [*self._history[-1:], (quantities, state)]
        return self._assemble(op, mode, scene, balls, state, ev, iterations, residual)

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

    def _predicted(self, op: OperatingPoint, count: int) -> SteadyState | None:
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
        if len(self._history) < 2:
            return None
        (q0, old), (q1, last) = self._history
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
        self._solver.extrapolate(
            (old.ball_nb, old.kinematics, old.nut_offset, q0[0]),
            (last.ball_nb, last.kinematics, last.nut_offset, q1[0]),
            s,
            speed,
            start.ball_nb,
            start.kinematics,
            start.nut_offset,
        )
        return start

    def _rescaled(
        self, start: SteadyState, scene: ContactScene, balls: BallSet, speed: float
    ) -> SteadyState:
        """Warm start at another speed: rates scale with the speed (same rolling pattern)."""
        if start.screw_speed != 0.0 and speed != 0.0:
            kin = start.kinematics * (speed / start.screw_speed)
        elif speed != 0.0:
            kin = self._rolling_kinematics(scene, balls, start.ball_nb, start.nut_offset)
        else:
            kin = np.zeros_like(start.kinematics)
        return SteadyState(start.ball_nb.copy(), kin, start.nut_offset.copy(), speed)

    def _cold_solve(
        self, op: OperatingPoint, balls: BallSet, loads: FloatArray
    ) -> tuple[SteadyState, ContactSource, int, float]:
        """Solve from no warm start: :meth:`_cold_solve_direct`, or, with the compiled solver
        and more than one sphere per nut, from the averaged problem first
        (:meth:`_solve_from_averaged`) and directly when that fails."""
        if self.backend == "compiled" and len(balls.nut) > 2:
            try:
                return self._solve_from_averaged(op, balls, loads)
            except SolverError:
                pass  # the averaged solution is no start for this problem: solve it directly
        return self._cold_solve_direct(op, balls, loads)

    def _averaged_balls(self, balls: BallSet) -> BallSet:
        """One sphere per nut standing for all of it, under the mean of its spheres' gravity
        (in Frenet components): the symmetric problem closest to ``balls`` (on a vertical screw
        every sphere's gravity is that mean, and the problem is the symmetric one)."""
        key = f"averaged {len(balls.nut)}"
        averaged = self._ball_sets.get(key)
        if averaged is None:
            nut = np.array([0, 1])
            weight = np.array([float(np.sum(balls.weight[balls.nut == k])) for k in (0, 1)])
            gravity = np.stack([np.mean(balls.gravity[balls.nut == k], axis=0) for k in (0, 1)])
            averaged = BallSet(nut=nut, azimuth=np.zeros(2), weight=weight, gravity=gravity)
            self._ball_sets[key] = averaged
        return averaged

    def _solve_from_averaged(
        self, op: OperatingPoint, balls: BallSet, loads: FloatArray
    ) -> tuple[SteadyState, ContactSource, int, float]:
        """Cold solve of the averaged problem (:meth:`_averaged_balls`, two spheres), then every
        sphere warm-started from its nut's sphere, with that sphere's Jacobian block (its nut
        row scaled to the one sphere it now stands for): the cost of a cold solve of two spheres
        and a warm solve of all (compiled solver only)."""
        averaged = self._averaged_balls(balls)
        state, _, iterations, _ = self._cold_solve_direct(op, averaged, loads)
        assert self._jacobian is not None  # a cold solve computes the blocks
        blocks, scales = self._jacobian
        spread = blocks[balls.nut]  # a copy
        spread[:, 6, :] *= (balls.weight / averaged.weight[balls.nut])[:, None]
        self._jacobian = (spread, scales)
        start = SteadyState(
            state.ball_nb[balls.nut],
            state.kinematics[balls.nut],
            state.nut_offset.copy(),
            state.screw_speed,
        )
        scene = self.scene(op.temperature, op.screw_speed)
        solved, ev, more, residual = self._newton(scene, balls, start, loads, warm=True)
        return solved, ev, iterations + more, residual

    def _cold_solve_direct(
        self, op: OperatingPoint, balls: BallSet, loads: FloatArray
    ) -> tuple[SteadyState, ContactSource, int, float]:
        """The start-up path (:meth:`_startup_continuation`); where it fails, the static
        equilibrium and then the speed (:meth:`_speed_continuation`); where that fails too,
        along the preload from a heavier point (:meth:`_preload_continuation`). All are fixed
        paths: the result depends on the operating point alone."""
        try:
            return self._startup_continuation(op, balls, loads)
        except SolverError:
            pass
        try:
            return self._speed_continuation(op, balls, loads)
        except SolverError as err:
            if op.screw_speed == 0.0:
                raise
            try:
                return self._preload_continuation(op, balls, loads)
            except SolverError:
                raise err from None

    def _startup_continuation(
        self, op: OperatingPoint, balls: BallSet, loads: FloatArray
    ) -> tuple[SteadyState, ContactSource, int, float]:
        """The steady state reached by quasi-static start-up: solved cold at
        :data:`STARTUP_SPEED` (of ``op``'s sign), then the speed raised in steps to ``op``'s,
        each warm-started from the last with the rates scaled by the speed. A step whose rates
        over the speed move by more than :data:`BRANCH_JUMP` (:func:`rate_change`) or that does
        not converge is retried shorter (:meth:`_startup_step`). Where none down to
        :data:`STARTUP_MIN_RATIO` does, longer steps are tried (ratio excess times 4 each) and
        the first that converges is taken (the last at :data:`STARTUP_MAX_RATIO` itself): to
        where the branch ends (a real screw jumps there too).
        A longer step that would end past the target speed, where the state the path was on
        ends just below it, solves past it and follows the state reached back down to the
        target (:meth:`_startup_return`; the target itself lies in the basin of the ended
        state and does not converge). Raises SolverError when no step up to
        :data:`STARTUP_MAX_RATIO` converges. At or below the start-up speed:
        :meth:`_speed_continuation`."""
        target = abs(op.screw_speed)
        if target <= STARTUP_SPEED:
            return self._speed_continuation(op, balls, loads)
        sign = math.copysign(1.0, op.screw_speed)
        state, ev, total, residual = self._speed_continuation(
            replace(op, screw_speed=sign * STARTUP_SPEED), balls, loads
        )
        speed = STARTUP_SPEED
        ratio = STARTUP_MAX_RATIO
        previous: SteadyState | None = None
        while speed < target:
            step = self._startup_step(op, balls, loads, (previous, state), speed, ratio)
            if step is None:  # no step converges on the branch: the longest converged one
                ratio = STARTUP_MIN_RATIO
                while step is None:
                    if ratio >= STARTUP_MAX_RATIO:
                        raise SolverError(
                            f"steady state: start-up path stopped at {sign * speed:.6g} rad/s"
                        )
                    ratio = min(1.0 + 4.0 * (ratio - 1.0), STARTUP_MAX_RATIO)
                    step = self._startup_step(
                        op, balls, loads, (previous, state), speed, ratio, jump=True
                    )
            solved, ev, iterations, residual = step[0]
            total += iterations
            previous, state, speed, ratio = state, solved, step[1], step[2]
            ratio = min(1.0 + STARTUP_GROWTH * (ratio - 1.0), STARTUP_MAX_RATIO)
        return state, ev, total, residual

    def _startup_step(
        self,
        op: OperatingPoint,
        balls: BallSet,
        loads: FloatArray,
        path: tuple[SteadyState | None, SteadyState],
        speed: float,
        ratio: float,
        jump: bool = False,
    ) -> tuple[tuple[SteadyState, ContactSource, int, float], float, float] | None:
        """One step of :meth:`_startup_continuation` from the last state of ``path`` (the one
        before it, or None, and the last) at |speed| [rad/s]: the longest speed ratio from
        ``ratio`` down (its excess halved each time) to :data:`STARTUP_MIN_RATIO` whose solve,
        started from :func:`secant_start`, converges with a :func:`rate_change` within
        :data:`BRANCH_JUMP` (``jump``: ``ratio`` alone, any rate change, and past the target
        when the step to the target does not converge). Returns (solve, |speed| reached,
        ratio) or None."""
        target = abs(op.screw_speed)
        while True:
            step_speed = min(speed * ratio, target)
            solve = self._startup_solve(op, balls, loads, path, step_speed, jump)
            if solve is not None and (jump or rate_change(path[1], solve[0]) <= BRANCH_JUMP):
                return solve, step_speed, ratio
            if jump and solve is None and speed * ratio > target:
                # The jump ends past the target: the state it reaches, followed back down.
                solve = self._startup_solve(op, balls, loads, path, speed * ratio, jump)
                if solve is not None:
                    solve = self._startup_return(op, balls, loads, solve, speed * ratio)
                return None if solve is None else (solve, target, ratio)
            if jump or ratio <= STARTUP_MIN_RATIO:
                return None
            ratio = max(1.0 + 0.5 * (ratio - 1.0), STARTUP_MIN_RATIO)

    def _startup_solve(
        self,
        op: OperatingPoint,
        balls: BallSet,
        loads: FloatArray,
        path: tuple[SteadyState | None, SteadyState],
        speed: float,
        jump: bool = False,
    ) -> tuple[SteadyState, ContactSource, int, float] | None:
        """Newton solve at |speed| [rad/s] (``op``'s sign, temperature and ``loads``) started
        from the last state of ``path`` (on the secant through both when the first is not
        None) with at most :data:`STARTUP_MAX_ITER` iterations (``jump``, a step to another
        state: :data:`NEWTON_MAX_ITER`); None when it does not converge."""
        signed = math.copysign(speed, op.screw_speed)
        scene = self.scene(op.temperature, signed)
        previous, state = path
        if previous is None:
            start = self._rescaled(state, scene, balls, signed)
        else:
            start = secant_start(previous, state, signed)
        try:
            return self._newton(
                scene,
                balls,
                start,
                loads,
                warm=True,
                max_iterations=NEWTON_MAX_ITER if jump else STARTUP_MAX_ITER,
            )
        except SolverError:
            return None

    def _startup_return(
        self,
        op: OperatingPoint,
        balls: BallSet,
        loads: FloatArray,
        solve: tuple[SteadyState, ContactSource, int, float],
        speed: float,
    ) -> tuple[SteadyState, ContactSource, int, float] | None:
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
            step = self._startup_solve(op, balls, loads, (previous, solve[0]), step_speed)
            if step is not None and rate_change(solve[0], step[0]) <= BRANCH_JUMP:
                previous, solve, speed = solve[0], step, step_speed
                total += step[2]
                ratio = min(1.0 + STARTUP_GROWTH * (ratio - 1.0), STARTUP_MAX_RATIO)
            elif ratio <= STARTUP_MIN_RATIO:
                return None
            else:
                ratio = max(1.0 + 0.5 * (ratio - 1.0), STARTUP_MIN_RATIO)
        return solve[0], solve[1], total, solve[3]

    def _preload_continuation(
        self, op: OperatingPoint, balls: BallSet, loads: FloatArray
    ) -> tuple[SteadyState, ContactSource, int, float]:
        """Cold solve at ``op`` with :data:`PRELOAD_CONTINUATION_LIFT` more preload [N]
        (:meth:`_speed_continuation`), then down to ``op``'s preload in
        :data:`PRELOAD_CONTINUATION_STEPS` steps uniform in sqrt(preload), each warm-started
        from the previous one (same speed and temperature) and, where that fails, solved by
        :meth:`_speed_continuation`; ``loads`` are ``op``'s."""
        heavy = replace(op, preload=op.preload + PRELOAD_CONTINUATION_LIFT)
        state, ev, total, residual = self._speed_continuation(
            heavy, balls, self.nut_axial_loads(heavy)
        )
        scene = self.scene(op.temperature, op.screw_speed)
        roots = np.linspace(
            math.sqrt(heavy.preload), math.sqrt(op.preload), PRELOAD_CONTINUATION_STEPS + 1
        )
        for k, root in enumerate(roots[1:].tolist()):
            last = k == PRELOAD_CONTINUATION_STEPS - 1
            step_op = op if last else replace(op, preload=root * root)
            step_loads = loads if last else self.nut_axial_loads(step_op)
            try:
                state, ev, iterations, residual = self._newton(scene, balls, state, step_loads)
            except SolverError:
                state, ev, iterations, residual = self._speed_continuation(
                    step_op, balls, step_loads
                )
            total += iterations
        return state, ev, total, residual

    def _speed_continuation(
        self, op: OperatingPoint, balls: BallSet, loads: FloatArray
    ) -> tuple[SteadyState, ContactSource, int, float]:
        """Static equilibrium first (robust: smooth Hertz only), then the speed.

        If the direct step to full speed fails, the speed is raised in stages (continuation,
        :data:`CONTINUATION_SCHEDULES`), each stage warm-started from the previous one.
        """
        static_scene = self.scene(op.temperature, 0.0)
        state = self._initial_state(static_scene, balls, loads)
        state, ev, total, residual = self._newton(static_scene, balls, state, loads)
        if op.screw_speed == 0.0:
            return state, ev, total, residual
        last_error: SolverError | None = None
        for attempt in CONTINUATION_SCHEDULES:
            current = state
            try:
                for fraction in attempt:
                    speed = op.screw_speed * fraction
                    scene = self.scene(op.temperature, speed)
                    current = self._rescaled(current, scene, balls, speed)
                    current, ev, iterations, residual = self._newton(scene, balls, current, loads)
                    total += iterations
                return current, ev, total, residual
            except SolverError as err:
                last_error = err
        assert last_error is not None
        raise last_error

    def forget_warm_start(self) -> None:
        """Make the next solve start cold (used by benchmarks and after a scene change)."""
        self._warm = None
        self._warm_loads = None
        self._jacobian = None
        self._history = []

    def evaluate(self, op: OperatingPoint) -> TwinOutput:
        """Drag torque and contact states at ``op`` (warm-started from the previous call)."""
        return self.solve(op).output

    # ------------------------------------------------------------------ results

    def _assemble(
        self,
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
            return self._assemble_compiled(op, mode, scene, balls, state, ev, iterations, residual)
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
        lift_power = self._potential_energy_rate(scene, balls, state)
        gravity_torque = lift_power / speed if speed != 0.0 else 0.0
        contacts = _contact_states(balls, ev)
        output = TwinOutput(
            drag_torque=total,
            nut_torque=nut_torque,
            breakdown=breakdown,
            fidelity=f"{self.name}-{mode}",
            operating_point=op,
            contacts=contacts,
            notes=self._fixed_notes(mode, scene, len(balls.nut)),
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

    def _assemble_compiled(
        self,
        op: OperatingPoint,
        mode: str,
        scene: ContactScene,
        balls: BallSet,
        state: SteadyState,
        solved: KernelSolution,
        iterations: int,
        residual: float,
    ) -> SteadySolution:
        """:meth:`_assemble` from the compiled solver's own summary of the solution (the same
        sums, taken in the kernel) and its per-contact states (views of one array)."""
        solver = self._solver
        summary = solved.summary.tolist()
        speed = op.screw_speed
        # The kernel divided the powers by the speed (zero at standstill), as _assemble does,
        # and summed the mechanisms in their order, as TorqueBreakdown.total does.
        torque = solver.SUMMARY_TORQUE
        breakdown = filled(
            TorqueBreakdown,
            lubricant_shear=summary[torque],
            dry_contact=summary[torque + 1],
            rolling_resistance=summary[torque + 2],
            hysteresis=summary[torque + 3],
            curvature=summary[torque + 4],
            spin=summary[torque + 5],
        )
        nut = solver.SUMMARY_NUT_TORQUE
        lift_power = -(summary[solver.SUMMARY_BALLS_POWER] + self._nut_gravity_power(scene))
        output = filled(
            TwinOutput,
            drag_torque=summary[solver.SUMMARY_DRAG],
            nut_torque=(summary[nut], summary[nut + 1]),
            breakdown=breakdown,
            fidelity=f"{self.name}-{mode}",
            operating_point=op,
            contacts=self._kernel_contact_states(mode, balls, solved),
            notes=self._fixed_notes(mode, scene, len(balls.nut)),
        )
        return filled(
            SteadySolution,
            output=output,
            state=state,
            balls=balls,
            contact_source=solved,
            screw_torque_direct=summary[solver.SUMMARY_DIRECT],
            gravity_torque=lift_power / speed if speed != 0.0 else 0.0,
            iterations=iterations,
            residual=residual,
        )

    def _kernel_contact_states(
        self, mode: str, balls: BallSet, solved: KernelSolution
    ) -> ContactStates:
        """:func:`_contact_states` of the compiled solver's state rows (no copies; the index
        arrays, the same for every solve of a mode, are shared and read-only)."""
        index = self._contact_index.get(mode)
        if index is None:
            count = len(balls.nut)
            index = (
                np.repeat(np.arange(count), 4),
                np.repeat(balls.nut, 4),
                np.tile(np.arange(4), count),
            )
            for array in index:
                array.flags.writeable = False
            self._contact_index[mode] = index
        sphere, nut, half_groove = index
        in_contact = solved.active.reshape(-1)
        rows = self._solver.STATE_ROWS
        return contact_states_from_rows(sphere, nut, half_groove, in_contact, solved.states, rows)

    def _fixed_notes(self, mode: str, scene: ContactScene, count: int) -> tuple[str, ...]:
        """The notes of :meth:`_assemble` (they depend on the mode, the temperature and
        whether the screw stands), kept per temperature."""
        key = (mode, scene.temperature, scene.screw_speed == 0.0)
        notes = self._notes.get(key)
        if notes is None:
            if len(self._notes) >= SCENE_CACHE_SIZE:
                self._notes.pop(next(iter(self._notes)))
            lines = [f"steady state, {mode} mode ({count} spheres solved)"]
            if not self.inertial_terms:
                lines.append("centrifugal force and gyroscopic moment of the spheres dropped")
            if scene.screw_speed == 0.0:
                lines.append("zero speed: nothing slides, drag torque 0 (breakaway not modelled)")
            lines.extend(self._spacing_notes(scene))
            notes = self._notes[key] = tuple(lines)
        return notes

    def _nut_gravity_power(self, scene: ContactScene) -> float:
        """Gravity's power on the two nuts, moving at -Omega p/(2 pi) z [W] (vertical screw)."""
        if self.config.screw.orientation != "vertical":
            return 0.0
        lead_rate = scene.geometry.lead / (2.0 * math.pi)
        g = self.config.environment.gravity
        return 2.0 * self.config.screw.nut_mass * g * scene.screw_speed * lead_rate

    def _potential_energy_rate(
        self, scene: ContactScene, balls: BallSet, state: SteadyState
    ) -> float:
        """Rate of change of the gravitational energy of spheres and nuts [W].

        Sphere i moves with v = w_B (z x r + p/(2 pi) z) relative to the screw plus
        Omega z x r; each nut with -Omega p/(2 pi) z. On a horizontal screw the spheres' share
        does not vanish (1.75 turns are not a whole number), on a vertical one the nuts' weight
        dominates.
        """
        geom = scene.geometry
        lead_rate = geom.lead / (2.0 * math.pi)
        z_t, _, z_b = geometry.axis_direction(geom.helix_angle)  # z has no n-component
        r_n = state.ball_nb[:, 0] - geom.pitch_radius  # centre from the axis: (0, r_n, b)
        r_b = state.ball_nb[:, 1]
        w_ball = state.kinematics[:, 0]
        orbit_rate = w_ball + scene.screw_speed
        along = w_ball * lead_rate
        # v = (w_B + Omega) z x r + w_B p/(2 pi) z, z x r = (-z_b r_n, -z_t r_b, z_t r_n).
        acc = balls.gravity
        g_dot_v = (
            acc[:, 0] * (orbit_rate * (-z_b * r_n) + along * z_t)
            + acc[:, 1] * (orbit_rate * (-z_t * r_b))
            + acc[:, 2] * (orbit_rate * (z_t * r_n) + along * z_b)
        )
        balls_power = scene.ball_mass * float(np.sum(balls.weight * g_dot_v))
        return -(balls_power + self._nut_gravity_power(scene))

    def _spacing_notes(self, scene: ContactScene) -> list[str]:
        """Sphere-to-sphere contact is skipped when equally spaced spheres cannot touch."""
        geom = self.config.screw
        length = 2.0 * math.pi * geom.pitch_radius * geom.loaded_turns / math.cos(geom.helix_angle)
        gap = length / geom.balls_per_nut - 2.0 * scene.geometry.ball_radius
        if gap > 0.0:
            return [f"sphere-to-sphere contacts skipped: equal spacing leaves {gap * 1e3:.3f} mm"]
        return ["spheres are packed without gap: sphere-to-sphere contact not resolved here"]


def inertial_actions(
    scene: ContactScene, ball_nb: FloatArray, kinematics: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """d'Alembert terms of the orbiting spheres that the steady contact laws add (section 7).

    Centrifugal force m (Omega + w_B)^2 r_perp on the centre (r_perp its distance vector from
    the axis) and gyroscopic moment (Omega + w_B) z x I omega_abs, omega_abs = omega + Omega z,
    both in Frenet components; ``evaluate_contacts`` (steady use) adds the force and subtracts
    the moment.

    Args:
        scene: constants of the operating point (screw speed Omega [rad/s], sphere mass [kg]
            and inertia [kg m^2], geometry).
        ball_nb: (B, 2) ball-centre offsets (n, b) from the ideal helix [m].
        kinematics: (B, 4) orbital rate w_B and angular velocity (t, n, b) relative to the
            screw [rad/s].

    Returns:
        (centrifugal force (B, 3) [N], gyroscopic moment (B, 3) [N m]).
    """
    geom = scene.geometry
    zhat = geometry.axis_direction(geom.helix_angle)
    r_ball = np.stack(
        [np.zeros(len(ball_nb)), ball_nb[:, 0] - geom.pitch_radius, ball_nb[:, 1]], axis=-1
    )
    orbit_rate = scene.screw_speed + kinematics[:, 0]
    r_perp = r_ball - np.einsum("bi,i->b", r_ball, zhat)[:, None] * zhat
    centrifugal = (scene.ball_mass * orbit_rate**2)[:, None] * r_perp
    omega_abs = kinematics[:, 1:4] + scene.screw_speed * zhat
    gyroscopic = orbit_rate[:, None] * np.cross(zhat, scene.ball_inertia * omega_abs)
    return np.asarray(centrifugal), np.asarray(gyroscopic)


def along_line(old: SteadyState, last: SteadyState, fraction: float, speed: float) -> SteadyState:
    """Start at ``speed`` [rad/s] on the line through two solutions at speeds of its sign:
    offsets [m] and rates over the speed [-] (the rolling pattern) moved beyond ``last`` by
    ``fraction`` [-] times their step from ``old``, the rates then times ``speed``. The readable
    form of :func:`~ballscrew_twin.kernels.steady_solver.extrapolate`."""
    rates = last.kinematics / last.screw_speed
    rates = rates + fraction * (rates - old.kinematics / old.screw_speed)
    return SteadyState(
        last.ball_nb + fraction * (last.ball_nb - old.ball_nb),
        rates * speed,
        last.nut_offset + fraction * (last.nut_offset - old.nut_offset),
        speed,
    )


def secant_start(previous: SteadyState, last: SteadyState, speed: float) -> SteadyState:
    """Start at ``speed`` [rad/s] on the line through two solutions at speeds of its sign, in
    log |speed| (:func:`along_line`): the fraction log(speed / last speed) / log(last speed /
    previous speed), limited to [0, 2]."""
    span = math.log(last.screw_speed / previous.screw_speed)
    fraction = min(max(math.log(speed / last.screw_speed) / span, 0.0), 2.0)
    return along_line(previous, last, fraction, speed)


def continues_branch(previous: SteadyState, solved: SteadyState) -> bool:
    """``solved``, warm-started from ``previous``, is on its branch: at standstill (one static
    equilibrium), or at a speed of the same sign with no :func:`rate_change` beyond
    :data:`BRANCH_JUMP`."""
    if solved.screw_speed == 0.0:
        return True
    if previous.screw_speed * solved.screw_speed <= 0.0:
        return False
    return rate_change(previous, solved) <= BRANCH_JUMP


def rate_change(old: SteadyState, new: SteadyState) -> float:
    """Largest change of a sphere's rate over the screw speed between two solutions at speeds
    of one sign, each relative to 1 + its old size [-] (orbital rate and angular velocity:
    about 0.5 and 6 times the screw speed when rolling)."""
    before = old.kinematics / old.screw_speed
    after = new.kinematics / new.screw_speed
    return float(np.max(np.abs(after - before) / (1.0 + np.abs(before))))


def _contact_states(balls: BallSet, ev: ContactEvaluation) -> ContactStates:
    """Flatten (B, 4) contact arrays into one row per sphere and half groove."""
    count = len(balls.nut)
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
        nut=np.repeat(balls.nut, 4),
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
