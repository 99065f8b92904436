"""Fixed-step tick schedule of the twin node, in step with a clock (no rclpy here).

Tick ``k`` is due at ``origin + k * period`` of the node's clock (wall time, or ``/clock``
under ``use_sim_time``). Each time the node wakes up it asks :meth:`TickScheduler.due` which
ticks to run: every tick that fell due since the last one (catching up after a short stall),
only the newest one when more than ``max_catch_up`` are due (the others are counted as
skipped), and a fresh start when the clock jumped backwards or far forwards. So the simulation
never drifts from the clock: it either keeps up, catches up, or skips and says so. On a wall
clock a far forward leap is time the caller did not run (a stall, or a stepped system clock),
so the ticks that fell due in it are counted as skipped too; on a replayed ``/clock`` it is a
seek, and nothing was missed.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from ..params import check_number, limits

#: A forward jump of the clock larger than this is a jump (replay seek), not a stall [ns].
FORWARD_JUMP_NS = 1_000_000_000


class TickPlan(NamedTuple):
    """What to run now (a named tuple: made at every wake-up, so it is cheap to build).

    Attributes:
        ticks: indices of the ticks to run, oldest first (times: :meth:`TickScheduler.time_of`).
        skipped: ticks that fell due but are not run (too far behind, or a forward jump of a wall
            clock) [-].
        jumped_back: the clock went backwards: the schedule restarted at ``now`` [-].
        jumped_forward: the clock leapt ahead by more than :data:`FORWARD_JUMP_NS`: restarted.
    """

    ticks: range
    skipped: int = 0
    jumped_back: bool = False
    jumped_forward: bool = False


#: Allowed simulation steps [ns] (whole numbers, > 0).
PERIOD_LIMITS = limits("ns", 0, math.inf, lo_open=True, integer=True)
#: Allowed most ticks run in one wake-up [-].
CATCH_UP_LIMITS = limits("-", 1, math.inf, integer=True)


class TickScheduler:
    """Fixed simulation step locked to a clock.

    Args:
        period_ns: simulation step [ns], > 0.
        max_catch_up: most ticks run in one wake-up; more due ticks are skipped [-], >= 1.
        wall_clock: the clock is wall time: the ticks passed in a forward jump count as skipped.
    """

    def __init__(self, period_ns: int, max_catch_up: int, *, wall_clock: bool = False) -> None:
        check_number(period_ns, PERIOD_LIMITS, "period_ns", text=False)
        check_number(max_catch_up, CATCH_UP_LIMITS, "max_catch_up", text=False)
        self.period_ns = period_ns
        self.max_catch_up = max_catch_up
        self.wall_clock = wall_clock
        self.origin_ns: int | None = None
        #: Index of the last tick handed out.
        self.last_index = 0

    def time_of(self, index: int) -> int:
        """Clock time at which tick ``index`` is due [ns]."""
        if self.origin_ns is None:
            raise RuntimeError("the schedule has not started")
        return self.origin_ns + index * self.period_ns

    def next_due_ns(self) -> int:
        """Clock time at which the next tick not yet handed out is due [ns]."""
        return self.time_of(self.last_index + 1)

    def start(self, origin_ns: int) -> None:
        """Start the grid at ``origin_ns`` [ns]: tick 0 is due then and counts as run, so the
        first tick handed out is tick 1 (align ``origin_ns`` with the waking timer's start)."""
        self.origin_ns = origin_ns
        self.last_index = 0

    def due(self, now_ns: int) -> TickPlan:
        """The ticks to run at clock time ``now_ns`` [ns] (and book them as handed out)."""
        if self.origin_ns is None:
            return self._start(now_ns)
        if now_ns < self.time_of(self.last_index):
            return self._start(now_ns, jumped_back=True)
        due_index = (now_ns - self.origin_ns) // self.period_ns
        backlog = due_index - self.last_index
        if backlog <= 0:
            return TickPlan(range(0))
        if backlog > self.max_catch_up:
            if backlog * self.period_ns > FORWARD_JUMP_NS:
                # The restart runs one tick of the backlog; on a wall clock the rest were missed.
                missed = backlog - 1 if self.wall_clock else 0
                return self._start(now_ns, jumped_forward=True, skipped=missed)
            self.last_index = due_index
            return TickPlan(range(due_index, due_index + 1), skipped=backlog - 1)
        first = self.last_index + 1
        self.last_index = due_index
        return TickPlan(range(first, due_index + 1))

    def _start(
        self,
        now_ns: int,
        *,
        jumped_back: bool = False,
        jumped_forward: bool = False,
        skipped: int = 0,
    ) -> TickPlan:
        """Restart at ``now_ns`` and hand out tick 0 (``skipped`` ticks missed before)."""
        self.origin_ns = now_ns
        self.last_index = 0
        return TickPlan(range(1), skipped, jumped_back, jumped_forward)
