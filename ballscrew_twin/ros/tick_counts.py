"""Counts of the twin node's ticks: per window of time, since start-up, and whether the node
is still starting (no rclpy here)."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

#: A tick published within this time of its due time is on time [ns].
ON_TIME_NS = 1_000_000


@dataclass
class TickWindow:
    """Counters of the ticks of one window (since the last diagnostics message, or over one
    simulated second for the fidelity step-down).

    Attributes:
        ticks: ticks published [-].
        late: ticks published more than :data:`ON_TIME_NS` after their due time [-].
        skipped: ticks not run because the node fell too far behind [-].
        failures: model steps that failed (the catalogue model stood in) [-].
        step_time_sum: sum of the model step times [s].
        step_time_max: longest model step time [s].
        latencies_ns: due time to torque published, per tick [ns].
    """

    ticks: int = 0
    late: int = 0
    skipped: int = 0
    failures: int = 0
    step_time_sum: float = 0.0
    step_time_max: float = 0.0
    latencies_ns: list[int] = field(default_factory=list)

    def add(self, step_time: float, latency_ns: int) -> None:
        """Book one published tick: model step time [s], publish latency [ns]."""
        self.ticks += 1
        self.step_time_sum += step_time
        self.step_time_max = max(self.step_time_max, step_time)
        self.latencies_ns.append(latency_ns)
        if latency_ns > ON_TIME_NS:
            self.late += 1

    @property
    def mean_step_time(self) -> float:
        """Mean model step time [s]; 0 without ticks."""
        return self.step_time_sum / self.ticks if self.ticks else 0.0


@dataclass
class TickTotals:
    """Counts of the node's ticks since start-up [-].

    Attributes:
        published: ticks whose torque was published.
        contacts: contact-state messages published.
        late: ticks published late (after :data:`ON_TIME_NS`).
        skipped: ticks skipped after start-up (a warning).
        startup_skipped: ticks skipped during start-up (loading the model: not a warning).
        clock_jumps_back: times the clock went backwards (simulation restarted).
        clock_jumps_forward: times the clock leapt ahead (simulation restarted).
        tick_errors: exceptions that escaped a tick on the tick thread.
    """

    published: int = 0
    contacts: int = 0
    late: int = 0
    skipped: int = 0
    startup_skipped: int = 0
    clock_jumps_back: int = 0
    clock_jumps_forward: int = 0
    tick_errors: int = 0


class TickBook:
    """The node's tick counts: the window of the next /diagnostics message, the totals since
    start-up, and the start-up phase (before the first tick on time, at most ``grace_ns``
    [ns] of the steady clock), during which skipped ticks are not a warning.

    Attributes:
        totals: counts since start-up.
        window: counts since the last :meth:`close_window`.
        latency_log: if set, every tick's publish latency [ns] is appended (benchmarks).
    """

    def __init__(self, grace_ns: int) -> None:
        self.totals = TickTotals()
        self.window = TickWindow()
        self.latency_log: list[int] | None = None
        self._startup_ends_ns = time.monotonic_ns() + grace_ns

    @property
    def starting_up(self) -> bool:
        """Whether the node is still starting: no tick on time yet, within the grace time."""
        return time.monotonic_ns() < self._startup_ends_ns

    def close_window(self) -> TickWindow:
        """The window so far; a new one starts."""
        w, self.window = self.window, TickWindow()
        return w

    def book_skipped(self, count: int, review: TickWindow) -> bool:
        """Count ``count`` skipped ticks; whether at start-up (else they are also counted in
        the window and in the step-down's ``review`` window)."""
        if self.starting_up:
            self.totals.startup_skipped += count
            return True
        self.window.skipped += count
        review.skipped += count
        self.totals.skipped += count
        return False

    def book_published(self, step_time: float, latency_ns: int, review: TickWindow) -> None:
        """Count a published tick: model step time [s], publish latency [ns] (in the window,
        the step-down's ``review`` window and the totals); the first on time ends start-up."""
        self.totals.published += 1
        if latency_ns <= ON_TIME_NS:
            self._startup_ends_ns = 0  # keeping up: start-up is over
        else:
            self.totals.late += 1
        self.window.add(step_time, latency_ns)
        review.add(step_time, latency_ns)
        if self.latency_log is not None:
            self.latency_log.append(latency_ns)
