"""``ballscrew-twin node [--params-file FILE] [--ros-args ...]``: run the twin node.

The same node as the ``twin_node`` console script (:mod:`ballscrew_twin.ros.twin_node`); every
argument after ``--ros-args`` goes to ROS unchanged (``-p name:=value``, ``--params-file``,
``-r old:=new``, ``--log-level`` ...).
"""

from __future__ import annotations

import argparse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``node``."""
    parser.add_argument(
        "--params-file",
        default=None,
        help="ROS parameter file (e.g. config/twin_node.yaml); same as --ros-args --params-file",
    )
    parser.add_argument(
        "--ros-args",
        dest="ros_args",
        nargs=argparse.REMAINDER,
        default=[],
        help="ROS arguments, passed on unchanged (must come last)",
    )


def ros_argv(args: argparse.Namespace) -> list[str]:
    """The argument vector rclpy sees: program name, then ``--ros-args`` and its arguments."""
    ros: list[str] = []
    if args.params_file:
        ros += ["--params-file", args.params_file]
    ros += list(args.ros_args)
    return ["ballscrew-twin-node", "--ros-args", *ros] if ros else ["ballscrew-twin-node"]


def run(args: argparse.Namespace) -> int:
    """Run the twin node until SIGINT/SIGTERM; 0 on a clean stop, 1 if it cannot start."""
    from .twin_node import run_node

    return run_node(ros_argv(args))
