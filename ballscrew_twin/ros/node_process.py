"""One node in a process of its own until SIGINT/SIGTERM: ``rclpy.init``, the node, an
executor, a ``spin_once`` loop, and a clean stop (the order of it matters, see below)."""

from __future__ import annotations

import signal
import sys
from collections.abc import Callable
from typing import TypeVar

import rclpy
from rclpy.exceptions import ParameterException
from rclpy.executors import Executor, ExternalShutdownException
from rclpy.node import Node

from ..errors import BallscrewTwinError
from .executors import spin

NodeT = TypeVar("NodeT", bound=Node)


def _ignore_signal(_signum: int, _frame: object) -> None:
    """Python-level SIGINT/SIGTERM handler behind rclpy's: the context shutdown is enough."""


def run_node_process(
    program: str,
    argv: list[str],
    make_node: Callable[[], NodeT],
    make_executor: Callable[[NodeT], Executor],
) -> int:
    """Run the node ``make_node()`` with ROS arguments ``argv`` until shut down; the exit code
    (1: it cannot start, said on stderr as ``program``). ``make_executor(node)`` returns the
    executor that spins the node, with the node added."""
    # rclpy's SIGINT/SIGTERM handler shuts the context down, then calls the handler installed
    # before it. Python's default one would raise KeyboardInterrupt at a random point of the
    # shutdown (it killed the process with SIGINT in 1 stop of ~8): install a silent one.
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, _ignore_signal)
    try:
        rclpy.init(args=argv)
    except Exception as err:  # rclpy's RCLError: unreadable --params-file, bad --ros-args
        print(f"{program}: cannot start: {err}", file=sys.stderr)
        return 1
    node: NodeT | None = None
    executor: Executor | None = None
    exit_code = 0
    try:
        node = make_node()
        executor = make_executor(node)
        spin(executor)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except (BallscrewTwinError, ParameterException, ValueError) as err:
        # Bad parameter file, screw configuration or initial operating point: say which.
        hint = ""
        if "expecting type 'DOUBLE'" in str(err):
            hint = " (write floating-point parameters with a decimal point, e.g. 1000.0)"
        print(f"{program}: cannot start: {err}{hint}", file=sys.stderr)
        exit_code = 1
    except Exception:
        if rclpy.ok():
            raise
        # SIGINT/SIGTERM while the node or the executor was being made shut the context down
        # under them (rclpy's RCLError "the given context is not valid"): a clean stop.
    finally:
        # The executor no longer spins here. Take the node out of it before destroying the node
        # (destroying a node under a live executor crashed with SIGSEGV in 3 of 20 stops), and
        # release the executor before the process exits: an EventsExecutor that still holds
        # the node's callbacks at exit aborts ("Destroying callback manager with callbacks
        # remaining", SIGABRT in 1 of 8 SIGTERM stops).
        if executor is not None and node is not None:
            executor.remove_node(node)
        if node is not None:
            node.destroy_node()
        if executor is not None:
            executor.shutdown()
            del executor
        rclpy.try_shutdown()
    return exit_code
