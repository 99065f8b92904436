"""The tick thread: calls its function when asked, survives its errors, stops promptly."""

from __future__ import annotations

import gc
import itertools
import sys
import threading
import time

import pytest

from ballscrew_twin.errors import ConfigError
from ballscrew_twin.ros.tick_thread import MAX_SLEEP, SWITCH_INTERVAL, TickThread, prepare_process


def test_calls_run_due_after_the_delay_it_asks_for() -> None:
    calls: list[float] = []
    done = threading.Event()

    def run_due() -> float:
        calls.append(time.monotonic())
        if len(calls) == 20:
            done.set()
        return 0.005  # s

    thread = TickThread(run_due, lambda err: None)
    thread.start()
    assert done.wait(5.0)
    thread.stop()
    assert not thread.running
    gaps = [b - a for a, b in itertools.pairwise(calls[:20])]
    assert min(gaps) >= 0.005  # never before it is due
    assert sorted(gaps)[len(gaps) // 2] < 0.05  # and not some unrelated period (median)
    assert "timer slack" in thread.scheduling


def test_an_error_is_reported_and_the_calls_go_on() -> None:
    errors: list[Exception] = []
    calls = []

    def run_due() -> float:
        calls.append(1)
        if len(calls) == 2:
            raise RuntimeError("boom")
        return 0.0

    thread = TickThread(run_due, errors.append)
    thread.start()
    deadline = time.monotonic() + 5.0
    while len(calls) < 10 and time.monotonic() < deadline:
        time.sleep(0.01)
    thread.stop()
    assert len(calls) >= 10
    assert [str(e) for e in errors] == ["boom"]


def test_nothing_to_drive_and_stop_while_idle() -> None:
    calls = []

    def run_due() -> None:
        calls.append(time.monotonic())

    thread = TickThread(run_due, lambda err: None)
    thread.start()
    time.sleep(3.5 * MAX_SLEEP)
    start = time.monotonic()
    thread.stop()
    assert time.monotonic() - start < 2.0 * MAX_SLEEP + 0.5
    assert not thread.running
    assert 2 <= len(calls) <= 6  # called again every MAX_SLEEP while idle


def test_priority_checked_and_its_outcome_reported() -> None:
    with pytest.raises(ConfigError, match="priority = 100"):
        TickThread(lambda: None, lambda err: None, priority=100)
    ran = threading.Event()
    thread = TickThread(lambda: ran.set(), lambda err: None, priority=1)
    thread.start()
    assert ran.wait(5.0)
    thread.stop()
    # Granted (root, rtprio limit) or refused with the reason: either way it says which.
    assert "SCHED_FIFO" in thread.scheduling


def test_prepare_process_sets_the_switch_interval_and_the_callers_priority() -> None:
    before = sys.getswitchinterval()
    results: dict[str, str] = {}
    try:
        # In threads of their own: a granted SCHED_FIFO must not stay on the test's thread.
        for priority in (0, 1, 5):
            worker = threading.Thread(
                target=lambda p=priority: results.__setitem__(str(p), prepare_process(p))
            )
            worker.start()
            worker.join()
        assert sys.getswitchinterval() == pytest.approx(SWITCH_INTERVAL)
        assert gc.get_freeze_count() > 0
    finally:
        sys.setswitchinterval(before)
        gc.unfreeze()
    assert results["0"] == results["1"] == "normal scheduling"  # the tick thread's - 1 is 0
    assert "SCHED_FIFO" in results["5"] and "4" in results["5"]  # granted or refused, named
