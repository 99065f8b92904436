"""The dynamic model's compiled step: :mod:`ballscrew_twin.kernels.dynamic_step` driven with the
model's constants, its kept Jacobian and its predictor's history.

:class:`CompiledStep` packs a :class:`~.dynamic_state.DynamicState` into the kernel's flat
arrays, runs one step and unpacks the new state and its :class:`~.dynamic_state.StepReport`;
the result equals :meth:`ballscrew_twin.models.dynamic.DynamicModel._step`, the readable
reference, to rounding (test/kernels/test_dynamic_step.py). SI units.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ..kernels.solver_settings import PREDICTOR_ORDER
from .dynamic_state import Commands, DynamicState, StepReport

if TYPE_CHECKING:
    from .dynamic import DynamicModel


class CompiledStep:
    """The compiled step (kernels/dynamic_step.py) with its constants and kept Jacobian."""

    def __init__(self, model: DynamicModel) -> None:
        from ..kernels import dynamic_layouts as kl  # numba: imported when a model steps compiled
        from ..kernels import dynamic_step as ks
        from ..kernels.contacts import scene_arrays

        ks.ensure_fresh_cache()
        self.ks, self.kl = ks, kl
        self.model = model
        screw = model.config.screw
        geom = model.geometry
        scene = model._scene
        weight = screw.nut_mass * model.config.environment.gravity
        if screw.orientation != "vertical":
            weight = 0.0
        consts = np.zeros(kl.N_CONST)
        consts[kl.K_DT] = model.time_step
        consts[kl.K_MASS] = scene.ball_mass
        consts[kl.K_INERTIA] = scene.ball_inertia
        consts[kl.K_GX : kl.K_GZ + 1] = model.gravity
        consts[kl.K_G] = model.config.environment.gravity
        consts[kl.K_SCREW_INERTIA] = screw.screw_inertia
        consts[kl.K_NUT_MASS] = screw.nut_mass
        consts[kl.K_WEIGHT] = weight
        consts[kl.K_KP] = model.controller.proportional
        consts[kl.K_KI] = model.controller.integral
        consts[kl.K_BALL_RADIUS] = geom.ball_radius
        consts[kl.K_PITCH_RADIUS] = geom.pitch_radius
        consts[kl.K_LEAD_RATE] = model.lead_rate
        consts[kl.K_SIN_HELIX] = model.zhat[0]
        consts[kl.K_COS_HELIX] = math.cos(geom.helix_angle)
        consts[kl.K_NUT_OFFSET0 : kl.K_NUT_OFFSET0 + 2] = model._nut_offset0
        consts[kl.K_IMPLICIT] = float(model.implicit_positions)
        self.consts = consts
        self.params = np.array(scene_arrays(scene), dtype=np.float64)
        count = len(model.ball_nut)
        self.ball_nut = model.ball_nut.astype(np.int64)
        self.sphere_offset, self.spalls = model.faults.compiled_arrays(
            count, self.ball_nut, model.ball_index
        )
        self.jac_own = np.zeros((count, 8, 6))
        self.jac_shared = np.zeros((count, 8, 3))
        self.jac_active = np.zeros((count, 4), dtype=np.bool_)
        self.jac_meta = np.array([0, 0, model.jacobian_interval], dtype=np.int64)
        self.history = np.zeros((PREDICTOR_ORDER, count + 1, 6))
        self.history_meta = np.array([math.nan, 0.0, 0.0])
        self.stats = np.zeros(kl.S_COUNT)

    def set_integrator(self, time_step: float, implicit_positions: bool) -> None:
        """The step [s] and sphere-position treatment of the next steps; the kept Jacobian
        and the predictor's history are dropped (DynamicModel.set_integrator)."""
        kl = self.kl
        self.consts[kl.K_DT] = time_step
        self.consts[kl.K_IMPLICIT] = float(implicit_positions)
        self.jac_meta[kl.J_VALID] = 0
        self.history_meta[kl.H_NEXT_TIME] = math.nan

    def step(self, state: DynamicState, commands: Commands) -> tuple[DynamicState, StepReport]:
        """One compiled step; the same result as :meth:`DynamicModel._step` (to rounding)."""
        from ..kernels.contacts import evaluation_from_buffer

        ks, kl, model = self.ks, self.kl, self.model
        body = np.array(
            [
                state.time,
                state.screw_angle,
                state.screw_speed,
                state.controller_integral,
                state.nut_position[0],
                state.nut_position[1],
                state.nut_velocity[0],
                state.nut_velocity[1],
            ]
        )
        count = len(state.helix_parameter)
        pos, vel, omega = np.empty((count, 3)), np.empty((count, 3)), np.empty((count, 3))
        theta, new_body = np.empty(count), np.empty(kl.N_BODY)
        stats = self.stats
        active, buffer = ks.step_kernel(
            np.ascontiguousarray(state.ball_position, dtype=np.float64),
            np.ascontiguousarray(state.ball_velocity, dtype=np.float64),
            np.ascontiguousarray(state.ball_omega, dtype=np.float64),
            np.ascontiguousarray(state.helix_parameter, dtype=np.float64),
            body,
            np.array([commands.screw_speed, commands.preload]),
            self.ball_nut,
            self.consts,
            self.params,
            self.sphere_offset,
            self.spalls,
            model.faults.jammed(state.time, self.ball_nut, model.ball_index),
            self.jac_own,
            self.jac_shared,
            self.jac_active,
            self.jac_meta,
            self.history,
            self.history_meta,
            pos,
            vel,
            omega,
            theta,
            new_body,
            stats,
        )
        model.unconverged_steps += int(stats[kl.S_UNCONVERGED])
        model.last_step_residual = float(stats[kl.S_RESIDUAL])
        work = model.work
        work["contact_evaluations"] += int(stats[kl.S_EVALS])
        work["jacobians"] += int(stats[kl.S_JACOBIANS])
        work["newton_iterations"] += int(stats[kl.S_ITERATIONS])
        new = DynamicState(
            time=float(new_body[kl.B_TIME]),
            screw_angle=float(new_body[kl.B_ANGLE]),
            screw_speed=float(new_body[kl.B_SPEED]),
            controller_integral=float(new_body[kl.B_INTEGRAL]),
            nut_position=new_body[kl.B_NUT_POS : kl.B_NUT_POS + 2].copy(),
            nut_velocity=new_body[kl.B_NUT_VEL : kl.B_NUT_VEL + 2].copy(),
            ball_position=pos,
            ball_velocity=vel,
            ball_omega=omega,
            helix_parameter=theta,
        )
        report = StepReport(
            motor_torque=float(stats[kl.S_MOTOR]),
            contacts=evaluation_from_buffer(active, buffer),
            nut_force=stats[kl.S_NUT_FORCE : kl.S_NUT_FORCE + 2].copy(),
            screw_torque=float(stats[kl.S_SCREW_TORQUE]),
            dissipation=float(stats[kl.S_DISSIPATION]),
            mechanism_dissipation=stats[kl.S_MECHANISMS : kl.S_MECHANISMS + kl.N_MECHANISMS].copy(),
            nut_dissipation=stats[kl.S_NUT_DISSIPATION : kl.S_NUT_DISSIPATION + 2].copy(),
        )
        return new, report
