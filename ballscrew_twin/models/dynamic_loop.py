"""The one time loop of the dynamic model, and the dynamic model behind the one model interface.

:class:`TimeLoop` steps a :class:`~.dynamic.DynamicModel` run step by run step under commands
given as a function of time and hands every step of the model to a hook: the step's start
state, its commands, the motor torque before it and its :class:`~.dynamic_state.StepReport`.
What to record is the hook's. A :class:`StepPlan` says how a run step is integrated (a start
phase of finer semi-implicit substeps, a non-converged step redone as such substeps). Its users:

- :func:`~.simulation.simulate` (its Python loop, the reference its compiled loop retraces);
- the scene runner (``ballscrew-twin scene`` with the dynamic model selected);
- :class:`DynamicStepping`, the dynamic model as a :class:`~.base.TimeSteppingModel` (``reset``,
  ``step(op, dt)``), the interface every other fidelity level offers; the registry's
  :func:`~.registry.as_stepping` gives it.

SI units throughout (s, rad/s, N, N m, W).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from ..errors import OperatingPointError, SolverError
from .base import MECHANISMS, OperatingPoint, TorqueBreakdown, TwinOutput
from .dynamic_state import Commands, DynamicState, StepReport
from .steady_output import contact_states

if TYPE_CHECKING:
    from .dynamic import DynamicModel

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class ModelStep:
    """One step of the model as :class:`TimeLoop` hands it to its hook.

    Attributes:
        k: run step [-]; j: model step within it (substeps of the start phase or of a redone
        step) [-]; length: the step's length [s]; commands: its commands; state: the state at
        its start; motor: the motor torque before it [N m]; report: what the step computed.
    """

    k: int
    j: int
    length: float
    commands: Commands
    state: DynamicState
    motor: float
    report: StepReport


#: The hook of every step of the model.
StepHook = Callable[[ModelStep], None]

#: Below this screw speed [rad/s] the dynamic model's drag torque is 0 (nothing to divide by).
STANDSTILL_SPEED = 1e-9


@dataclass(frozen=True)
class StepPlan:
    """How the run steps of a :class:`TimeLoop` are integrated.

    Attributes:
        time_step: a run step [s].
        implicit_positions: the treatment of the sphere positions after the start phase and
            after a redone step (see :class:`~.dynamic.DynamicModel`).
        fine_time_step: the step of the start phase and of a redone step [s] (None: neither).
        fine_steps: run steps of the start phase [-], each ``substeps`` semi-implicit steps
            of ``fine_time_step``.
        substeps: model steps in a run step of the start phase [-].
        fallback: semi-implicit steps of ``fine_time_step`` a run step whose Newton iterations
            do not converge is redone as [-] (1: never redone).
    """

    time_step: float
    implicit_positions: bool = False
    fine_time_step: float | None = None
    fine_steps: int = 0
    substeps: int = 1
    fallback: int = 1

    def start(self, model: DynamicModel) -> None:
        """Set ``model``'s integrator for run step 0 (the start phase's, when there is one)."""
        if self.fine_steps > 0:
            assert self.fine_time_step is not None  # fine_steps > 0 needs it
            model.set_integrator(self.fine_time_step, False)

    def parts(self, model: DynamicModel, k: int) -> tuple[int, float]:
        """Model steps in run step ``k`` and their length [s]; switches ``model`` to the run's
        step at the end of the start phase."""
        if self.fine_steps > 0 and k == self.fine_steps:
            model.set_integrator(self.time_step, self.implicit_positions)
        if k < self.fine_steps:
            assert self.fine_time_step is not None  # fine_steps > 0 needs it
            return self.substeps, self.fine_time_step
        return 1, self.time_step


def check_finite(state: DynamicState, report: StepReport, t: float) -> None:
    """Raise :class:`SolverError` naming the first non-finite quantity of the step from
    ``state`` at time ``t`` [s]."""
    checks = {
        "screw speed": state.screw_speed,
        "motor torque": report.motor_torque,
        "dissipation": report.dissipation,
        "screw torque": report.screw_torque,
        "nut velocity": float(np.sum(state.nut_velocity)),
        "sphere velocity": float(np.sum(state.ball_velocity)),
        "sphere angular velocity": float(np.sum(state.ball_omega)),
    }
    for name, value in checks.items():
        if not math.isfinite(value):
            raise SolverError(
                f"dynamic model diverged at t = {t:.7g} s: {name} is {value} "
                f"(last screw speed {state.screw_speed:.6g} rad/s)"
            )


class TimeLoop:
    """Steps ``model`` from ``state`` run step by run step (k = 0, 1, ...; time k
    ``plan.time_step``) under ``commands_at(t)``.

    Each step of the model is checked (:func:`check_finite`) and handed to ``visit``; in the
    start phase a run step is ``plan.substeps`` model steps (j = 0, 1, ...), their commands at
    their own start times; a run step redone as fallback substeps keeps the commands of its
    start. ``after_step(n)`` is called when n run steps are done. The caller sets the model's
    integrator for run step 0 (:meth:`StepPlan.start`).

    Attributes:
        state: the state at the start of run step ``next_step``.
        motor: the motor torque at the end of the last step [N m] (0 at rest).
        next_step: the run step the next :meth:`run` starts at.
        fallbacks: run steps redone as fallback substeps.
        unconverged: (run step, the model's last scaled residual) of every run step one of
            whose model steps ended its Newton iterations above the tolerance.
    """

    def __init__(
        self,
        model: DynamicModel,
        state: DynamicState,
        plan: StepPlan,
        commands_at: Callable[[float], Commands],
        visit: StepHook,
        after_step: Callable[[int], None] | None = None,
    ) -> None:
        self.model = model
        self.state = state
        self.plan = plan
        self.commands_at = commands_at
        self.visit = visit
        self.after_step = after_step
        self.motor = 0.0  # the controller starts at rest with zero error
        self.next_step = 0
        self.fallbacks = 0
        self.unconverged: list[tuple[int, float]] = []

    def run(self, last: int, *, final_report: bool) -> None:
        """Run steps ``next_step`` .. ``last``; with ``final_report`` the step of run step
        ``last`` is taken for its report only (``state`` stays at its start)."""
        model, plan = self.model, self.plan
        dt = plan.time_step
        for k in range(self.next_step, last + 1):
            t = k * dt
            parts, step = plan.parts(model, k)
            report_only = final_report and k == last
            redo = False  # the run step did not converge: redone as fallback substeps
            unconverged = False  # one of its steps ended above the tolerance
            j = 0
            while j < parts:
                t_model = t + j * step if parts > 1 else t
                commands = self.commands_at(t if redo else t_model)
                before = model.unconverged_steps
                new_state, report = model.step(self.state, commands)
                if parts == 1 and plan.fallback > 1 and model.unconverged_steps > before:
                    assert plan.fine_time_step is not None  # fallback > 1 needs it
                    model.unconverged_steps = before
                    model.set_integrator(plan.fine_time_step, False)
                    parts, step, redo = plan.fallback, plan.fine_time_step, True
                    self.fallbacks += 1
                    continue
                unconverged = unconverged or model.unconverged_steps > before
                check_finite(self.state, report, t_model)
                self.visit(ModelStep(k, j, step, commands, self.state, self.motor, report))
                if report_only:
                    break
                self.state, self.motor = new_state, report.motor_torque
                j += 1
            if unconverged:  # listed once per run step, with its last step's residual
                self.unconverged.append((k, model.last_step_residual))
            if report_only:
                return
            if redo:
                model.set_integrator(dt, plan.implicit_positions)
            self.next_step = k + 1
            if self.after_step is not None:
                self.after_step(k + 1)


def dynamic_output(
    model: DynamicModel, state: DynamicState, report: StepReport, op: OperatingPoint
) -> TwinOutput:
    """The :class:`TwinOutput` of the step from ``state`` under the command ``op``: the drag
    torque is the dissipation of the friction mechanisms over the screw speed of ``state``
    [N m] (the steady model's definition; 0 at standstill), split by mechanism and by nut."""
    ev = report.contacts
    power = np.array([float(np.sum(ev.dissipation[m])) for m in MECHANISMS])
    per_ball = np.sum([ev.dissipation[m] for m in MECHANISMS], axis=(0, 2))
    speed = state.screw_speed
    scale = 1.0 / speed if abs(speed) > STANDSTILL_SPEED else 0.0
    breakdown = power * scale
    master, slave = (float(per_ball[model.ball_nut == k].sum()) * scale for k in (0, 1))
    notes = []
    if op.temperature != model.temperature:
        notes.append(
            f"temperature {model.temperature:.6g} K (fixed when the dynamic model is built), "
            f"not the commanded {op.temperature:.6g} K"
        )
    if op.axial_load != 0.0:
        notes.append(f"axial load {op.axial_load:.6g} N not modelled by the dynamic model")
    return TwinOutput(
        drag_torque=float(power.sum()) * scale,
        nut_torque=(master, slave),
        breakdown=TorqueBreakdown(
            **{m: float(value) for m, value in zip(MECHANISMS, breakdown, strict=True)}
        ),
        fidelity="dynamic",
        operating_point=op,
        contacts=contact_states(model.ball_nut, ev),
        notes=tuple(notes),
    )


class DynamicStepping:
    """The dynamic model as a :class:`~.base.TimeSteppingModel`: :meth:`reset` starts it at
    rest in the static equilibrium of the command's preload (it cannot start rolling: its
    speed controller brings the screw to the commanded speed), :meth:`step` runs whole steps
    of the model's ``time_step`` under the command held over the tick (:class:`TimeLoop`).

    The output of a tick is that of its last step of the model (:func:`dynamic_output`); the
    temperature is the model's (fixed when built) and the axial load is not modelled (both
    noted in the output when the command differs).
    """

    def __init__(self, model: DynamicModel) -> None:
        self.model = model
        self.name = "dynamic"
        self._loop: TimeLoop | None = None
        self._commands = Commands(screw_speed=0.0, preload=0.0)
        self._last: tuple[DynamicState, StepReport] | None = None

    def reset(self, op: OperatingPoint) -> None:
        """Start at rest in the static equilibrium of ``op``'s preload [N]."""
        op.validate()
        model = self.model
        state = model.initial_state(op.preload)
        self._last = None
        self._loop = TimeLoop(
            model,
            state,
            StepPlan(time_step=model.time_step, implicit_positions=model.implicit_positions),
            self._commands_at,
            self._keep,
        )

    def step(self, op: OperatingPoint, dt: float) -> TwinOutput:
        """Advance by ``dt`` [s], a whole number of the model's steps, under ``op`` (the first
        call without :meth:`reset` starts at ``op``).

        Raises:
            OperatingPointError: ``dt`` is not a positive whole number of model steps.
            SolverError: the model produced a non-finite value (time and quantity named).
        """
        op.validate()
        time_step = self.model.time_step
        steps = round(dt / time_step)
        if steps < 1 or abs(steps * time_step - dt) > 1e-9 * dt:
            raise OperatingPointError(
                f"dt = {dt!r} s is not a whole number of the dynamic model's steps "
                f"({time_step:.6g} s)"
            )
        if self._loop is None:
            self.reset(op)
        loop = self._loop
        assert loop is not None  # set by reset
        self._commands = Commands(screw_speed=op.screw_speed, preload=op.preload)
        loop.run(loop.next_step + steps - 1, final_report=False)
        assert self._last is not None  # at least one step was visited
        state, report = self._last
        return dynamic_output(self.model, state, report, op)

    def _commands_at(self, t: float) -> Commands:
        """The command of the tick (held over it; ``t`` [s] is not used)."""
        return self._commands

    def _keep(self, step: ModelStep) -> None:
        """Keep the last step's start state and report (the tick's output)."""
        self._last = (step.state, step.report)
