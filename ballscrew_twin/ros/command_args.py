"""Command-line arguments shared by the ``ballscrew-twin`` commands that start an rclpy node.

Each such command accepts ``--ros-args ...`` (last; passed to ROS unchanged: ``-p name:=value``,
``--params-file``, ``-r old:=new``, ``--log-level`` ...), and the node commands also take a
``--params-file`` shortcut. No rclpy import here, so ``--help`` stays fast.
"""

from __future__ import annotations

import argparse

from ..errors import ConfigError
from ..params import check_number, positive


def add_ros_arguments(parser: argparse.ArgumentParser, params_example: str | None = None) -> None:
    """Add ``--ros-args`` and, when ``params_example`` names a file, ``--params-file``."""
    if params_example is not None:
        parser.add_argument(
            "--params-file",
            default=None,
            help=f"ROS parameter file (e.g. {params_example}); same as --ros-args --params-file",
        )
    parser.add_argument(
        "--ros-args",
        dest="ros_args",
        nargs=argparse.REMAINDER,
        default=[],
        help="ROS arguments, passed on unchanged (must come last)",
    )


def ros_argv(program: str, args: argparse.Namespace) -> list[str]:
    """The argument vector rclpy sees: ``program``, then ``--ros-args`` and its arguments."""
    ros: list[str] = []
    if getattr(args, "params_file", None):
        ros += ["--params-file", args.params_file]
    ros += list(args.ros_args)
    return [program, "--ros-args", *ros] if ros else [program]


def check_duration(parser: argparse.ArgumentParser, duration: float) -> None:
    """Refuse a ``--duration`` [s] that is not a finite number > 0 through ``parser.error``
    (exit status 2), with the package's one number check's words: the option, the value, the
    unit and the range."""
    try:
        check_number(duration, positive("s"), "--duration", text=False)
    except ConfigError as err:
        parser.error(str(err))
