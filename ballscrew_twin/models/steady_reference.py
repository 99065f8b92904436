"""The readable Newton iteration of the steady model: the definition the compiled solver is
tested against.

:class:`ReadableNewton` evaluates the scaled residuals with a contact-law function (the numpy
laws, ``backend="reference"``, or the compiled ones, ``backend="newton"``), differentiates them by
central differences (spheres are independent given their nut's offset) and takes damped Newton
steps of the bordered system with a backtracking line search. The compiled solver
(:mod:`ballscrew_twin.kernels.steady_solver`) does the same with exact Jacobian blocks. Units:
SI (m, rad/s, N, N m); residuals dimensionless.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from ..errors import SolverError
from ..kernels.solver_settings import DIAGONAL_SHIFT, LINE_SEARCH_STEPS, MIN_STEP
from ..params import TwinConfig
from ..physics import geometry
from ..physics.contact_types import ContactEvaluation, ContactScene
from .steady_problem import inertial_actions, residual_scales
from .steady_types import BallSet, SteadyState

FloatArray = NDArray[np.float64]
#: The contact laws: (scene, ball_nb, kinematics, nut offset per sphere, gravity) -> evaluation.
ContactLaws = Callable[
    [ContactScene, FloatArray, FloatArray, FloatArray, FloatArray], ContactEvaluation
]

POSITION_STEP = 1e-10  # m, finite-difference step of the ball and nut offsets
KINEMATIC_STEP_REL = 1e-7  # finite-difference step of the rates, relative to the screw speed


class ReadableNewton:
    """The steady state's Newton iteration in numpy.

    Args:
        config: parameter set.
        evaluate: the contact laws (numpy or compiled; the same numbers to rounding).
        inertial_terms: keep the centrifugal force and gyroscopic moment (see
            :class:`~ballscrew_twin.models.steady.SteadyStateModel`).
        tolerance: convergence limit of the worst scaled residual [-].
    """

    def __init__(
        self, config: TwinConfig, evaluate: ContactLaws, inertial_terms: bool, tolerance: float
    ) -> None:
        self.config = config
        self._evaluate = evaluate
        self.inertial_terms = inertial_terms
        self.tolerance = tolerance

    def residual(
        self, scene: ContactScene, balls: BallSet, state: SteadyState, loads: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray, ContactEvaluation]:
        """Scaled residuals: (B, 6) sphere balance, (B,) each sphere's axial push on its nut
        (times the spheres it stands for) and (2,) nut axial balance."""
        e_ball = state.nut_offset[balls.nut]
        # Trial states of the line search may be absurd (huge pressure): their non-finite
        # residuals are rejected by the solver, so numpy's overflow warnings are not news.
        with np.errstate(over="ignore", invalid="ignore"):
            ev = self._evaluate(scene, state.ball_nb, state.kinematics, e_ball, balls.gravity)
        force_scale, moment_scale = residual_scales(self.config, scene, loads)
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

    @staticmethod
    def unknown_mask(scene: ContactScene, count: int) -> NDArray[np.bool_]:
        """Which of the 6 unknowns per sphere are solved: the rates are frozen at zero speed."""
        mask = np.ones((count, 6), dtype=bool)
        if scene.screw_speed == 0.0:
            mask[:, 2:] = False
        return mask

    def solve(
        self,
        scene: ContactScene,
        balls: BallSet,
        state: SteadyState,
        loads: FloatArray,
        max_iterations: int,
        tolerance: float | None = None,
    ) -> tuple[SteadyState, ContactEvaluation, int, float]:
        """Newton iteration from ``state`` with a central-difference Jacobian: (converged
        state, its contacts, iterations, worst scaled residual); SolverError when it does not
        converge in ``max_iterations`` to ``tolerance`` (None: :attr:`tolerance`)."""
        limit = self.tolerance if tolerance is None else tolerance
        count = len(balls.nut)
        mask = self.unknown_mask(scene, count)
        ball_res, _, nut_res, ev = self.residual(scene, balls, state, loads)
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
            if worst < limit:
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
                rb_p, ax_p, _, _ = self.residual(scene, balls, unpack(zp, e), loads)
                rb_m, ax_m, _, _ = self.residual(scene, balls, unpack(zm, e), loads)
                jac[:, :, j] = (rb_p - rb_m) / (2.0 * steps[j])
                jac_nut_z[:, j] = (ax_p - ax_m) / (2.0 * steps[j])  # sphere i on its own nut
            rb_p, _, rn_p, _ = self.residual(scene, balls, unpack(z, e + POSITION_STEP), loads)
            rb_m, _, rn_m, _ = self.residual(scene, balls, unpack(z, e - POSITION_STEP), loads)
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
            dz, de = self.damped_step(
                jac, jac_z_e, jac_nut_z, jac_e_e, res_b, nut_res, diag, DIAGONAL_SHIFT, balls
            )
            dz = np.where(mask, dz, 0.0)
            base = merit(ball_res, nut_res)
            step = 1.0
            for _ in range(LINE_SEARCH_STEPS):
                trial = unpack(z + step * dz, e + step * de)
                rb, _, rn, ev_t = self.residual(scene, balls, trial, loads)
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
        if worst < limit:  # the last update converged
            return unpack(z, e), ev, max_iterations, worst
        raise SolverError(
            f"steady state did not converge in {max_iterations} iterations "
            f"(scaled residual {worst:.3g} > {limit:.1g})"
        )

    @staticmethod
    def damped_step(
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
