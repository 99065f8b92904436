"""The model the twin node steps, the catalogue model standing in for it, and how the model
changes: a parameter change, a table built, or a step-down under ``fidelity: auto`` (no rclpy).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ..models.base import OperatingPoint, TimeSteppingModel, TwinOutput
from . import fidelity_modes
from .step_down import StepDown, may_step_down
from .twin_messages import finite_output


def describe(op: OperatingPoint) -> str:
    """Human-readable operating point."""
    return (
        f"speed {op.screw_speed:g} rad/s, temperature {op.temperature:g} K, "
        f"preload {op.preload:g} N, axial load {op.axial_load:g} N"
    )


class TwinModels:
    """The model in use (:attr:`choice`) and its catalogue stand-in (:attr:`fallback`).

    Args:
        choice: the model to start with.
        fallback: the catalogue model, which stands in for a failed step.
        op: operating point both start in (their steady state).
        settings: what a cheaper model is built from, now.
        log: ``log(text)`` logs a model switch (a warning).
        warn: ``warn(key, text)`` logs a warning, throttled per key.

    Attributes:
        switches: model switches since start-up [-].
        failures: failed steps since start-up [-].
        step_down: the step-budget watch of ``fidelity: auto``.
    """

    def __init__(
        self,
        choice: fidelity_modes.ModelChoice,
        fallback: TimeSteppingModel,
        op: OperatingPoint,
        settings: Callable[[], fidelity_modes.ModelSettings],
        log: Callable[[str], None],
        warn: Callable[[str, str], None],
    ) -> None:
        self.choice = choice
        self.fallback = fallback
        self._settings = settings
        self._log = log
        self._warn = warn
        self.switches = 0
        self.failures = 0
        self.step_down = StepDown()
        #: Model and fallback built for a parameter change being validated.
        self._pending: tuple[fidelity_modes.ModelChoice, TimeSteppingModel] | None = None
        choice.model.reset(op)
        fallback.reset(op)

    def prepare(self, choice: fidelity_modes.ModelChoice, fallback: TimeSteppingModel) -> None:
        """Hold a model and fallback built for parameters being changed (see :meth:`apply`)."""
        self._pending = (choice, fallback)

    def apply(self, op: OperatingPoint) -> None:
        """Run the models :meth:`prepare` holds (if any) from the next step on, from ``op``."""
        if self._pending is None:
            return
        choice, fallback = self._pending
        self._pending = None
        self.switch(choice, op)
        self.fallback = fallback
        self.fallback.reset(op)

    def switch(self, choice: fidelity_modes.ModelChoice, op: OperatingPoint) -> None:
        """Run ``choice`` from the next step on, started in the steady state of ``op``."""
        previous = self.choice.model.name
        choice.model.reset(op)
        self.choice = choice
        self.switches += 1
        self.step_down.restart()
        self._log(f"model {previous} -> {choice.model.name}: {choice.reason}")

    def _step_down(self, why: str, op: OperatingPoint) -> None:
        """Switch to the next cheaper model ``auto`` can build, because of ``why``."""
        choice = fidelity_modes.choose("auto", self._settings(), below=self.choice.mode)
        reason = f"{choice.reason}: {why}"
        self.switch(fidelity_modes.ModelChoice(choice.model, choice.mode, reason), op)

    def review(
        self, op: OperatingPoint, *, requested: str, step_budget: float, period: float
    ) -> None:
        """After one simulated second: step down if the model overran its budget too long.

        Args:
            op: operating point a new model starts in.
            requested: the ``fidelity`` parameter.
            step_budget: share of the step the model may take [-].
            period: simulation step [s].
        """
        why = self.step_down.review(
            active=may_step_down(requested, self.choice.mode),
            model_name=self.choice.model.name,
            step_budget=step_budget,
            period=period,
        )
        if why is not None:
            self._step_down(why, op)

    def step(
        self, op: OperatingPoint, dt: float, *, contacts: bool, requested: str
    ) -> tuple[TwinOutput, bool]:
        """One step at ``op`` over ``dt`` [s]; whether it failed. The catalogue model stands in
        for a step that raises or is not finite (logged; under ``auto`` the failed model is
        left for a cheaper one until the ``fidelity`` parameter, ``requested``, is set anew).
        ``contacts=False``: the contact states are not needed on this step."""
        reason = ""
        try:
            model: Any = self.choice.model  # optional_contacts: step takes contacts=False
            if not contacts and getattr(model, "optional_contacts", False):
                out = model.step(op, dt, contacts=False)
            else:
                out = model.step(op, dt)
            if finite_output(out):
                return out, False
            reason = "returned a non-finite torque"
        except Exception as err:  # a failing model must not stop the node
            reason = f"raised {type(err).__name__}: {err}"
        self.failures += 1
        self._warn(
            "model",
            f"model {self.choice.model.name} {reason} at {describe(op)}; "
            "catalogue value published instead",
        )
        if may_step_down(requested, self.choice.mode):
            self._step_down(f"{self.choice.model.name} {reason}", op)
        return self.fallback.step(op, dt), True
