"""``ballscrew-twin bench <what> [options]``: benchmarks that print (and write) their numbers.

Each benchmark is a module of this package with ``DESCRIPTION``, ``add_arguments(parser)`` and
``run(args)``; :data:`BENCHMARKS` wires them. Only the chosen one is imported, and its options
are parsed after it is chosen (``bench WHAT --help`` lists them). Benchmarks measure; they never
assert a speed, so the machine's load cannot fail them.
"""

from __future__ import annotations

import argparse
import importlib

#: benchmark name -> module of this package.
BENCHMARKS: dict[str, str] = {
    "contacts": "contact_laws",
    "steady": "steady",
    "protocol": "protocol",
    "accuracy": "accuracy",
    "stability": "stability",
    "skips": "skips",
    "node": "node",
    "detection": "detection",
    "extrapolation": "extrapolation",
    "screw": "screw",
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The benchmark's name, and everything after it for the benchmark's own parser."""
    parser.add_argument("what", choices=tuple(BENCHMARKS), help="which benchmark")
    parser.add_argument("options", nargs=argparse.REMAINDER, help="options of that benchmark")


def run(args: argparse.Namespace) -> int:
    """Import the chosen benchmark, parse its options, run it."""
    module = importlib.import_module(f"{__name__}.{BENCHMARKS[args.what]}")
    parser = argparse.ArgumentParser(
        prog=f"ballscrew-twin bench {args.what}", description=module.DESCRIPTION
    )
    module.add_arguments(parser)
    return int(module.run(parser.parse_args(args.options)))
