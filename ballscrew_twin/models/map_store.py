"""Where steady maps are kept and found: the user's cache, :func:`find_map`, :func:`save_atomic`.

A table built for another screw is cached under the parameter set's fingerprint
(:func:`cached_map_path`, in :func:`cache_dir`, never in the package); :func:`find_map` finds
the table of a parameter set (a given file, the packaged table, the cache) and says why each
other one is refused. A table is only ever used for the parameter set it was built for.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np

from ..errors import MapError
from ..params import TwinConfig, config_fingerprint
from ..units import RPM
from . import map_grid
from .map_grid import MapGrid
from .steady_map import DEFAULT_MAP_PATH, FORMAT_VERSION, SteadyMap, load_map

#: Folder of the user's cache below ``$XDG_CACHE_HOME`` (default ``~/.cache``).
CACHE_FOLDER = "ballscrew_twin"


def map_fingerprint(path: str | Path) -> str:
    """The fingerprint saved in a map file (read alone, without the tables).

    Raises:
        MapError: the file is missing or not a map.
    """
    try:
        with np.load(Path(path), allow_pickle=False) as data:
            return str(data["fingerprint"])
    except (OSError, KeyError, ValueError, EOFError) as err:
        raise MapError(f"{path}: not a readable steady map ({err})") from err


def cache_dir() -> Path:
    """The user's cache of built tables: ``$XDG_CACHE_HOME/ballscrew_twin`` (``$XDG_CACHE_HOME``
    unset or relative: ``~/.cache``), never inside the package."""
    base = os.environ.get("XDG_CACHE_HOME", "")
    root = Path(base) if base and Path(base).is_absolute() else Path.home() / ".cache"
    return root / CACHE_FOLDER


def cached_map_path(config: TwinConfig, grid: MapGrid) -> Path:
    """Where the table of ``config`` on ``grid`` is cached: :func:`cache_dir` / a name made of
    the fingerprint, the node counts and the file format (a table of an earlier format is not
    looked at: it is built again)."""
    nodes = f"{grid.speed_nodes}x{grid.temperature_nodes}x{grid.preload_nodes}"
    rpm = f"{grid.speed_max / RPM:.0f}rpm"
    name = f"steady_map_{config_fingerprint(config)[:20]}_{nodes}_{rpm}_v{FORMAT_VERSION}.npz"
    return cache_dir() / name


@dataclass(frozen=True)
class MapSearch:
    """What :func:`find_map` found.

    Attributes:
        table: the table built for the parameter set, or None.
        path: the file it came from ("" when none).
        refused: one line per file considered and refused, with the reason.
    """

    table: SteadyMap | None
    path: str
    refused: tuple[str, ...]


def find_map(config: TwinConfig, path: str | Path = "") -> MapSearch:
    """The table built for ``config``: ``path`` if given, else the packaged table, else the
    cached table of :func:`~.map_grid.grid_for` ``config``; a file built for other parameters
    (another fingerprint), unreadable or missing is refused and the reason kept."""
    fingerprint = config_fingerprint(config)
    refused: list[str] = []
    candidates = [Path(path).expanduser()] if path else []
    candidates += [DEFAULT_MAP_PATH, cached_map_path(config, map_grid.grid_for(config))]
    for index, file in enumerate(candidates):
        explicit = bool(path) and index == 0
        if not file.is_file():
            if explicit:
                refused.append(f"{file}: no such file")
            continue
        try:
            saved = map_fingerprint(file)
            if saved != fingerprint:
                refused.append(
                    f"{file}: built for other parameters (fingerprint {saved[:12]}, "
                    f"{config.source or config.name} has {fingerprint[:12]})"
                )
                continue
            return MapSearch(load_map(file), str(file), tuple(refused))
        except MapError as err:
            refused.append(str(err))
    return MapSearch(None, "", tuple(refused))


class Saveable(Protocol):
    """A table that writes itself to a file (:class:`SteadyMap`,
    :class:`~.friction_response.FrictionResponse`)."""

    def save(self, path: str | Path) -> None:
        """Write the table to ``path``."""
        ...


def save_atomic(table: Saveable, path: Path) -> None:
    """Save ``table`` to ``path`` through a temporary file in the same folder (created), so a
    reader never sees a half-written table."""
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_name(f".{path.stem}.{os.getpid()}.partial.npz")
    try:
        table.save(partial)
        os.replace(partial, path)
    finally:
        partial.unlink(missing_ok=True)
