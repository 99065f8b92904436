"""High-fidelity dynamic model: every sphere in 6 DOF, the screw, both nuts (paper section 2).

Bodies, in the inertial frame with z up along the screw axis:

- each sphere: centre position and velocity (3 + 3), angular velocity (3); a perfect sphere
  needs no orientation. Newton-Euler: m dv/dt = F + m g, I domega/dt = M.
- the screw: angle phi and speed Omega about z, driven by a PI speed controller:
  I_s dOmega/dt = T_motor + T_contacts.
- each nut: axial position z_k and speed (rotation held by its guide):
  M_n d^2 z_k/dt^2 = F_contacts,k + P_k(t) - M_n g.

The contact actions come from the same laws as the steady-state model (``contact_forces`` /
its numba kernel) in their dynamic form: each sphere is located on the thread by its helix
parameter (the point of the ball-centre helix whose normal plane contains the centre, Eq. 4),
its centre velocity relative to the screw is given, the nut groove is the screw's helicoid
shifted axially by z_k + phi p / (2 pi) (a nut turned by -phi relative to the screw is a nut
shifted by phi p / (2 pi)), and it slides axially relative to the thread at dz_k/dt +
Omega p / (2 pi).

Integration (docs/model.md, section 10): the regularised friction makes the sphere velocities
stiff (time constant m / (dF/dv) ~ 1 ns), the contact springs less so (~100 kHz). Velocities
of spheres, nuts and screw are advanced by backward Euler, solved by Newton iterations from a
polynomial extrapolation of the last steps' velocities (PREDICTOR_ORDER) with the Jacobian of
the contact actions with respect to those velocities (finite differences, kept between steps;
refreshed when a correction is needed and it is older than ``jacobian_interval`` steps or the
contact set changed, and within a step whenever an iteration contracts the residual by less
than JACOBIAN_REFRESH_RATIO); positions move with the new velocities (semi-implicit Euler:
the contact actions at the step's start positions) or, with ``implicit_positions``, the contact
actions are those with the sphere centres and the screw angle at the end of the step (backward
Euler in these positions, stable above the contact springs' ~3 us limit; docs/model.md section
10).
The step is the user's. :meth:`DynamicModel._step` is the readable reference; the default runs
the same algorithm compiled (kernels/dynamic_step.py driven by dynamic_compiled.py, tested
equal). The state, commands and step report types are in dynamic_state.py.

Optional: contacts between neighbouring spheres of a nut (sphere_contact.py) in the implicit
step, and a jammed sphere (rotation held at zero, faults.py).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from ..errors import ConfigError, OperatingPointError
from ..kernels.solver_settings import (
    HELIX_NEWTON_STEPS,
    JACOBIAN_REFRESH_RATIO,
    PREDICTOR_ORDER,
    STEP_BACKTRACKS,
    STEP_NEWTON_MAX,
    STEP_TOLERANCE,
    VELOCITY_STEP,
)
from ..params import TwinConfig, check_number, limits
from ..physics import geometry
from ..physics.contact_types import ContactEvaluation
from .base import DISSIPATION_KEYS, OperatingPoint
from .contact_forces import evaluate_contacts, make_scene
from .dynamic_compiled import CompiledStep
from .dynamic_state import Commands, DynamicState, SpeedController, StepReport
from .faults import Faults
from .sphere_contact import SpherePairContact, sphere_pair_contact
from .steady import SteadyStateModel

FloatArray = NDArray[np.float64]
ContactFunction = Callable[..., ContactEvaluation]

#: Extrapolation u_n, u_{n-1}, ... -> u_{n+1} of each order (kernels/dynamic_step.py has a copy).
PREDICTOR_COEFFICIENTS = ((1.0,), (2.0, -1.0), (3.0, -3.0, 1.0), (4.0, -6.0, 4.0, -1.0))
#: Allowed integration steps [s] (a scenario's ``time_step`` has the same range).
TIME_STEP_LIMITS = limits("s", 0.0, 1e-4, lo_open=True)
#: Allowed steps between two refreshes of the velocity Jacobian [-].
JACOBIAN_INTERVAL_LIMITS = limits("-", 1, math.inf, integer=True)


@dataclass
class DynamicModel:
    """Multibody model of the double-nut ball screw with all loaded spheres.

    Args:
        config: parameter set.
        temperature: bulk temperature [K] (constant during a run, as in the paper).
        time_step: integration step [s].
        jacobian_interval: steps after which the velocity Jacobian is refreshed when a Newton
            correction needs it (at once when a contact opens or closes). 1, the default, is
            needed through impacts and the preload transient: saturated damping and friction
            are not smooth enough for a stale linearisation (measured, docs/model.md section
            10).
        controller: PI gains of the screw speed controller.
        backend: ``"compiled"`` (numba kernel) or ``"reference"`` (numpy) contact laws.
        faults: defective spheres and raceway spalls (models/faults.py).
        compiled_step: with the compiled backend, run the whole step in numba
            (:mod:`ballscrew_twin.kernels.dynamic_step`, tested equal to :meth:`_step`, the
            readable reference); False, or the reference backend: :meth:`_step` in Python.
        sphere_contacts: contacts between neighbouring spheres of a nut along the helix
            (paper section 2.5, :mod:`.sphere_contact`), inside the implicit step. They run
            in the Python step only (the compiled step does not carry them yet).
        implicit_positions: evaluate the contact actions with the sphere centres at the end
            of the step, x_n + dt v_{n+1}, and the screw at phi_n + dt Omega_{n+1} (backward
            Euler in these positions; the nut positions stay at the step's start), instead of
            at x_n, phi_n.
    """

    config: TwinConfig
    temperature: float
    time_step: float = 1e-6
    jacobian_interval: int = 1
    controller: SpeedController = field(default_factory=SpeedController)
    backend: str = "compiled"
    faults: Faults = field(default_factory=Faults)
    compiled_step: bool = True
    sphere_contacts: bool = False
    implicit_positions: bool = False

    def __post_init__(self) -> None:
        OperatingPoint(screw_speed=0.0, temperature=self.temperature, preload=0.0).validate()
        # the package's one number check: the refusal names the setting, its unit and range
        check_number(
            self.time_step, TIME_STEP_LIMITS, "time_step", text=False, error=OperatingPointError
        )
        check_number(
            self.jacobian_interval,
            JACOBIAN_INTERVAL_LIMITS,
            "jacobian_interval",
            text=False,
            error=OperatingPointError,
        )
        self._scene = make_scene(self.config, self.temperature, 0.0)
        geom = self._scene.geometry
        self.geometry = geom
        self._contacts: ContactFunction = evaluate_contacts
        if self.backend == "compiled":
            from ..kernels.contacts import evaluate_contacts_compiled

            self._contacts = evaluate_contacts_compiled
        elif self.backend != "reference":
            raise ConfigError(f"backend = {self.backend!r} must be compiled or reference")
        count = self.config.screw.balls_per_nut
        self.ball_nut = np.repeat(np.array([0, 1]), count)
        self.ball_index = np.tile(np.arange(count), 2)
        self.lead_rate = geom.lead / (2.0 * math.pi)
        self.zhat = geometry.axis_direction(geom.helix_angle)
        self.gravity = np.array([0.0, 0.0, -self.config.environment.gravity])
        if self.config.screw.orientation != "vertical":
            self.gravity = np.array([0.0, -self.config.environment.gravity, 0.0])
        self._nut_offset0 = np.zeros(2)
        self._jacobian: Jacobians | None = None
        # The predictor's memory (_predict, _remember): the velocities at the starts of the
        # last steps, newest first, each (sphere rows (B, 6), screw / nut velocities (3,)); the
        # time [s] the next step starts at if it continues the last one; the order to use.
        self._history: list[tuple[FloatArray, FloatArray]] = []
        self._history_time = math.nan
        self._history_order = 0
        self._jacobian_contacts = np.zeros((0, 4), dtype=bool)
        self._step_location: tuple[FloatArray, tuple[FloatArray, FloatArray, FloatArray]] | None
        self._step_location = None
        self.unconverged_steps = 0  # steps that ended at STEP_NEWTON_MAX iterations
        self.last_step_residual = 0.0  # scaled residual at the end of the last step
        # Work counters of the compiled step (zero with the Python step): contact-law
        # evaluations of all spheres, Jacobian evaluations, Newton iterations, since creation.
        self.work = {"contact_evaluations": 0, "jacobians": 0, "newton_iterations": 0}
        self._jacobian_age = 0
        # Neighbours along the helix: spheres k and k + 1 of the same nut (no recirculation).
        pairs = [
            (i, i + 1) for i in range(2 * count - 1) if self.ball_nut[i] == self.ball_nut[i + 1]
        ]
        self.sphere_pairs = np.array(pairs, dtype=np.int64).reshape(-1, 2)
        # Jacobian colours: neighbours differ in parity, so perturbing one parity at a time
        # gives each sphere's own derivatives of its pair forces (two colours with pairs).
        parity = self.ball_index % 2
        self._colours = [np.ones(2 * count, dtype=bool)]
        if self.sphere_contacts:
            self._colours = [parity == 0, parity == 1]
        self._kernel: CompiledStep | None = None
        if self.compiled_step and self.backend == "compiled" and not self.sphere_contacts:
            self._kernel = CompiledStep(self)

    def set_integrator(self, time_step: float, implicit_positions: bool) -> None:
        """Change the step [s] and the treatment of the sphere positions between two steps (a
        scenario's start phase, simulation.py). The kept Jacobian (it holds dt) and the
        predictor's history (equal steps) are dropped."""
        check_number(
            time_step, TIME_STEP_LIMITS, "time_step", text=False, error=OperatingPointError
        )
        self.time_step = time_step
        self.implicit_positions = implicit_positions
        self._jacobian = None
        self._history, self._history_time, self._history_order = [], math.nan, 0
        if self._kernel is not None:
            self._kernel.set_integrator(time_step, implicit_positions)

    # ----------------------------------------------------------------- initial state

    def initial_state(self, preload: float = 0.0) -> DynamicState:
        """Spheres at the static equilibrium of the steady model at ``preload`` [N], at rest.

        The spheres of each nut are spread evenly along its loaded turns; the master nut's
        turns lie above the slave nut's.
        """
        static = SteadyStateModel(self.config, mode="symmetric").solve(
            OperatingPoint(screw_speed=0.0, temperature=self.temperature, preload=preload)
        )
        screw = self.config.screw
        count = screw.balls_per_nut
        spacing = 2.0 * math.pi * screw.loaded_turns / count
        gap_turns = 2.0 * math.pi * (screw.loaded_turns + 0.5)  # slave turns below the master's
        theta = np.concatenate([np.arange(count) * spacing, np.arange(count) * spacing - gap_turns])
        offsets = static.state.ball_nb[self.ball_nut]
        frames = geometry.frenet_frame(theta, self.geometry.helix_angle)
        position = (
            self._helix_point(theta)
            + offsets[:, 0:1] * frames[:, 1]
            + offsets[:, 1:2] * (frames[:, 2])
        )
        self._nut_offset0 = static.state.nut_offset.copy()
        self._jacobian = None
        self._history, self._history_time, self._history_order = [], math.nan, 0
        if self._kernel is not None:
            self._kernel = CompiledStep(self)
        zeros = np.zeros((2 * count, 3))
        return DynamicState(
            time=0.0,
            screw_angle=0.0,
            screw_speed=0.0,
            controller_integral=0.0,
            nut_position=np.zeros(2),
            nut_velocity=np.zeros(2),
            ball_position=position,
            ball_velocity=zeros.copy(),
            ball_omega=zeros.copy(),
            helix_parameter=theta,
        )

    def _helix_point(self, theta: FloatArray) -> FloatArray:
        """B(theta) of Eq. 2 in the screw frame [m]."""
        r_m = self.geometry.pitch_radius
        return np.stack([r_m * np.cos(theta), r_m * np.sin(theta), self.lead_rate * theta], axis=-1)

    # ----------------------------------------------------------------- contact actions

    def _locate(self, state: DynamicState) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Helix parameter, Frenet frames (screw frame rows t, n, b) and (n, b) offsets.

        Inside :meth:`step` the positions do not change while velocities are iterated, so the
        step locates the spheres once (``_step_location``) for every evaluation it makes.
        """
        cached = self._step_location
        if cached is not None and cached[0] is state.ball_position:
            return cached[1]
        to_screw = _to_screw_frame(state.screw_angle)
        r_s = state.ball_position @ to_screw.T
        theta = state.helix_parameter.copy()
        r_m, lead = self.geometry.pitch_radius, self.lead_rate
        for _ in range(HELIX_NEWTON_STEPS):  # (r - B(theta)) . dB/dtheta = 0
            rel = r_s - self._helix_point(theta)
            tangent = np.stack(
                [-r_m * np.sin(theta), r_m * np.cos(theta), np.full_like(theta, lead)], axis=-1
            )
            bend = np.stack([-r_m * np.cos(theta), -r_m * np.sin(theta), 0 * theta], axis=-1)
            f = np.einsum("bi,bi->b", rel, tangent)
            df = -np.einsum("bi,bi->b", tangent, tangent) + np.einsum("bi,bi->b", rel, bend)
            theta = theta - f / df
        frames = geometry.frenet_frame(theta, self.geometry.helix_angle)
        rel = r_s - self._helix_point(theta)
        nb = np.stack(
            [np.einsum("bi,bi->b", rel, frames[:, 1]), np.einsum("bi,bi->b", rel, frames[:, 2])],
            axis=-1,
        )
        return theta, frames, nb

    def contact_actions(
        self,
        state: DynamicState,
        ball_velocity: FloatArray | None = None,
        ball_omega: FloatArray | None = None,
        nut_velocity: FloatArray | None = None,
        screw_speed: float | None = None,
    ) -> Actions:
        """Contact actions on every sphere (world frame) and each sphere's share on the screw
        and on its nut, at the state's positions and the given (default: the state's)
        velocities."""
        v = state.ball_velocity if ball_velocity is None else ball_velocity
        w = state.ball_omega if ball_omega is None else ball_omega
        vn = state.nut_velocity if nut_velocity is None else nut_velocity
        speed = state.screw_speed if screw_speed is None else screw_speed
        theta, frames, nb = self._locate(state)
        to_screw = _to_screw_frame(state.screw_angle)
        zaxis = np.array([0.0, 0.0, 1.0])
        # Velocities relative to the rotating screw, then in each sphere's Frenet frame.
        v_rel = (v - speed * np.cross(zaxis, state.ball_position)) @ to_screw.T
        w_rel = (w - speed * zaxis) @ to_screw.T
        v_frenet = np.einsum("bij,bj->bi", frames, v_rel)
        w_frenet = np.einsum("bij,bj->bi", frames, w_rel)
        shift = state.nut_position + self.lead_rate * state.screw_angle
        nut_offset = self._nut_offset0 + shift * math.cos(self.geometry.helix_angle)
        slide = vn + speed * self.lead_rate
        if speed != self._scene.screw_speed:
            self._scene = replace(self._scene, screw_speed=speed)
        kin = np.concatenate([np.zeros((len(nb), 1)), w_frenet], axis=1)
        offsets = self.faults.approach_offsets(
            theta, state.screw_angle, self.ball_nut, self.ball_index
        )
        ev = self._contacts(
            self._scene,
            nb,
            kin,
            nut_offset[self.ball_nut],
            np.zeros((len(nb), 3)),
            centre_velocity=v_frenet,
            nut_slide=slide[self.ball_nut],
            approach_offset=offsets,
        )
        to_world = to_screw.T
        force = np.einsum("bji,bj->bi", frames, ev.force) @ to_world.T
        moment = np.einsum("bji,bj->bi", frames, ev.moment) @ to_world.T
        on_nut = np.where(geometry.IS_NUT[None, :, None], ev.groove_force, 0.0).sum(axis=1)
        screw_share = np.where(~geometry.IS_NUT[None, :], ev.groove_moment_z, 0.0).sum(axis=1)
        pair_result = None
        if self.sphere_contacts and len(self.sphere_pairs):
            pair_result, pair_force, pair_moment = self._pair_actions(state.ball_position, v, w)
            force = force + pair_force
            moment = moment + pair_moment
        return Actions(
            generalised=np.concatenate([force, moment], axis=1),
            screw_moment=screw_share,
            nut_force=np.einsum("bi,i->b", on_nut, self.zhat),
            contacts=ev,
            helix_parameter=theta,
            pairs=pair_result,
        )

    def _pair_actions(
        self, position: FloatArray, velocity: FloatArray, omega: FloatArray
    ) -> tuple[SpherePairContact, FloatArray, FloatArray]:
        """Sphere-to-sphere contacts of the neighbour pairs (world frame): the pair result,
        and the force [N] and moment [N m] they put on every sphere, (B, 3) each."""
        a, b = self.sphere_pairs[:, 0], self.sphere_pairs[:, 1]
        result = sphere_pair_contact(
            self._scene, position[a], position[b], velocity[a], velocity[b], omega[a], omega[b]
        )
        force = np.zeros_like(position)
        moment = np.zeros_like(position)
        np.add.at(force, a, result.force_on_a)
        np.add.at(force, b, -result.force_on_a)
        np.add.at(moment, a, result.moment_on_a)
        np.add.at(moment, b, result.moment_on_b)
        return result, force, moment

    # ----------------------------------------------------------------- energy

    def energy(
        self, state: DynamicState, contacts: ContactEvaluation | None = None
    ) -> dict[str, float]:
        """Stored energy [J]: kinetic (spheres, screw, nuts), elastic (Hertz, 2/5 K delta^2.5,
        the potential of Eq. 18's elastic force) and gravitational (relative to the start).

        ``contacts``: the contact laws already evaluated at ``state``'s positions (at any
        velocities: approach and stiffness depend on the positions only), else evaluated here.
        """
        screw = self.config.screw
        mass, inertia = self._scene.ball_mass, self._scene.ball_inertia
        kinetic = (
            0.5 * mass * float(np.sum(state.ball_velocity**2))
            + 0.5 * inertia * float(np.sum(state.ball_omega**2))
            + 0.5 * screw.screw_inertia * state.screw_speed**2
            + 0.5 * screw.nut_mass * float(np.sum(state.nut_velocity**2))
        )
        ev = self.contact_actions(state).contacts if contacts is None else contacts
        delta = np.where(ev.active, np.maximum(ev.approach, 0.0), 0.0)
        elastic = 0.4 * float(np.sum(ev.hertz.stiffness * delta**2.5))
        if self.sphere_contacts and len(self.sphere_pairs):
            pairs, _, _ = self._pair_actions(
                state.ball_position, state.ball_velocity, state.ball_omega
            )
            elastic += float(np.sum(pairs.elastic_energy))
        potential = -mass * float(np.sum(state.ball_position @ self.gravity))
        if screw.orientation == "vertical":
            potential += (
                screw.nut_mass * self.config.environment.gravity * float(np.sum(state.nut_position))
            )
        return {"kinetic": kinetic, "elastic": elastic, "gravitational": potential}

    def input_power(self, state: DynamicState, commands: Commands, motor_torque: float) -> float:
        """Power put in by the motor and the preload force [W] (preload pushes the nuts apart)."""
        return motor_torque * state.screw_speed + commands.preload * float(
            state.nut_velocity[0] - state.nut_velocity[1]
        )

    # ----------------------------------------------------------------- stepping

    def _jacobians(
        self, state: DynamicState, u: FloatArray, shared: FloatArray, base: Actions
    ) -> Jacobians:
        """Derivatives of each sphere's actions, evaluated at the step's trial state
        (:meth:`_trial`) for sphere velocities ``u`` (B, 6) and screw / nut velocities
        ``shared`` (3,) from the step's start ``state``, with respect to its own velocities and
        to the shared ones (screw speed, its nut's velocity), by forward differences; ``base``:
        the actions at ``u``, ``shared``.

        A sphere's actions depend on its own velocities (and, with implicit positions, its own
        position x_n + dt v) and the shared ones only, so perturbing one component of all
        spheres at once gives every sphere's column: 6 + 1 + 1 evaluations for any number of
        spheres. With implicit positions a perturbed sphere velocity or screw speed moves the
        sphere or the screw by dt times the perturbation: the columns are the total
        derivatives d f(x_n + dt v, phi_n + dt Omega, u) / du.
        """
        count = len(base.screw_moment)
        own = np.zeros((count, 8, 6))  # rows: force (3), moment (3), screw share, nut share
        jac_shared = np.zeros((count, 8, 3))  # columns: screw speed, master, slave nut velocity
        y0 = base.stacked()
        r_b = self.geometry.ball_radius
        for j in range(6):
            for colour in self._colours:
                bumped = u.copy()
                h = VELOCITY_STEP if j < 3 else VELOCITY_STEP / r_b
                bumped[colour, j] += h
                actions = self.contact_actions(self._trial(state, bumped, shared))
                column = (actions.stacked() - y0) / h
                own[colour, :, j] = column[colour]
        h_screw = VELOCITY_STEP / self.geometry.pitch_radius
        moved = self._trial(state, u, shared + np.array([h_screw, 0.0, 0.0]))
        jac_shared[:, :, 0] = (self.contact_actions(moved).stacked() - y0) / h_screw
        moved = self._trial(state, u, shared + np.array([0.0, VELOCITY_STEP, VELOCITY_STEP]))
        column = (self.contact_actions(moved).stacked() - y0) / VELOCITY_STEP
        for k in (0, 1):  # both nuts moved at once: each sphere feels its own nut only
            members = self.ball_nut == k
            jac_shared[members, :, 1 + k] = column[members]
        return Jacobians(own, jac_shared)

    def _with_velocities(
        self, state: DynamicState, u: FloatArray, shared: FloatArray
    ) -> DynamicState:
        """The state's positions (shared, not copied) with sphere velocities ``u`` (B, 6) and
        screw/nut velocities ``shared``."""
        return replace(
            state,
            ball_velocity=u[:, :3].copy(),
            ball_omega=u[:, 3:].copy(),
            screw_speed=float(shared[0]),
            nut_velocity=shared[1:].copy(),
        )

    def _trial(self, state: DynamicState, u: FloatArray, shared: FloatArray) -> DynamicState:
        """Where the step from ``state`` evaluates the contact actions for the end-of-step
        sphere velocities ``u`` (B, 6) and screw / nut velocities ``shared`` (3,): at the
        step's positions x_n (semi-implicit Euler), or with ``implicit_positions`` with the
        sphere centres and the screw where these velocities put them, x_n + dt v [m] and
        phi_n + dt Omega [rad] (backward Euler in these positions; the nut positions stay at
        the step's start). The helix search starts from the state's helix parameters."""
        trial = self._with_velocities(state, u, shared)
        if not self.implicit_positions:
            return trial
        return replace(
            trial,
            ball_position=state.ball_position + self.time_step * u[:, :3],
            screw_angle=state.screw_angle + self.time_step * float(shared[0]),
        )

    def _correction(
        self,
        jac: Jacobians,
        r_ball: FloatArray,
        r_shared: FloatArray,
        route: FloatArray,
        jammed: NDArray[np.bool_],
    ) -> tuple[FloatArray, FloatArray]:
        """Newton correction of the backward-Euler equations (Schur complement on 3 rows).

        Sphere rows (M_i - dt A_i) du_i - dt B_i dU = r_i, shared rows
        (S - dt sum_i E_i D_i + dt K_motor) dU - dt sum_i E_i C_i du_i = r_s. A jammed
        sphere's rotation rows become I dw_i = 0.
        """
        dt = self.time_step
        screw = self.config.screw
        mass, inertia = self._scene.ball_mass, self._scene.ball_inertia
        diag = np.concatenate([np.full(3, mass), np.full(3, inertia)])
        block = np.eye(6)[None] * diag[None, :, None] - dt * jac.own[:, :6]
        rhs = np.concatenate([r_ball[..., None], dt * jac.shared[:, :6]], axis=-1)
        if jammed.any():
            block[jammed, 3:] = np.eye(6)[3:] * inertia
            rhs[jammed, 3:] = 0.0
        solved = np.linalg.solve(block, rhs)  # (B, 6, 4): p_i and Q_i
        p, q = solved[:, :, 0], solved[:, :, 1:]
        c_i, d_i = jac.own[:, 6:], jac.shared[:, 6:]
        coupling = np.einsum("bij,bjk->bik", route, np.einsum("bij,bjk->bik", c_i, q) + d_i)
        lhs = np.diag([screw.screw_inertia, screw.nut_mass, screw.nut_mass]) - dt * coupling.sum(0)
        k_p, k_i = self.controller.proportional, self.controller.integral
        lhs[0, 0] += dt * (k_p + k_i * dt)
        rhs_shared = r_shared + dt * np.einsum("bij,bj->i", route, np.einsum("bij,bj->bi", c_i, p))
        d_shared = np.linalg.solve(lhs, rhs_shared)
        return p + np.einsum("bij,j->bi", q, d_shared), d_shared

    def _extrapolations(
        self, u0: FloatArray, shared0: FloatArray
    ) -> list[tuple[FloatArray, FloatArray]]:
        """u_{n+1} extrapolated at every order the history allows (0: u_n), sphere rows and
        screw / nut velocities."""
        guesses = []
        for order in range(len(self._history) + 1):
            weights = PREDICTOR_COEFFICIENTS[order]
            u, shared = weights[0] * u0, weights[0] * shared0
            for weight, (u_old, shared_old) in zip(weights[1:], self._history, strict=False):
                u, shared = u + weight * u_old, shared + weight * shared_old
            guesses.append((u, shared))
        return guesses

    def _predict(
        self, time: float, u0: FloatArray, shared0: FloatArray, jammed: NDArray[np.bool_]
    ) -> tuple[FloatArray, FloatArray, bool]:
        """Newton's first guess for the step starting at ``time`` [s] from sphere velocities
        ``u0`` (B, 6) and screw / nut velocities ``shared0`` (3,): extrapolated from the starts
        of the last steps at the order chosen by :meth:`_remember` when this step continues the
        last one, else u_n. A jammed sphere's rotation stays zero. Also returns whether it
        extrapolated."""
        if self._history_time != time:
            self._history = []
        order = self._history_order if self._history else 0
        u, shared = self._extrapolations(u0, shared0)[order]
        u = u.copy()
        u[jammed, 3:] = 0.0
        return u, shared.copy(), order > 0

    def _remember(
        self,
        time: float,
        u0: FloatArray,
        shared0: FloatArray,
        u: FloatArray,
        shared: FloatArray,
    ) -> None:
        """After the step from ``time`` [s]: the order for the next step is the one whose
        prediction came closest to the converged ``u``, ``shared`` (largest difference, angular
        velocities times the ball radius, screw speed times the pitch radius, in m/s; ties to
        the lower order); u_n joins the history (at most PREDICTOR_ORDER starts kept)."""
        if self._history_time != time:
            self._history = []
        scale = np.array([1.0, 1.0, 1.0] + [self.geometry.ball_radius] * 3)
        shared_scale = np.array([self.geometry.pitch_radius, 1.0, 1.0])
        errors = [
            max(
                float(np.max(scale * np.abs(guess - u))),
                float(np.max(shared_scale * np.abs(guess_shared - shared))),
            )
            for guess, guess_shared in self._extrapolations(u0, shared0)
        ]
        self._history_order = int(np.argmin(errors))
        self._history = [(u0.copy(), shared0.copy()), *self._history][:PREDICTOR_ORDER]
        self._history_time = time + self.time_step

    def step(self, state: DynamicState, commands: Commands) -> tuple[DynamicState, StepReport]:
        """Advance all bodies by one step (see :meth:`_step`); the spheres are located once."""
        if self._kernel is not None:
            return self._kernel.step(state, commands)
        self._step_location = (state.ball_position, self._locate(state))
        try:
            return self._step(state, commands)
        finally:
            self._step_location = None

    def _step(self, state: DynamicState, commands: Commands) -> tuple[DynamicState, StepReport]:
        """Advance all bodies by one backward-Euler step of the velocities, solved by Newton.

        The equations M (u - u_n) = dt f(x_n, u) for every sphere and S (U - U_n) = dt g for
        screw (PI controller implicit) and nuts are solved by Newton iterations until the
        scaled residual is below STEP_TOLERANCE (at most STEP_NEWTON_MAX), starting from the
        predictor's guess (:meth:`_predict`; a guess already below the tolerance ends the step
        without a correction). The Jacobian of the contact actions is the one kept from earlier
        steps; before the first correction it is refreshed at the guess when the contact set
        changed or it is older than ``jacobian_interval`` steps; it is re-evaluated at the
        iterate only when the last iteration reduced the residual by less than
        JACOBIAN_REFRESH_RATIO (a modified Newton iteration: same solution, fewer Jacobians).
        Positions then move with the new velocities. The
        reported contact actions and dissipation are those at the converged velocities, i.e.
        the forces the step applied.
        """
        dt = self.time_step
        screw = self.config.screw
        mass, inertia = self._scene.ball_mass, self._scene.ball_inertia
        diag = np.concatenate([np.full(3, mass), np.full(3, inertia)])
        gravity = np.concatenate([mass * self.gravity, np.zeros(3)])
        shared_mass = np.array([screw.screw_inertia, screw.nut_mass, screw.nut_mass])
        k_p, k_i = self.controller.proportional, self.controller.integral
        weight = screw.nut_mass * self.config.environment.gravity
        if screw.orientation != "vertical":
            weight = 0.0
        count = len(state.ball_velocity)
        route = np.zeros((count, 3, 2))  # E_i: (screw share, nut share) -> shared rows
        route[:, 0, 0] = 1.0
        route[np.arange(count), 1 + self.ball_nut, 1] = 1.0
        jammed = self.faults.jammed(state.time, self.ball_nut, self.ball_index)
        u0 = np.concatenate([state.ball_velocity, state.ball_omega], axis=1)
        u0[jammed, 3:] = 0.0  # a jam blocks the rotation (faults.py)
        shared0 = np.concatenate([[state.screw_speed], state.nut_velocity])

        def residual(
            acts: Actions, u: FloatArray, shared: FloatArray
        ) -> tuple[FloatArray, FloatArray, float]:
            """Backward-Euler residuals (sphere rows, shared rows) and their scaled maximum."""
            f = acts.generalised + gravity
            error = commands.screw_speed - shared[0]
            motor = k_p * error + k_i * (state.controller_integral + dt * error)
            shares = np.stack([acts.screw_moment, acts.nut_force], axis=-1)
            g = np.array([motor, commands.preload - weight, -commands.preload - weight])
            g = g + np.einsum("bij,bj->i", route, shares)
            r_ball = dt * f - diag * (u - u0)
            r_ball[jammed, 3:] = 0.0  # blocked rotation: omega = 0 is the equation
            r_shared = dt * g - shared_mass * (shared - shared0)
            force_scale = np.abs(f[:, :3]).max() + mass * self.config.environment.gravity
            scale = dt * np.concatenate(
                [np.full(3, force_scale), np.full(3, force_scale * self.geometry.ball_radius)]
            )
            shared_scale = dt * (np.abs(g) + np.array([1e-6, 1e-3, 1e-3]))
            worst = max(
                float(np.max(np.abs(r_ball) / scale)),
                float(np.max(np.abs(r_shared) / shared_scale)),
            )
            return r_ball, r_shared, worst

        # A step that does not converge from the predicted guess is solved again from u_n with
        # a fresh Jacobian (the guess must not cost convergence).
        for attempt in range(2):
            if attempt == 0:
                u, shared, predicted = self._predict(state.time, u0, shared0, jammed)
            else:
                u, shared, predicted = u0.copy(), shared0.copy(), False
            actions = self.contact_actions(self._trial(state, u, shared))
            contact_set = actions.contacts.active
            stale = (
                attempt == 1
                or self._jacobian is None
                or self._jacobian_age >= self.jacobian_interval
                or not np.array_equal(contact_set, self._jacobian_contacts)
            )
            if attempt == 0:
                self._jacobian_age += 1
            r_ball, r_shared, worst = residual(actions, u, shared)
            previous = worst
            converged = False
            for iteration in range(STEP_NEWTON_MAX):
                if worst < STEP_TOLERANCE:
                    converged = True
                    break
                if iteration == 0 and stale:  # refreshed when a correction needs it, at the start
                    self._jacobian = self._jacobians(state, u, shared, actions)
                    self._jacobian_contacts = contact_set.copy()
                    self._jacobian_age = 1
                if iteration > 0 and not worst < JACOBIAN_REFRESH_RATIO * previous:
                    self._jacobian = self._jacobians(state, u, shared, actions)  # at the iterate
                    self._jacobian_contacts = actions.contacts.active.copy()
                    self._jacobian_age = 0
                assert self._jacobian is not None  # refreshed above when there was none
                du, d_shared = self._correction(self._jacobian, r_ball, r_shared, route, jammed)
                step = 1.0
                for _ in range(STEP_BACKTRACKS + 1):  # backtrack while the residual grows
                    u_try, shared_try = u + step * du, shared + step * d_shared
                    acts = self.contact_actions(self._trial(state, u_try, shared_try))
                    rb, rs, w = residual(acts, u_try, shared_try)
                    if w < worst or iteration == 0:
                        break
                    step *= 0.5
                previous = worst
                u, shared, actions, r_ball, r_shared, worst = u_try, shared_try, acts, rb, rs, w
            unconverged = not converged and worst >= STEP_TOLERANCE
            if not unconverged or not predicted:
                break
        if unconverged:
            self.unconverged_steps += 1
        self.last_step_residual = worst
        self._remember(state.time, u0, shared0, u, shared)
        screw_speed = float(shared[0])
        nut_velocity = shared[1:].copy()
        new_error = commands.screw_speed - screw_speed
        integral = state.controller_integral + dt * new_error
        new = DynamicState(
            time=state.time + dt,
            screw_angle=state.screw_angle + dt * screw_speed,
            screw_speed=screw_speed,
            controller_integral=integral,
            nut_position=state.nut_position + dt * nut_velocity,
            nut_velocity=nut_velocity,
            ball_position=state.ball_position + dt * u[:, :3],
            ball_velocity=u[:, :3].copy(),
            ball_omega=u[:, 3:].copy(),
            helix_parameter=actions.helix_parameter,
        )
        ev = actions.contacts
        dissipation = float(sum(np.sum(v) for v in ev.dissipation.values()))
        per_ball = np.sum([ev.dissipation[name] for name in DISSIPATION_KEYS], axis=(0, 2))
        pair_dissipation = 0.0
        if actions.pairs is not None:
            pair_dissipation = float(np.sum(actions.pairs.dissipation))
        report = StepReport(
            motor_torque=k_p * new_error + k_i * integral,
            contacts=ev,
            nut_force=np.array([actions.nut_force[self.ball_nut == k].sum() for k in (0, 1)]),
            screw_torque=float(actions.screw_moment.sum()),
            dissipation=dissipation + pair_dissipation,
            sphere_pairs=actions.pairs,
            sphere_dissipation=pair_dissipation,
            mechanism_dissipation=np.array(
                [float(np.sum(ev.dissipation[name])) for name in DISSIPATION_KEYS]
            ),
            nut_dissipation=np.array([float(per_ball[self.ball_nut == k].sum()) for k in (0, 1)]),
        )
        return new, report


def _to_screw_frame(angle: float) -> FloatArray:
    """Rotation taking world (inertial) components into the screw frame turned by ``angle``."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


@dataclass
class Actions:
    """Contact actions at one state (world frame)."""

    generalised: FloatArray  # (B, 6) force [N] and moment [N m] on each sphere
    screw_moment: FloatArray  # (B,) N m, each sphere's moment on the screw about z
    nut_force: FloatArray  # (B,) N, each sphere's axial force on its nut
    contacts: ContactEvaluation
    helix_parameter: FloatArray  # (B,) rad
    pairs: SpherePairContact | None = None  # sphere-to-sphere contacts, when modelled

    def stacked(self) -> FloatArray:
        """(B, 8): force, moment, screw share, nut share."""
        return np.concatenate(
            [self.generalised, self.screw_moment[:, None], self.nut_force[:, None]], axis=1
        )


@dataclass
class Jacobians:
    """Velocity Jacobians of each sphere's stacked actions (rows as :meth:`Actions.stacked`)."""

    own: FloatArray  # (B, 8, 6) with respect to its velocity and angular velocity
    shared: FloatArray  # (B, 8, 3) with respect to screw speed, master and slave nut velocity
