"""Fixtures of the ROS tests: one rclpy context per test, bounded spinning."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator

import pytest
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor

#: Longest a test waits for a message to arrive [s]; discovery on loopback takes ~0.1 s.
DEFAULT_TIMEOUT = 10.0

#: DragTorque's torque fields, in message order (the ``values`` of ``DragTorqueEncoder.encode``).
TORQUES = (
    "total",
    "nut_master",
    "nut_slave",
    "lubricant_shear",
    "dry_contact",
    "rolling_resistance",
    "hysteresis",
    "curvature",
    "spin",
)
#: DragTorque's float fields after ``fidelity``, in message order.
OPERATING_POINT = ("real_time_factor", "screw_speed", "temperature", "preload", "axial_load")


@pytest.fixture
def ros_context() -> Iterator[Context]:
    """An initialised rclpy context of its own, shut down after the test."""
    context = Context()
    rclpy.init(context=context)
    try:
        yield context
    finally:
        rclpy.try_shutdown(context=context)


@pytest.fixture
def executor(ros_context: Context) -> Iterator[SingleThreadedExecutor]:
    """A single-threaded executor on the test's context; nodes added to it are destroyed after."""
    ex = SingleThreadedExecutor(context=ros_context)
    try:
        yield ex
    finally:
        for node in ex.get_nodes():
            ex.remove_node(node)
            node.destroy_node()
        ex.shutdown(timeout_sec=1.0)


SpinUntil = Callable[..., bool]


def spin_until(
    executor: SingleThreadedExecutor,
    condition: Callable[[], bool],
    timeout: float = DEFAULT_TIMEOUT,
    every: Callable[[], None] | None = None,
) -> bool:
    """Spin ``executor`` until ``condition()`` holds or ``timeout`` [s] passes.

    ``every`` runs before each spin step (e.g. to re-publish a best-effort command).
    Returns whether the condition was met; never blocks longer than about ``timeout``.
    """
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if every is not None:
            every()
        executor.spin_once(timeout_sec=0.02)
        if condition():
            return True
    return condition()


@pytest.fixture(name="spin_until")
def spin_until_fixture() -> SpinUntil:
    """:func:`spin_until` as a fixture."""
    return spin_until
