"""``ballscrew-twin sweep``: a grid or random sample of operating points and parameters.

Every point is an operating point (speed, temperature, preload, axial load) plus optional values
of any numeric field of the parameter set, named by its dotted path (``lubricant.eyring_stress``,
``contact.dry_friction_coefficient``, ``materials.ball.young_modulus``, ...). Each dimension is
given as

- a list ``a,b,c`` or a single value;
- ``lin:LO:HI:N`` or ``log:LO:HI:N``: N values evenly or geometrically spaced (grid);
- ``uniform:LO:HI`` or ``loguniform:LO:HI``: drawn at random (needs ``--samples``).

Without ``--samples`` the points are the cartesian product of the dimensions (in the order
speed, temperature, preload, axial load, then the parameters as given). With ``--samples N`` N
points are drawn with ``--seed``: each random dimension independently, each list by a uniform
choice among its values. Speeds are given in rpm and temperatures in degrees Celsius (negative
values as ``--temperature=-20,20``); everything else, and everything written, is SI. Random
draws are made in SI units (log-uniform temperatures are log-uniform in kelvin).

Each point is evaluated independently (a cold start, through
:class:`~ballscrew_twin.models.validity.ValidatedModel`: outside the validity envelope the value
is the clamped one and the ``notes`` column says so), so its result does not depend on which
worker ran it or in what order. The points run in chunks over local processes
(``--workers``, default all cores) or, with ``--scheduler tcp://host:port``, on an existing Dask
distributed cluster; both give the same file. A point that fails is a row with
``status = error`` and the message, never a crash of the sweep.

Output: ``--out FILE.csv`` (one row per point), ``FILE.json`` (the exact settings: model, mode,
parameter file and its SHA-256, dimensions, seed, package versions, run statistics) and
``FILE.png`` (drag torque as curves over a grid, one per value of the second varying
dimension, or as a heat map of random draws: :mod:`ballscrew_twin.plots.sweep`).
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import hashlib
import itertools
import json
import math
import os
import platform
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .. import __version__
from ..errors import ConfigError, SweepError
from ..models.base import MECHANISMS, OperatingPoint
from ..models.validity import ValidatedModel, ValidityEnvelope, kelvin_from_command_line
from ..params import TwinConfig, check_number, config_from_mapping, limits, load_config
from ..units import RPM
from .drag import MODEL_CHOICES, command_line_model

#: Operating-point dimensions: name -> (SI unit, CLI unit, CLI -> SI conversion).
OPERATING_DIMENSIONS: dict[str, tuple[str, str, Callable[[float], float]]] = {
    "screw_speed": ("rad/s", "rpm", lambda rpm: rpm * RPM),
    "temperature": ("K", "C", lambda celsius: kelvin_from_command_line(celsius, "--temperature")),
    "preload": ("N", "N", lambda newton: newton),
    "axial_load": ("N", "N", lambda newton: newton),
}
#: CSV column of each operating-point dimension (SI unit in the name).
OPERATING_COLUMNS = {
    "screw_speed": "screw_speed_rad_s",
    "temperature": "temperature_K",
    "preload": "preload_N",
    "axial_load": "axial_load_N",
}
#: Points per task sent to a worker (amortises the task overhead of ~1 ms local, more on Dask).
DEFAULT_CHUNK_SIZE = 8
#: Seconds to wait for a Dask scheduler before giving up.
DEFAULT_CONNECT_TIMEOUT = 20.0
RESULT_COLUMNS = (
    "status",
    "drag_torque_Nm",
    "nut_torque_master_Nm",
    "nut_torque_slave_Nm",
    *(f"{name}_Nm" for name in MECHANISMS),
    "fidelity",
    "notes",
    "error",
)


# ---------------------------------------------------------------------------------------------
# Dimensions


@dataclass(frozen=True)
class Dimension:
    """One swept quantity, in SI units.

    Attributes:
        name: operating-point field (``screw_speed``, ``temperature``, ``preload``,
            ``axial_load``) or dotted path of a parameter-set field.
        unit: its SI unit.
        values: the grid values (or the choices of a random draw); empty for a range.
        low: lower end of a random range [unit].
        high: upper end of a random range [unit].
        log: the random range is log-uniform.
    """

    name: str
    unit: str
    values: tuple[float, ...] = ()
    low: float = math.nan
    high: float = math.nan
    log: bool = False

    @property
    def is_range(self) -> bool:
        """Drawn from a continuous range (only with ``--samples``)."""
        return not self.values

    def describe(self) -> dict[str, Any]:
        """JSON-ready description (SI)."""
        if self.values:
            return {"name": self.name, "unit": self.unit, "values": list(self.values)}
        kind = "loguniform" if self.log else "uniform"
        return {"name": self.name, "unit": self.unit, kind: [self.low, self.high]}

    def draw(self, rng: np.random.Generator, count: int) -> list[float]:
        """``count`` values drawn with ``rng`` (uniform, log-uniform or choice of ``values``)."""
        if self.values:
            return [self.values[i] for i in rng.integers(0, len(self.values), size=count)]
        if self.log:
            return [
                float(v) for v in np.exp(rng.uniform(np.log(self.low), np.log(self.high), count))
            ]
        return [float(v) for v in rng.uniform(self.low, self.high, count)]


#: Allowed counts of the command line (--samples, --chunk-size, --workers) [-].
COUNT_LIMITS = limits("-", 1, math.inf, integer=True)


def _check_count(value: int, option: str) -> None:
    """Refuse a count ``value`` of the command-line ``option`` below 1 (the package's one
    number check, :func:`~ballscrew_twin.params.check_number`) with a SweepError naming it."""
    check_number(value, COUNT_LIMITS, option, text=False, error=SweepError)


def _number(
    text: str, where: str, unit: str, *, lo: float = -math.inf, whole: bool = False
) -> float:
    """``text`` as a finite number in ``unit`` from ``lo`` on (a whole one with ``whole``): the
    package's one number check (:func:`~ballscrew_twin.params.check_number`); its refusal as a
    SweepError naming ``where``."""
    meta = limits(unit, lo, math.inf, integer=whole)
    return float(check_number(text, meta, where, error=SweepError))


def parse_dimension(
    name: str,
    spec: str,
    unit: str,
    to_si: Callable[[float], float] = float,
    given_unit: str | None = None,
) -> Dimension:
    """Parse one dimension's specification (see the module docstring) into SI units.

    Args:
        name: the quantity's name (used in messages).
        spec: ``a,b,c`` | ``lin:LO:HI:N`` | ``log:LO:HI:N`` | ``uniform:LO:HI`` |
            ``loguniform:LO:HI``, in the command-line unit of the quantity.
        unit: the SI unit of the result (for messages and the settings file).
        to_si: conversion from the command-line unit to SI.
        given_unit: the command-line unit of ``spec``'s numbers (None: ``unit``).

    Raises:
        SweepError: naming the dimension and what is wrong.
    """
    where = f"sweep dimension {name} = {spec!r}"
    given = given_unit or unit
    kind, _, rest = spec.partition(":")
    if not rest:
        values = tuple(to_si(_number(part.strip(), where, given)) for part in spec.split(","))
        return Dimension(name, unit, values=values)
    parts = rest.split(":")
    if kind in ("lin", "log"):
        if len(parts) != 3:
            raise SweepError(f"{where}: expected {kind}:LO:HI:N")
        low, high = (
            _number(parts[0], f"{where}: LO", given),
            _number(parts[1], f"{where}: HI", given),
        )
        count = int(_number(parts[2], f"{where}: N", "-", lo=1, whole=True))
        if kind == "log":
            if low <= 0.0 or high <= 0.0:
                raise SweepError(f"{where}: log spacing needs LO, HI > 0")
            grid = np.geomspace(low, high, count)
        else:
            grid = np.linspace(low, high, count)
        return Dimension(name, unit, values=tuple(to_si(float(v)) for v in grid))
    if kind in ("uniform", "loguniform"):
        if len(parts) != 2:
            raise SweepError(f"{where}: expected {kind}:LO:HI")
        low = to_si(_number(parts[0], f"{where}: LO", given))
        high = to_si(_number(parts[1], f"{where}: HI", given))
        if not low < high:
            raise SweepError(f"{where}: LO must be below HI")
        if kind == "loguniform" and low <= 0.0:
            raise SweepError(f"{where}: log-uniform needs LO > 0 (in {unit})")
        return Dimension(name, unit, low=low, high=high, log=kind == "loguniform")
    raise SweepError(
        f"{where}: unknown form {kind!r}; use a list, lin:, log:, uniform: or loguniform:"
    )


def parameter_unit(config: TwinConfig, path: str) -> str:
    """SI unit of the numeric parameter-set field at dotted ``path``.

    Raises:
        SweepError: the path does not name a numeric field (the message lists the choices).
    """
    node: Any = config
    parts = path.split(".")
    for depth, part in enumerate(parts):
        if not dataclasses.is_dataclass(node):
            raise SweepError(f"sweep parameter {path!r}: {part!r} is below a non-section field")
        known = {f.name: f for f in dataclasses.fields(node)}
        if part not in known:
            raise SweepError(
                f"sweep parameter {path!r}: no field {part!r}; choices here: {sorted(known)}"
            )
        if depth == len(parts) - 1:
            if "min" not in known[part].metadata:
                raise SweepError(f"sweep parameter {path!r} is not a numeric field")
            return str(known[part].metadata["unit"])
        node = getattr(node, part)
    raise AssertionError("unreachable: the loop returns at the leaf")


def with_overrides(config: TwinConfig, overrides: dict[str, float]) -> TwinConfig:
    """``config`` with the fields at the dotted paths set, validated like a parameter file.

    Raises:
        ConfigError: a value out of its allowed range or breaking a cross-field rule (the
            message names the field).
    """
    if not overrides:
        return config
    data = dataclasses.asdict(config)
    source = data.pop("source")
    for path, value in overrides.items():
        *sections, leaf = path.split(".")
        node = data
        for section in sections:
            node = node[section]
        node[leaf] = value
    changed = ", ".join(f"{k} = {v!r}" for k, v in overrides.items())
    return config_from_mapping(data, f"{source or config.name} with {changed}")


# ---------------------------------------------------------------------------------------------
# Points and their evaluation


@dataclass(frozen=True)
class SweepTask:
    """What every worker needs to evaluate points: picklable, SI units.

    Attributes:
        model: a ``--model`` name (``drag.MODEL_CHOICES``).
        mode: steady-model mode (``auto``, ``symmetric``, ``full``).
        config: the parameter set before the per-point overrides.
        version: the client's package version; a worker with another version refuses the
            points (each becomes an error row) rather than mixing results of two versions.
    """

    model: str
    mode: str
    config: TwinConfig
    version: str = __version__


def evaluate_point(task: SweepTask, point: dict[str, float]) -> dict[str, Any]:
    """The result row of one point (its columns of :data:`RESULT_COLUMNS`).

    Never raises for a failing point: the row has ``status = error`` and the message.
    """
    row: dict[str, Any] = dict.fromkeys(RESULT_COLUMNS, "")
    overrides = {k: v for k, v in point.items() if k not in OPERATING_DIMENSIONS}
    try:
        if task.version != __version__:
            raise SweepError(
                f"worker runs ballscrew_twin {__version__}, the sweep was started with "
                f"{task.version}: install the same version on every worker"
            )
        config = with_overrides(task.config, overrides)
        op = OperatingPoint(**{k: point[k] for k in OPERATING_DIMENSIONS})
        model = ValidatedModel(
            command_line_model(task.model, task.mode, config), ValidityEnvelope.for_config(config)
        )
        out = model.evaluate(op)
    except Exception as err:  # a failed point is a row, never a crash of the sweep
        row["status"] = "error"
        row["error"] = f"{type(err).__name__}: {err}"
        return row
    row.update(
        {
            "status": "ok",
            "drag_torque_Nm": out.drag_torque,
            "nut_torque_master_Nm": out.nut_torque[0],
            "nut_torque_slave_Nm": out.nut_torque[1],
            "fidelity": out.fidelity,
            "notes": " | ".join(out.notes),
        }
    )
    for name in MECHANISMS:
        row[f"{name}_Nm"] = getattr(out.breakdown, name)
    return row


def evaluate_chunk(
    task: SweepTask, chunk: list[tuple[int, dict[str, float]]]
) -> list[tuple[int, dict[str, Any]]]:
    """Rows of a chunk of indexed points (runs on a worker: local process or Dask)."""
    return [(index, evaluate_point(task, point)) for index, point in chunk]


def grid_points(dimensions: Sequence[Dimension]) -> list[dict[str, float]]:
    """Cartesian product of the dimensions' values, the last dimension varying fastest."""
    ranged = [d.name for d in dimensions if d.is_range]
    if ranged:
        raise SweepError(
            f"dimensions {ranged} are random ranges (uniform:/loguniform:): give --samples"
        )
    names = [d.name for d in dimensions]
    return [
        dict(zip(names, combo, strict=True))
        for combo in itertools.product(*(d.values for d in dimensions))
    ]


def random_points(
    dimensions: Sequence[Dimension], samples: int, seed: int
) -> list[dict[str, float]]:
    """``samples`` points drawn with ``numpy.random.default_rng(seed)``, dimension by dimension."""
    _check_count(samples, "--samples")
    rng = np.random.default_rng(seed)
    columns = {d.name: d.draw(rng, samples) for d in dimensions}
    return [{name: columns[name][i] for name in columns} for i in range(samples)]


# ---------------------------------------------------------------------------------------------
# Execution: local processes or Dask distributed


Chunk = list[tuple[int, dict[str, float]]]


def _chunks(points: Sequence[dict[str, float]], size: int) -> list[Chunk]:
    indexed = list(enumerate(points))
    return [indexed[i : i + size] for i in range(0, len(indexed), size)]


def _run_local(task: SweepTask, chunks: list[Chunk], workers: int) -> Iterator[list[Any]]:
    """Rows of every chunk, as chunks complete, over ``workers`` local processes."""
    if workers <= 1:
        for chunk in chunks:
            yield evaluate_chunk(task, chunk)
        return
    with ProcessPoolExecutor(max_workers=workers) as pool:
        futures = [pool.submit(evaluate_chunk, task, chunk) for chunk in chunks]
        for future in as_completed(futures):
            yield future.result()


def _run_dask(
    task: SweepTask, chunks: list[Chunk], address: str, timeout: float
) -> Iterator[list[Any]]:
    """Rows of every chunk, as chunks complete, on the Dask scheduler at ``address``
    (``timeout``: seconds to wait for the connection)."""
    from distributed import Client
    from distributed import as_completed as dask_completed

    try:
        client = Client(address, timeout=f"{timeout}s")
    except (OSError, TimeoutError) as err:
        raise SweepError(f"cannot reach the Dask scheduler at {address}: {err}") from err
    with client:
        futures = client.map(evaluate_chunk, [task] * len(chunks), chunks, pure=False)
        for future in dask_completed(futures):
            yield future.result()


@dataclass
class SweepResult:
    """Rows in point order and the run's settings."""

    columns: list[str]
    rows: list[dict[str, Any]]
    settings: dict[str, Any]


def run_sweep(
    task: SweepTask,
    dimensions: Sequence[Dimension],
    points: Sequence[dict[str, float]],
    *,
    workers: int = 1,
    scheduler: str | None = None,
    connect_timeout: float = DEFAULT_CONNECT_TIMEOUT,
    chunk_size: int = DEFAULT_CHUNK_SIZE,
    progress: bool = False,
) -> SweepResult:
    """Evaluate ``points`` and collect the rows in point order.

    Args:
        task: model, mode and base parameter set.
        dimensions: the swept dimensions (their names are the points' keys), the four
            operating-point dimensions included (single values for those not varied).
        points: the points (SI values keyed by dimension name).
        workers: local processes (1: in this process); ignored with ``scheduler``.
        scheduler: address of a Dask distributed scheduler (``tcp://host:port``), or None.
        connect_timeout: seconds to wait for the scheduler.
        chunk_size: points per task.
        progress: show a tqdm bar (stderr).
    """
    from tqdm import tqdm

    _check_count(chunk_size, "--chunk-size")
    names = [d.name for d in dimensions]
    missing = [n for n in OPERATING_DIMENSIONS if n not in names]
    if missing:
        raise SweepError(f"operating-point dimensions {missing} are missing (give single values)")
    chunks = _chunks(points, chunk_size)
    started = time.perf_counter()
    stream = (
        _run_dask(task, chunks, scheduler, connect_timeout)
        if scheduler is not None
        else _run_local(task, chunks, workers)
    )
    results: dict[int, dict[str, Any]] = {}
    with tqdm(total=len(points), desc="sweep", unit="point", disable=not progress) as bar:
        for rows in stream:
            results.update(rows)
            bar.update(len(rows))
    wall = time.perf_counter() - started
    columns = [
        "index",
        "model",
        "mode",
        *OPERATING_COLUMNS.values(),
        *[n for n in names if n not in OPERATING_DIMENSIONS],
        *RESULT_COLUMNS,
        "config_sha256",
        "package_version",
    ]
    config_hash = config_sha256(task.config)
    rows = []
    for index, point in enumerate(points):
        row: dict[str, Any] = {"index": index, "model": task.model, "mode": task.mode}
        for key, column in OPERATING_COLUMNS.items():
            row[column] = point[key]
        row.update({n: point[n] for n in names if n not in OPERATING_DIMENSIONS})
        row.update(results[index])
        row["config_sha256"] = config_hash
        row["package_version"] = __version__
        rows.append(row)
    failed = sum(1 for r in rows if r["status"] != "ok")
    settings = {
        "model": task.model,
        "mode": task.mode,
        "config_file": task.config.source,
        "config_sha256": config_hash,
        "config_name": task.config.name,
        "dimensions": [d.describe() for d in dimensions],
        "points": len(points),
        "failed_points": failed,
        "chunk_size": chunk_size,
        "executor": f"dask {scheduler}" if scheduler else f"local processes x {max(workers, 1)}",
        "wall_time_s": wall,
        "package_version": __version__,
        "numpy_version": np.__version__,
        "python_version": platform.python_version(),
    }
    return SweepResult(columns=columns, rows=rows, settings=settings)


def config_sha256(config: TwinConfig) -> str:
    """SHA-256 of the parameter file ``config`` was read from (empty if it has none)."""
    path = Path(config.source)
    if not config.source or not path.is_file():
        return ""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _cell(value: Any) -> str:
    """CSV text of one value; floats with repr (exact round trip)."""
    if isinstance(value, float):  # numpy floats too (their repr names the type)
        return repr(float(value))
    return str(value)


def write_csv(result: SweepResult, path: Path) -> None:
    """One row per point, SI units (column names carry them)."""
    with path.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle)
        writer.writerow(result.columns)
        for row in result.rows:
            writer.writerow([_cell(row.get(c, "")) for c in result.columns])


def write_plot(result: SweepResult, dimensions: Sequence[Dimension], path: Path) -> Path | None:
    """Drag torque over the swept dimensions (PNG; see :mod:`ballscrew_twin.plots.sweep`);
    None when nothing varies or no point succeeded."""
    from ..plots.sweep import plot_sweep

    ok = sum(r["status"] == "ok" for r in result.rows)
    title = f"sweep: {result.settings['model']}, {ok} of {len(result.rows)} points ok"
    return plot_sweep(result.rows, dimensions, OPERATING_COLUMNS, title, path)


# ---------------------------------------------------------------------------------------------
# Command line


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``sweep``."""
    parser.add_argument("--model", default="steady", choices=MODEL_CHOICES)
    parser.add_argument("--mode", default="auto", choices=("auto", "symmetric", "full"))
    parser.add_argument("--config", default=None, help="parameter YAML (default: paper screw)")
    parser.add_argument("--speed", default="100", help="screw speed [rpm] (list or range)")
    parser.add_argument("--temperature", default="20", help="temperature [deg C]")
    parser.add_argument("--preload", default="1500", help="preload [N]")
    parser.add_argument("--axial-load", default="0", help="external axial load [N]")
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="PATH=SPEC",
        help="a parameter-set field by dotted path, SI (repeatable)",
    )
    parser.add_argument("--samples", type=int, default=None, help="random points (else a grid)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the random draw")
    parser.add_argument(
        "--workers", type=int, default=os.cpu_count() or 1, help="local processes (default: cores)"
    )
    parser.add_argument("--scheduler", default=None, help="Dask scheduler tcp://host:port")
    parser.add_argument(
        "--connect-timeout",
        type=float,
        default=DEFAULT_CONNECT_TIMEOUT,
        help="seconds to wait for the Dask scheduler",
    )
    parser.add_argument("--chunk-size", type=int, default=DEFAULT_CHUNK_SIZE)
    parser.add_argument("--out", required=True, help="CSV file (.json and .png written beside)")
    parser.add_argument("--no-plot", action="store_true", help="do not write the PNG")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def dimensions_from_args(args: argparse.Namespace, config: TwinConfig) -> list[Dimension]:
    """The swept dimensions of the command line (SI), single values included."""
    dims = [
        parse_dimension(name, getattr(args, name.replace("screw_", "")), unit, to_si, given)
        for name, (unit, given, to_si) in OPERATING_DIMENSIONS.items()
    ]
    for item in args.param:
        path, sep, spec = item.partition("=")
        if not sep or not path or not spec:
            raise SweepError(
                f"--param {item!r}: expected PATH=SPEC, e.g. lubricant.eyring_stress=1e6"
            )
        path = path.strip()
        if path in (d.name for d in dims):
            raise SweepError(f"--param {path!r} is given twice")
        dims.append(parse_dimension(path, spec.strip(), parameter_unit(config, path)))
    return dims


def run(args: argparse.Namespace) -> int:
    """``sweep``: evaluate the points, write CSV, JSON settings and PNG, print a summary."""
    out = Path(args.out)
    if out.suffix != ".csv":
        raise ConfigError(f"--out {out}: expected a .csv file name")
    config = load_config(args.config)
    dims = dimensions_from_args(args, config)
    if args.samples is None:
        points = grid_points(dims)
    else:
        points = random_points(dims, args.samples, args.seed)
    _check_count(args.workers, "--workers")
    task = SweepTask(model=args.model, mode=args.mode, config=config)
    result = run_sweep(
        task,
        dims,
        points,
        workers=args.workers,
        scheduler=args.scheduler,
        connect_timeout=args.connect_timeout,
        chunk_size=args.chunk_size,
        progress=not args.quiet,
    )
    result.settings["seed"] = args.seed if args.samples is not None else None
    result.settings["samples"] = args.samples
    out.parent.mkdir(parents=True, exist_ok=True)
    write_csv(result, out)
    out.with_suffix(".json").write_text(json.dumps(result.settings, indent=2), encoding="utf-8")
    plot = None if args.no_plot else write_plot(result, dims, out.with_suffix(".png"))
    failed = result.settings["failed_points"]
    print(
        f"sweep: {len(points)} points ({failed} failed) of {args.model} in "
        f"{result.settings['wall_time_s']:.2f} s ({result.settings['executor']}); "
        f"wrote {out}, {out.with_suffix('.json')}" + (f", {plot}" if plot else "")
    )
    clamped = sum("validity:" in str(row.get("notes", "")) for row in result.rows)
    if clamped:
        print(
            f"sweep: {clamped} of {len(points)} points were outside the validity envelope and "
            "evaluated clamped into it (notes column; docs/model.md section 13)",
            file=sys.stderr,
        )
    return 0
