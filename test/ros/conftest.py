"""Fixtures of the ROS tests: one rclpy context per test, bounded spinning."""

from __future__ import annotations

import time
import weakref
from collections.abc import Callable, Iterator
from typing import Any

import pytest
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

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


#: Every rclpy node this process has made and not destroyed (see :func:`ros_context`).
_NODES: weakref.WeakSet[Node] = weakref.WeakSet()
_node_init = Node.__init__
_node_destroy = Node.destroy_node


def _tracked_node_init(self: Node, *args: Any, **kwargs: Any) -> None:
    _node_init(self, *args, **kwargs)
    _NODES.add(self)


def _tracked_node_destroy(self: Node) -> None:
    _NODES.discard(self)
    _node_destroy(self)


Node.__init__ = _tracked_node_init  # type: ignore[method-assign]
Node.destroy_node = _tracked_node_destroy  # type: ignore[method-assign]


def _destroy_left_nodes(context: Context) -> None:
    """Destroy the nodes of ``context`` still alive: with their own ``destroy_node``, or
    rclpy's where that fails (a node whose constructor raised half-way)."""
    for node in [n for n in _NODES if n.context is context]:
        try:
            node.destroy_node()
        except Exception:  # a half-built subclass: free what rclpy made
            _NODES.discard(node)
            _node_destroy(node)


@pytest.fixture
def ros_context() -> Iterator[Context]:
    """An initialised rclpy context of its own; after the test, every node made on it that is
    still alive is destroyed (also one whose constructor raised after rclpy's had run, or one
    the test forgot), and the context is shut down.

    A node left alive on a context that was only shut down keeps its DDS readers. With one
    such node (a health node, best-effort inputs) in the test process, the replayed sample
    bags lost 5-40 % of their messages to the next test's reliable subscribers in 4 of 8
    cases, at a time from which nothing more arrived, while the replay's drain reported
    every message acknowledged (Fast DDS 2.14.5, loopback; 2026-11-26)."""
    context = Context()
    rclpy.init(context=context)
    try:
        yield context
    finally:
        _destroy_left_nodes(context)
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
