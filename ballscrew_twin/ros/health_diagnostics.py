"""The health node's ``/diagnostics`` checks and its ``/clock`` watchdog (no rclpy here).

Checks: ``health`` (the verdict, its class and the monitor's counts), ``torque input`` (age of
the last torque sample) and, under ``use_sim_time``, ``clock`` (STALE when ``/clock`` has not
advanced for the node's ``clock_timeout`` of wall time: a replay paused or ended).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..health.monitor import HealthMonitor
from ..health.tracker import STATE_NAMES, STATE_UNITS
from ..health.verdicts import FAULT, OK, UNKNOWN, VERDICT_NAMES, WARN, HealthSample
from . import diagnostics
from .diagnostics import STALE, Check

#: Diagnostic level of each verdict.
DIAG_LEVEL = {OK: diagnostics.OK, WARN: diagnostics.WARN, FAULT: diagnostics.ERROR, UNKNOWN: STALE}


@dataclass
class ClockWatch:
    """Whether the node's clock (``/clock`` under ``use_sim_time``) still advances, on the
    steady clock.

    Attributes:
        clock_ns: the node clock's last reading [ns].
        moved: steady time at which it last changed [s].
        stale: whether it has stood still for longer than the timeout.
    """

    clock_ns: int
    moved: float
    stale: bool = False

    def observe(self, clock_ns: int, now: float, *, sim_time: bool, timeout: float) -> str | None:
        """Take a reading ``clock_ns`` [ns] at steady time ``now`` [s]; ``"resumed"`` when the
        clock advances again after standing still, ``"stale"`` when it has just stood still for
        longer than ``timeout`` [s] under ``sim_time``, else None."""
        if clock_ns != self.clock_ns or not sim_time:
            resumed = self.stale
            self.clock_ns, self.moved, self.stale = clock_ns, now, False
            return "resumed" if resumed else None
        if not self.stale and now - self.moved > timeout:
            self.stale = True
            return "stale"
        return None

    def text(self, now: float) -> str:
        """What the watchdog sees at steady time ``now`` [s], one line."""
        still = now - self.moved
        if self.clock_ns == 0:
            return f"no /clock received for {still:.1f} s"
        return f"/clock stopped at {self.clock_ns * 1e-9:.3f} s, {still:.1f} s ago"


def health_check(
    monitor: HealthMonitor,
    last: HealthSample | None,
    counts: tuple[tuple[str, str], ...],
) -> Check:
    """The verdict of the last sample (STALE before the first comparison), with the
    monitor's state (the drift tracked, once a block was compared) and the node's ``counts``
    (key, value)."""
    values = [("blocks", str(len(monitor.samples))), *counts]
    values.append(
        (
            "gated [s]",
            f"{monitor.gated_time:.1f} of {monitor.gated_time + monitor.compared_time:.1f}",
        )
    )
    noise = monitor.sensor_variance
    if noise is not None:
        values.append(("sensor noise [N m]", f"{math.sqrt(noise):.3g}"))
    tracker = monitor.tracker
    if monitor.compared_time > 0.0:
        # the drift tracked so far, each tracked state with its 1-sigma (0 before the filter's
        # first step for a state without a prior)
        for name, unit, value, std, tracked in zip(
            STATE_NAMES,
            STATE_UNITS,
            tracker.state,
            tracker.std,
            tracker.settings.tracked,
            strict=True,
        ):
            if tracked:
                label = f"tracked {name.replace('_', ' ')} [{unit}]"
                values.append((label, f"{value:.3g} +- {std:.2g}"))
    alarm = monitor.alarm
    if alarm is not None:
        values += [
            ("alarm time [s]", f"{alarm.time:.3f}"),
            ("detector", alarm.detector),
            ("estimated onset [s]", f"{alarm.onset:.3f}"),
        ]
    aligner = monitor.aligner
    missing = [
        s.name for s in (aligner.speed, aligner.temperature, aligner.preload) if not s.stamps
    ]
    if last is None:
        text = "no comparison yet" + (f": waiting for {', '.join(missing)}" if missing else "")
        return Check("health", STALE, text, tuple(values))
    text = VERDICT_NAMES[last.verdict]
    if last.fault_class:
        text += f": {last.fault_class} (confidence {last.confidence:.2f})"
    elif last.note:
        text += f" ({last.note})"
    return Check("health", DIAG_LEVEL[last.verdict], text, tuple(values))


def stale_health(health: Check, clock: ClockWatch, now: float) -> Check:
    """``health`` as it is, or STALE while the clock stands still (at steady time ``now``
    [s])."""
    if not clock.stale:
        return health
    return Check(
        "health", STALE, f"STALE: {clock.text(now)}; last: {health.message}", health.values
    )


def clock_check(clock: ClockWatch, now: float) -> Check:
    """The ``clock`` check under ``use_sim_time``, at steady time ``now`` [s]."""
    if clock.stale:
        return Check("clock", STALE, clock.text(now))
    return Check("clock", diagnostics.OK, f"/clock at {clock.clock_ns * 1e-9:.3f} s")


def torque_check(age: float, stale_after: float) -> Check:
    """The torque input: STALE when its last sample is ``age`` [s] old, more than
    ``stale_after`` [s] (or none came)."""
    return Check(
        "torque input",
        STALE if age > stale_after else diagnostics.OK,
        "no torque received" if not math.isfinite(age) else f"last sample {age:.2f} s ago",
    )
