"""The executors the project's processes spin their nodes with, and one way to spin them.

rclpy 7.1.6 (Jazzy) offers the ``SingleThreadedExecutor`` and the C++ ``EventsExecutor``
(``rclpy.experimental``); the twin node takes either (parameter ``executor``), the processes
that only receive (console view, benchmark counter) take the events executor, which costs a
fraction of the CPU per message (docs/benchmarks.md, "Real-time node").
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rclpy.executors import Executor, SingleThreadedExecutor


def make_executor(name: str, context: Any) -> Executor:
    """The executor ``name`` (one of :data:`~ballscrew_twin.ros.twin_parameters.EXECUTORS`)
    on ``context``."""
    if name == "events":
        from rclpy.experimental import EventsExecutor

        return EventsExecutor(context=context)
    return SingleThreadedExecutor(context=context)


def spin(executor: Executor, until: Callable[[], bool] | None = None) -> None:
    """Spin until the context shuts down (or ``until()`` holds), one callback at a time.

    A ``spin_once`` loop for both executors: ``EventsExecutor.spin()`` ignored SIGTERM in an
    earlier check (docs ROS_NOTES), and the loop lets benchmarks stop after a fixed time.
    """
    context = executor.context
    while context.ok() and (until is None or not until()):
        spin_once(executor, 0.1)


def spin_once(executor: Executor, timeout_sec: float) -> None:
    """``executor.spin_once(timeout_sec)`` [s], where a shutdown (SIGINT/SIGTERM) between the
    caller's ``context.ok()`` and the wait is not an error (rclpy then raises RCLError: the wait
    set cannot be built on a shut-down context): the caller's ``context.ok()`` loop ends."""
    try:
        executor.spin_once(timeout_sec=timeout_sec)
    except Exception:
        if executor.context.ok():
            raise
