"""The twin node's ticks on a thread of their own, off the executor (no rclpy here).

An rclpy timer at 1 kHz costs a large share of a core by itself (the executor's Python wait-set
machinery runs on every wake-up) and a tick waits behind whatever callback the executor is
running. :class:`TickThread` instead sleeps until the next tick is due with the operating
system's high-resolution sleep (``time.sleep`` is ``clock_nanosleep`` on Linux), runs the ticks
that are due, and sleeps again; the executor thread only serves subscriptions, services and the
diagnostics timer. Measured in ``docs/benchmarks.md`` (``ballscrew-twin bench node``).

Optional real-time settings of the thread (Linux): a timer slack of 1 us instead of the kernel's
default 50 us, and ``SCHED_FIFO`` at a priority (needs CAP_SYS_NICE or an ``rtprio`` limit;
refused otherwise, which is reported, not fatal).
"""

from __future__ import annotations

import ctypes
import gc
import os
import sys
import threading
import time
from collections.abc import Callable

from ..errors import ConfigError

#: Longest single sleep, so that :meth:`TickThread.stop` is honoured promptly [s].
MAX_SLEEP = 0.05
#: Timer slack asked for the tick thread [ns] (Linux ``PR_SET_TIMERSLACK``).
TIMER_SLACK_NS = 1_000
_PR_SET_TIMERSLACK = 29
#: Interpreter switch interval of a process that runs a tick thread [s] (Python's default is
#: 5 ms: a thread woken for its tick could wait that long for the GIL).
SWITCH_INTERVAL = 2e-4


def prepare_process(priority: int = 0) -> str:
    """Process-wide settings for a process whose main job is a tick thread, made by the thread
    that will spin the executor: a short interpreter switch interval (:data:`SWITCH_INTERVAL`),
    the objects of start-up moved out of the garbage collector's reach (``gc.freeze``: later
    full collections stay short), and, when the tick thread runs at SCHED_FIFO ``priority``
    (> 1), the calling thread at ``priority - 1``: the tick thread needs the interpreter lock
    the executor thread may hold, and a holder preempted by ordinary processes would keep it
    waiting (priority inversion). Returns how the calling thread is scheduled."""
    sys.setswitchinterval(SWITCH_INTERVAL)
    gc.collect()
    gc.freeze()
    return _set_fifo_priority(priority - 1) if priority > 1 else "normal scheduling"


def _set_timer_slack(slack_ns: int) -> str:
    """Ask for a timer slack of ``slack_ns`` [ns] for the calling thread; what happened."""
    if not sys.platform.startswith("linux"):
        return "timer slack: default (not Linux)"
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(_PR_SET_TIMERSLACK, slack_ns, 0, 0, 0) != 0:
            return f"timer slack: default ({os.strerror(ctypes.get_errno())})"
    except (OSError, AttributeError) as err:
        return f"timer slack: default ({err})"
    return f"timer slack {slack_ns} ns"


def _set_fifo_priority(priority: int) -> str:
    """Run the calling thread under ``SCHED_FIFO`` at ``priority`` (1..99); what happened."""
    if priority <= 0:
        return "normal scheduling"
    if not hasattr(os, "sched_setscheduler"):
        return f"normal scheduling (SCHED_FIFO {priority} not available on {sys.platform})"
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except OSError as err:
        return f"normal scheduling (SCHED_FIFO {priority} refused: {err.strerror})"
    return f"SCHED_FIFO priority {priority}"


class TickThread:
    """Calls ``run_due`` whenever it asks to be called, on a daemon thread.

    Args:
        run_due: runs what is due and returns the time until it is to be called again [s]
            (<= 0: at once), or None when it has nothing to drive for now (called again after
            :data:`MAX_SLEEP`).
        on_error: called with any exception ``run_due`` raises; the thread goes on.
        priority: ``SCHED_FIFO`` priority of the thread, 1..99, or 0 for normal scheduling.
        name: thread name (shown by ``top -H``).
    """

    def __init__(
        self,
        run_due: Callable[[], float | None],
        on_error: Callable[[Exception], None],
        *,
        priority: int = 0,
        name: str = "twin_ticks",
    ) -> None:
        if not 0 <= priority <= 99:
            raise ConfigError(f"priority = {priority} must be in 0..99 (0: normal scheduling)")
        self._run_due = run_due
        self._on_error = on_error
        self._priority = priority
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name=name, daemon=True)
        #: How the thread is scheduled (set once it runs), e.g. for diagnostics.
        self.scheduling = "not started"

    @property
    def running(self) -> bool:
        """Whether the thread is alive."""
        return self._thread.is_alive()

    def start(self) -> None:
        """Start the thread (once)."""
        self._thread.start()

    def stop(self, timeout: float = 2.0) -> None:
        """Ask the thread to end and wait up to ``timeout`` [s] for it."""
        self._stop.set()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(timeout)

    def _loop(self) -> None:
        self.scheduling = (
            f"{_set_fifo_priority(self._priority)}, {_set_timer_slack(TIMER_SLACK_NS)}"
        )
        while not self._stop.is_set():
            try:
                delay = self._run_due()
            except Exception as err:  # reported by the owner; the ticks go on
                self._on_error(err)
                delay = MAX_SLEEP
            if delay is None:
                delay = MAX_SLEEP
            if delay > 0.0:
                time.sleep(min(delay, MAX_SLEEP))
