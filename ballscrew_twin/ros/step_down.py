"""When the twin node under ``fidelity: auto`` leaves its model for a cheaper one (no rclpy).

Two causes: the model does not fit into the step budget for :data:`OVER_BUDGET_WINDOWS`
windows of one simulated second in a row (so start-up and a single hiccup of a loaded machine
do not count), or a step of it failed. The node books its ticks here and asks after each
simulated second; building the cheaper model is ``ros/fidelity_modes.py``'s job.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .tick_counts import TickWindow

#: Windows (of one simulated second) in a row in which the model's mean step time exceeds the
#: step budget before ``fidelity: auto`` steps down [-].
OVER_BUDGET_WINDOWS = 2
#: The mode below which there is nothing to step down to.
CHEAPEST_MODE = "catalog"


def may_step_down(requested: str, mode: str) -> bool:
    """Whether the node may leave the model of ``mode`` for a cheaper one: only under the
    ``fidelity`` parameter ``auto`` (an explicit choice is kept), and not from the cheapest."""
    return requested == "auto" and mode != CHEAPEST_MODE


@dataclass
class StepDown:
    """The step budget watch of ``fidelity: auto``.

    Attributes:
        windows: windows in a row over the budget before stepping down [-].
        window: the ticks of the window under way.
        over_budget: windows in a row that were over the budget so far [-].
    """

    windows: int = OVER_BUDGET_WINDOWS
    window: TickWindow = field(default_factory=TickWindow)
    over_budget: int = 0

    def restart(self) -> None:
        """Start afresh (a new model runs): an empty window, no window over the budget."""
        self.window = TickWindow()
        self.over_budget = 0

    def window_full(self, sim_rate: float) -> bool:
        """Whether the window holds one simulated second at ``sim_rate`` [Hz]."""
        return self.window.ticks >= max(int(sim_rate), 1)

    def review(
        self, *, active: bool, model_name: str, step_budget: float, period: float
    ) -> str | None:
        """Close the window; why to step down now, or None.

        Args:
            active: whether the node may step down (:func:`may_step_down`); if not, the
                window is dropped and nothing counts.
            model_name: name of the model in use (for the reason).
            step_budget: share of the step the model may take [-].
            period: simulation step [s].
        """
        w = self.window
        self.window = TickWindow()
        if not active:
            return None
        budget = step_budget * period
        mean = w.mean_step_time
        self.over_budget = self.over_budget + 1 if mean > budget else 0
        if self.over_budget < self.windows:
            return None
        overdue = (w.late + w.skipped) / max(w.ticks + w.skipped, 1)
        return (
            f"{model_name} took {mean * 1e3:.3f} ms per step on average "
            f"(max {w.step_time_max * 1e3:.3f} ms; budget {budget * 1e3:.3f} ms of the "
            f"{period * 1e3:.3f} ms step), {overdue:.1%} ticks late or skipped"
        )
