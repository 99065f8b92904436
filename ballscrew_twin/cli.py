"""Command line: ``ballscrew-twin <command> ...``, the entry point that wires the commands.

Each command is a module with ``add_arguments(parser)`` and ``run(args)``: those of
:mod:`ballscrew_twin.commands` (one module per command), ``bench``
(:mod:`ballscrew_twin.benchmarks`) and the ROS commands of :mod:`ballscrew_twin.ros`. Only the
module of the command being run is imported (by name, so ``--help`` stays fast); a
:class:`BallscrewTwinError` it raises is printed as one line and exits with status 2. SI units
in and out, except speeds in rpm and temperatures in degrees Celsius on the command line,
converted by the commands at the edge.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence
from typing import Any

from .errors import BallscrewTwinError

__all__ = ["COMMANDS", "main"]

#: command -> (module, one-line help). Modules provide add_arguments(parser) and run(args).
COMMANDS: dict[str, tuple[str, str]] = {
    "drag": (
        "ballscrew_twin.commands.drag",
        "drag torque and contact states at one operating point",
    ),
    "calibrate": ("ballscrew_twin.commands.calibrate", "fit the parameters the paper omits"),
    "bench": ("ballscrew_twin.benchmarks", "benchmarks that print their numbers"),
    "report": ("ballscrew_twin.commands.report", "reproduce the paper's figures (PNG + CSV)"),
    "simulate": ("ballscrew_twin.commands.simulate", "run a scenario through the dynamic model"),
    "scene": (
        "ballscrew_twin.commands.scene",
        "run a scene with the cheapest model within tolerance",
    ),
    "sweep": ("ballscrew_twin.commands.sweep", "evaluate a grid or sample of operating points"),
    "map": ("ballscrew_twin.commands.map", "build or find the real-time table of a screw"),
    "node": ("ballscrew_twin.ros.node_command", "run the twin node (accepts --ros-args)"),
    "launch": ("ballscrew_twin.ros.launcher", "start several nodes from a launch file"),
    "replay": ("ballscrew_twin.ros.replay", "publish a recorded bag on its topics"),
    "record": ("ballscrew_twin.ros.record", "record topics into a bag"),
    "bench-data": ("ballscrew_twin.commands.bench_data", "generate recorded bench data"),
    "detect": ("ballscrew_twin.commands.detect", "run the fault detector on a bag"),
    "commission": ("ballscrew_twin.commands.commission", "fit a healthy unit's baseline to a bag"),
    "health-node": ("ballscrew_twin.ros.health_node", "run the health monitor node"),
}


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``ballscrew-twin`` console script."""
    parser = argparse.ArgumentParser(prog="ballscrew-twin", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    argv = list(sys.argv[1:] if argv is None else argv)
    wanted = argv[0] if argv and not argv[0].startswith("-") else None
    modules: dict[str, Any] = {}
    for name, (module_name, help_text) in COMMANDS.items():
        sub_parser = sub.add_parser(name, help=help_text)
        if wanted == name:  # import only the module of the command being run
            module = importlib.import_module(module_name)
            module.add_arguments(sub_parser)
            modules[name] = module
    args = parser.parse_args(argv)
    try:
        return int(modules[args.command].run(args))
    except BallscrewTwinError as err:
        print(f"ballscrew-twin {args.command}: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
