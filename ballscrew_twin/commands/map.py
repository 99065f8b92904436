"""``ballscrew-twin map build|find|response --config YAML``: the real-time table of any screw.

``build`` solves the symmetric steady model on the table's grid for the screw of ``--config``
(:func:`~ballscrew_twin.models.map_grid.grid_for`) in ``--workers`` processes, with a
progress bar, and saves it in the user cache under the parameter set's fingerprint
(:func:`~ballscrew_twin.models.map_store.cached_map_path`), where the twin node finds it, or
to ``--out``. ``find`` says which table the node would use for that screw, and why each other
one is refused. ``response`` builds the screw's friction response table
(:mod:`~ballscrew_twin.models.friction_response`: how the torque answers a unit's own mu_dry
and tau_0, which ``commission`` fits where the table exists) into the user cache or ``--out``.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

from ..errors import MapError
from ..models import friction_response, map_build, map_grid, map_store
from ..models.map_build import Progress
from ..params import TwinConfig, check_number, limits, load_config
from .progress import progress_bar


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``map``."""
    sub = parser.add_subparsers(dest="action", required=True)
    build = sub.add_parser("build", help="build the real-time table of a screw (user cache)")
    find = sub.add_parser("find", help="which table the node would use for a screw, and why")
    response = sub.add_parser(
        "response", help="build the friction response table commissioning fits with"
    )
    for action in (build, find, response):
        action.add_argument(
            "--config", default=None, help="parameter YAML (default: the shipped paper screw)"
        )
    build.add_argument("--out", default="", help="output .npz (default: the user cache)")
    build.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    build.add_argument(
        "--preview",
        action="store_true",
        help=f"the small preview table ({'x'.join(map(str, map_grid.PREVIEW_NODES))} nodes)",
    )
    build.add_argument(
        "--force", action="store_true", help="build even when the cache holds the table"
    )
    build.add_argument("--no-progress", action="store_true", help="no progress bar")
    response.add_argument("--out", default="", help="output .npz (default: the user cache)")
    response.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    response.add_argument("--no-progress", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    """Build or find the table; errors are raised as BallscrewTwinError (one line)."""
    config = load_config(args.config)
    if args.action == "find":
        search = map_store.find_map(config)
        for line in search.refused:
            print(f"refused: {line}")
        if search.table is None:
            path = map_store.cached_map_path(config, map_grid.grid_for(config))
            print(
                f"no table for {config.source}: build it with `ballscrew-twin map build "
                f"--config {config.source}` (it goes to {path})"
            )
            return 1
        print(f"table for {config.source}: {search.path}")
        return 0
    workers = limits("-", 1, math.inf, integer=True)
    check_number(args.workers, workers, "--workers", text=False, error=MapError)
    if args.action == "response":
        return _build_response(args, config)
    grid = map_grid.grid_for(config, preview=args.preview)
    out = Path(args.out) if args.out else map_store.cached_map_path(config, grid)
    if out.is_file() and not args.force and not args.out:
        print(f"{out}: already built for {config.source} (--force builds it again)")
        return 0
    start = time.monotonic()
    table = _built(
        "steady map",
        out,
        args.no_progress,
        lambda progress: map_build.build_map(
            config, grid, workers=args.workers, on_progress=progress
        ),
    )
    if table is None:
        return 130
    filled = int(table.filled.sum())
    print(
        f"wrote {out}: {table.node_count} nodes in {time.monotonic() - start:.1f} s, "
        f"{filled} filled from a neighbour (steady solver failed there)"
    )
    return 0


def ensure_friction_response(config: TwinConfig) -> None:
    """Build ``config``'s friction response table into the user cache when there is none, and
    say so (``commission``, and ``detect`` with a baseline that has friction scales)."""
    _, built = friction_response.ensure_response(config)
    if built is not None:
        print(f"built the friction response table of {config.source} into {built}")


def _build_response(args: argparse.Namespace, config: TwinConfig) -> int:
    """``map response``: solve the friction response table of ``config`` and write it."""
    out = Path(args.out) if args.out else friction_response.cached_response_path(config)
    start = time.monotonic()
    table = _built(
        "friction response",
        out,
        args.no_progress,
        lambda progress: friction_response.build_response(
            config, workers=args.workers, on_progress=progress
        ),
    )
    if table is None:
        return 130
    print(
        f"wrote {out}: {table.coefficients[..., 0, 0].size} nodes in "
        f"{time.monotonic() - start:.1f} s, {int(table.filled.sum())} filled from a neighbour "
        "(a solve failed or answered irregularly there)"
    )
    return 0


_Table = TypeVar("_Table", bound=map_store.Saveable)


def _built(
    label: str, out: Path, no_progress: bool, build: Callable[[Progress], _Table]
) -> _Table | None:
    """Run ``build`` with a progress bar named ``label`` and save its table to ``out``
    (atomically); None when interrupted, with nothing written."""
    try:
        with progress_bar(label, "line", enabled=not no_progress) as advance:
            table = build(lambda done, total, _elapsed: advance(done, total))
    except KeyboardInterrupt:
        print(f"interrupted: nothing written to {out}", file=sys.stderr)
        return None
    map_store.save_atomic(table, out)
    return table
