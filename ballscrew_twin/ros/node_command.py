"""``ballscrew-twin node [--params-file FILE] [--ros-args ...]``: run the twin node.

The same node as the ``twin_node`` console script (:mod:`ballscrew_twin.ros.twin_node`); every
argument after ``--ros-args`` goes to ROS unchanged (``-p name:=value``, ``--params-file``,
``-r old:=new``, ``--log-level`` ...).
"""

from __future__ import annotations

import argparse

from .command_args import add_ros_arguments, ros_argv


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``node``."""
    add_ros_arguments(parser, "config/twin_node.yaml")


def run(args: argparse.Namespace) -> int:
    """Run the twin node until SIGINT/SIGTERM; 0 on a clean stop, 1 if it cannot start."""
    from .twin_node import run_node

    return run_node(ros_argv("ballscrew-twin-node", args))
