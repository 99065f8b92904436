"""Tabulated steady state: the symmetric steady-state model on a grid, interpolated.

The two nuts of a preloaded double nut are independent in the steady state (the screw turns at
the commanded speed; each nut balances its own spheres against its own axial load), and on a
vertical screw every sphere of a nut is equivalent (symmetric mode). So one table holds, for
each nut, the drag torque by mechanism and the states of one sphere's four half-groove contacts
as functions of

- the screw speed, for each sign separately (a reversal is not a mirror image: the slips differ
  by a few per cent), on nodes uniform in log |speed| between ``speed_min`` and ``speed_max``;
- the temperature, on uniform nodes;
- the nut's *equivalent preload* (the preload that loads the nut alike with no external load:
  preload + axial load for the master nut, the preload for the slave nut; see
  :func:`equivalent_preloads`), on nodes uniform in its square root (the Hertz laws are
  steepest near zero load).

Between the nodes each quantity is a tensor product of Catmull-Rom cubics (C1; the edge cells
use a linearly extrapolated ghost node). The nut's drag torque is interpolated as
asinh(T / :data:`TORQUE_SCALE`), which is logarithmic for torques well above the scale, so the
power laws of the film and the viscosity become nearly linear; the mechanisms are interpolated
as they are and then corrected to add up to that torque. The contact states, which the drag
torque does not depend on, are kept on every other node of each axis (a quarter of the
file). Below ``speed_min`` the torque goes linearly to zero and the contact states are blended
linearly towards the standstill solution; outside the grid the inputs are clamped;
:meth:`SteadyMap.sample` says which. Nodes where the steady solver fails, even cold with its
continuation, are filled from their nearest solved neighbour in speed (a line solved at no
speed: the nearest such line in preload) and flagged; a sample that leans on a filled node
says so.

Build the committed table with ``ballscrew-twin map build --out
ballscrew_twin/data/steady_map.npz --force`` (progress bar; 2 worker processes by default).

Any other screw: ``ballscrew-twin map build --config YOUR.yaml`` builds the table of
:func:`grid_for` that screw into the user cache (:func:`cache_dir`, never the package), under
the parameter set's fingerprint (:func:`cached_map_path`); :func:`find_map` finds the table of
a parameter set (a given file, the packaged table, the cache) and says why each other one is
refused. A table is only ever used for the parameter set it was built for (its fingerprint).
"""

from __future__ import annotations

import hashlib
import math
import multiprocessing
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import NDArray

from ..errors import MapError, SolverError
from ..params import TwinConfig
from ..units import CELSIUS_ZERO, RPM
from .base import MECHANISMS, OperatingPoint
from .steady import SteadyStateModel

FloatArray = NDArray[np.float64]

#: Format version of the saved file; a file of another version is refused.
FORMAT_VERSION = 1
#: The committed map of the default parameter set (package data).
DEFAULT_MAP_PATH = Path(__file__).resolve().parent.parent / "data" / "steady_map.npz"
#: Steady-solver tolerance of the map's nodes (scaled residual) [-].
MAP_TOLERANCE = 1e-9
#: Torque scale of the asinh transform of the nut torque [N m] (linear below, log above).
TORQUE_SCALE = 1e-6
#: Contact quantities tabulated per half groove (names of :class:`~.base.ContactStates`);
#: ``in_contact`` is tabulated as 0/1 and read back as "interpolated value > 0.5".
CONTACT_FIELDS: tuple[str, ...] = (
    "normal_force",
    "friction_force",
    "contact_angle",
    "approach",
    "stiffness",
    "max_pressure",
    "semi_axis_x",
    "semi_axis_y",
    "film_thickness",
    "tallian_parameter",
    "load_share",
    "shear_stress",
    "lubricant_share",
    "slip_speed",
    "in_contact",
)
#: Contact fields that follow power laws of speed, viscosity and load (the film and what it
#: drives): interpolated as asinh(value / scale), logarithmic well above the scale (SI units).
LOG_SCALES: dict[str, float] = {
    "friction_force": 1e-9,
    "film_thickness": 1e-12,
    "tallian_parameter": 1e-6,
    "shear_stress": 1e-3,
    "slip_speed": 1e-9,
}
_LOG_FIELDS = np.array([name in LOG_SCALES for name in CONTACT_FIELDS])
_LOG_SCALE_VALUES = np.array([LOG_SCALES[name] for name in CONTACT_FIELDS if name in LOG_SCALES])
#: Lower bound of each field after interpolation: 0 except for the contact angle.
#: The scales by field, 1 where the field is interpolated as it is (the compiled kernel's form).
_LOG_SCALES_FULL = np.array([LOG_SCALES.get(name, 1.0) for name in CONTACT_FIELDS])
_LOWER_BOUND = np.array([-np.inf if name == "contact_angle" else 0.0 for name in CONTACT_FIELDS])
HALF_GROOVES = 4
NUTS = 2
NUT_NAMES = ("master", "slave")
#: Node counts (speed, temperature, preload) of the preview table of a new screw: built in
#: seconds, it serves while the full table is built (its error is measured by ``bench screw``).
PREVIEW_NODES = (9, 7, 9)
#: Niceness of the worker processes of a build (the real-time ticks of a node go first).
WORKER_NICENESS = 10
#: Folder of the user's cache below ``$XDG_CACHE_HOME`` (default ``~/.cache``).
CACHE_FOLDER = "ballscrew_twin"


def config_fingerprint(config: TwinConfig) -> str:
    """SHA-256 of every physical parameter of ``config`` (its name and source are ignored)."""
    text = repr(replace(config, name="", source=""))
    return hashlib.sha256(text.encode()).hexdigest()


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


def equivalent_preloads(op: OperatingPoint) -> tuple[float, float]:
    """Preload [N] that loads the (master, slave) nut as ``op`` does, with no external load.

    The external axial load acts on the master nut only (``SteadyStateModel.nut_axial_loads``),
    so the master nut carries preload + axial load and the slave nut the preload.
    """
    return op.preload + op.axial_load, op.preload


@dataclass(frozen=True)
class MapGrid:
    """Nodes of the map (odd node counts for a map: the contact table keeps every other node).

    Attributes:
        speed_min: lowest tabulated |screw speed| [rad/s] (> 0).
        speed_max: highest tabulated |screw speed| [rad/s].
        speed_nodes: nodes per speed sign, uniform in log |speed|.
        temperature_min: lowest temperature [K].
        temperature_max: highest temperature [K].
        temperature_nodes: nodes uniform in temperature.
        preload_max: highest equivalent preload [N] (the lowest is 0 N).
        preload_nodes: nodes uniform in sqrt(preload).
    """

    speed_min: float = 0.05 * RPM
    speed_max: float = 6000.0 * RPM
    speed_nodes: int = 49
    temperature_min: float = CELSIUS_ZERO - 40.0
    temperature_max: float = CELSIUS_ZERO + 100.0
    temperature_nodes: int = 29
    preload_max: float = 4000.0
    preload_nodes: int = 33

    def __post_init__(self) -> None:
        checks = (
            ("speed_min", 0.0 < self.speed_min < self.speed_max, "rad/s, 0 < speed_min < max"),
            ("temperature_min", 138.0 < self.temperature_min < self.temperature_max, "K, < max"),
            ("preload_max", self.preload_max > 0.0, "N, > 0"),
        )
        for name, ok, unit in checks:
            if not ok:
                raise MapError(f"map grid: {name} = {getattr(self, name)!r} is invalid ({unit})")
        for name in ("speed_nodes", "temperature_nodes", "preload_nodes"):
            if getattr(self, name) < 2:
                raise MapError(f"map grid: {name} = {getattr(self, name)} must be >= 2")

    def check_buildable(self) -> None:
        """Raise :class:`MapError` unless every node count is odd and >= 5 (see :meth:`coarse`)."""
        for name in ("speed_nodes", "temperature_nodes", "preload_nodes"):
            count = getattr(self, name)
            if count < 5 or count % 2 == 0:
                raise MapError(f"map grid: {name} = {count} must be odd and >= 5")

    @property
    def speeds(self) -> FloatArray:
        """|Speed| nodes [rad/s], ascending."""
        low, high = math.log(self.speed_min), math.log(self.speed_max)
        return np.exp(np.linspace(low, high, self.speed_nodes))

    @property
    def temperatures(self) -> FloatArray:
        """Temperature nodes [K]."""
        return np.linspace(self.temperature_min, self.temperature_max, self.temperature_nodes)

    @property
    def preloads(self) -> FloatArray:
        """Equivalent-preload nodes [N], uniform in sqrt(preload)."""
        return np.linspace(0.0, math.sqrt(self.preload_max), self.preload_nodes) ** 2

    def coarse(self) -> MapGrid:
        """Every other node of each axis (the grid of the contact table)."""
        return replace(
            self,
            speed_nodes=self.speed_nodes // 2 + 1,
            temperature_nodes=self.temperature_nodes // 2 + 1,
            preload_nodes=self.preload_nodes // 2 + 1,
        )

    def as_array(self) -> FloatArray:
        """The grid as 8 numbers (for saving)."""
        return np.array(
            [
                self.speed_min,
                self.speed_max,
                self.speed_nodes,
                self.temperature_min,
                self.temperature_max,
                self.temperature_nodes,
                self.preload_max,
                self.preload_nodes,
            ],
            dtype=np.float64,
        )

    @classmethod
    def from_array(cls, values: FloatArray) -> MapGrid:
        """Inverse of :meth:`as_array`."""
        v = [float(x) for x in values]
        if len(v) != 8:
            raise MapError(f"map grid: {len(v)} numbers, expected 8")
        return cls(v[0], v[1], int(v[2]), v[3], v[4], int(v[5]), v[6], int(v[7]))


def grid_for(config: TwinConfig, preview: bool = False) -> MapGrid:
    """The grid of ``config``'s table: the packaged table's nodes, with the speed range ending at
    the screw's critical speed when that is below 6000 rpm (the validity envelope clamps any
    faster command there, so nodes beyond it would never be read). ``preview``: the
    :data:`PREVIEW_NODES` grid over the same ranges."""
    grid = MapGrid()
    # params.py keeps the critical speed >= 1 rad/s, far above the lowest node (0.05 rpm).
    grid = replace(grid, speed_max=min(grid.speed_max, config.screw.critical_speed))
    if preview:
        speed, temperature, preload = PREVIEW_NODES
        grid = replace(
            grid, speed_nodes=speed, temperature_nodes=temperature, preload_nodes=preload
        )
    return grid


def cached_map_path(config: TwinConfig, grid: MapGrid) -> Path:
    """Where the table of ``config`` on ``grid`` is cached: :func:`cache_dir` / a name made of
    the fingerprint and the node counts."""
    nodes = f"{grid.speed_nodes}x{grid.temperature_nodes}x{grid.preload_nodes}"
    rpm = f"{grid.speed_max / RPM:.0f}rpm"
    return cache_dir() / f"steady_map_{config_fingerprint(config)[:20]}_{nodes}_{rpm}.npz"


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
    cached table of :func:`grid_for` ``config``; a file built for other parameters (another
    fingerprint), unreadable or missing is refused and the reason kept."""
    fingerprint = config_fingerprint(config)
    refused: list[str] = []
    candidates = [Path(path).expanduser()] if path else []
    candidates += [DEFAULT_MAP_PATH, cached_map_path(config, grid_for(config))]
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


def save_atomic(table: SteadyMap, path: Path) -> None:
    """Save ``table`` to ``path`` through a temporary file in the same folder (created), so a
    reader never sees a half-written table."""
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_name(f".{path.stem}.{os.getpid()}.partial.npz")
    try:
        table.save(partial)
        os.replace(partial, path)
    finally:
        partial.unlink(missing_ok=True)


@dataclass(frozen=True)
class NodeValues:
    """What one steady solve contributes to the table (index 0 master nut, 1 slave nut).

    Attributes:
        torque: (2, 6) drag torque per nut and mechanism [N m], :data:`~.base.MECHANISMS` order.
        contacts: (2, 4, F) contact quantities per nut and half groove, :data:`CONTACT_FIELDS`.
    """

    torque: FloatArray
    contacts: FloatArray


def node_values(model: SteadyStateModel, op: OperatingPoint) -> NodeValues:
    """Solve the symmetric steady state at ``op`` and extract the per-nut table entries.

    Raises:
        MapError: ``model`` does not solve one sphere per nut (symmetric mode).
        SolverError: the steady solver failed.
    """
    solution = model.solve(op)
    balls = solution.balls
    if not np.array_equal(balls.nut, np.arange(NUTS)):
        raise MapError("steady map: the steady model must run in symmetric mode (2 spheres)")
    torque = np.zeros((NUTS, len(MECHANISMS)))
    speed = solution.output.operating_point.screw_speed
    if solution.output.drag_torque != 0.0:  # zero at (or solved as) standstill
        for j, mechanism in enumerate(MECHANISMS):
            power = solution.contacts.dissipation[mechanism].sum(axis=1) * balls.weight
            torque[:, j] = power / speed
    states = solution.output.contacts
    assert states is not None  # the steady model always resolves its contacts
    contacts = np.stack(
        [np.asarray(getattr(states, name), dtype=np.float64) for name in CONTACT_FIELDS], axis=-1
    ).reshape(NUTS, HALF_GROOVES, len(CONTACT_FIELDS))
    return NodeValues(torque=torque, contacts=contacts)


# ---------------------------------------------------------------------------------------------
# Building


@dataclass(frozen=True)
class _Line:
    """One build task: every speed of one sign at one temperature and preload node."""

    sign: int  # 0: positive speeds, 1: negative speeds
    temperature: int
    preload: int


@dataclass(frozen=True)
class _LineResult:
    line: _Line
    torque: FloatArray  # (S, 2, 6)
    contacts: FloatArray  # (S, 2, 4, F)
    failed: NDArray[np.bool_]  # (S,)
    static: FloatArray  # (2, 4, F)


_WORKER: dict[str, SteadyStateModel | MapGrid] = {}


def _pool_worker_init(config: TwinConfig, grid: MapGrid, niceness: int) -> None:
    """Initialiser of a worker process (never of the calling process: its handler stays)."""
    # Ctrl-C reaches the whole process group: the parent alone stops the build (it terminates
    # the pool), so a worker does not print a KeyboardInterrupt traceback of its own.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if niceness:
        os.nice(niceness)
    _worker_init(config, grid)


def _worker_init(config: TwinConfig, grid: MapGrid) -> None:
    _WORKER["model"] = SteadyStateModel(config, mode="symmetric", tolerance=MAP_TOLERANCE)
    _WORKER["grid"] = grid


def _solve_line(line: _Line) -> _LineResult:
    """Standstill, then the speeds in ascending order, each warm-started from the last.

    A node the warm-started solve misses is solved cold by the steady model itself (its
    start-up path and fallbacks, a function of the node alone: docs/model.md 7a); if that
    fails too the node stays NaN and is flagged (not solved cold a second time, which would
    repeat the same path).
    """
    model, grid = _WORKER["model"], _WORKER["grid"]
    assert isinstance(model, SteadyStateModel) and isinstance(grid, MapGrid)
    temperature = float(grid.temperatures[line.temperature])
    preload = float(grid.preloads[line.preload])
    sign = 1.0 if line.sign == 0 else -1.0
    speeds = grid.speeds
    torque = np.full((len(speeds), NUTS, len(MECHANISMS)), np.nan)
    contacts = np.full((len(speeds), NUTS, HALF_GROOVES, len(CONTACT_FIELDS)), np.nan)
    failed = np.zeros(len(speeds), dtype=bool)
    model.forget_warm_start()
    static_op = OperatingPoint(screw_speed=0.0, temperature=temperature, preload=preload)
    static = node_values(model, static_op).contacts
    for i, speed in enumerate(speeds):
        op = OperatingPoint(screw_speed=sign * speed, temperature=temperature, preload=preload)
        try:
            values = node_values(model, op)
        except SolverError:
            model.forget_warm_start()
            failed[i] = True
            continue
        torque[i], contacts[i] = values.torque, values.contacts
    return _LineResult(line, torque, contacts, failed, static)


def _fill_failed(table: FloatArray, failed: NDArray[np.bool_]) -> None:
    """Replace failed nodes by the nearest solved node along the speed axis (axis 1), in place;
    a speed line that failed at every speed takes the whole nearest line along the last axis
    (the preload) that has a solved node.

    Raises:
        MapError: every line along the last axis failed at every speed.
    """
    count = failed.shape[1]
    whole = np.asarray(failed.all(axis=1))  # (sign, *rest): lines without a solved speed
    for sign, i, *rest in zip(*np.nonzero(failed), strict=True):
        if whole[(sign, *rest)]:
            continue
        for j in sorted(range(count), key=lambda k: abs(k - i)):
            if not failed[(sign, j, *rest)]:
                table[(sign, i, *rest)] = table[(sign, j, *rest)]
                break
    last = whole.shape[-1]
    for sign, *rest in zip(*np.nonzero(whole), strict=True):
        *other, k = rest
        for m in sorted(range(last), key=lambda q: abs(q - k)):
            if not whole[(sign, *other, m)]:
                table[(sign, slice(None), *other, k)] = table[(sign, slice(None), *other, m)]
                break
        else:
            raise MapError(f"steady map: the solver failed at every speed of lines {sign, *other}")


#: Progress callback of :func:`build_map`: (lines done, lines in all, seconds elapsed).
Progress = Callable[[int, int, float], None]


def build_map(
    config: TwinConfig,
    grid: MapGrid | None = None,
    workers: int = 2,
    progress: bool = True,
    on_progress: Progress | None = None,
    niceness: int = 0,
) -> SteadyMap:
    """Solve every node of ``grid`` with the symmetric steady model.

    Args:
        config: parameter set.
        grid: nodes (default :class:`MapGrid()`).
        workers: worker processes (1: solve in this process).
        progress: show a tqdm progress bar on stderr.
        on_progress: called after each line of nodes (see :data:`Progress`).
        niceness: added to the worker processes' niceness (with ``workers`` > 1). On Linux it
            is added to the calling thread's niceness before the workers start, so that they
            start niced (their imports included; a dedicated build thread stays niced);
            elsewhere each worker lowers its own priority once started.
    """
    from tqdm import tqdm

    grid = grid if grid is not None else MapGrid()
    grid.check_buildable()
    speeds, temps, preloads = grid.speeds, grid.temperatures, grid.preloads
    shape = (2, len(speeds), len(temps), len(preloads))
    torque = np.full((*shape, NUTS, len(MECHANISMS)), np.nan)
    contacts = np.full((*shape, NUTS, HALF_GROOVES, len(CONTACT_FIELDS)), np.nan)
    failed = np.zeros(shape, dtype=bool)
    static = np.full((*shape[2:], NUTS, HALF_GROOVES, len(CONTACT_FIELDS)), np.nan)
    lines = [_Line(s, t, p) for s in range(2) for t in range(shape[2]) for p in range(shape[3])]

    start = time.monotonic()

    def store(results: Iterable[_LineResult]) -> None:
        bar = tqdm(total=len(lines), desc="steady map", unit="line", disable=not progress)
        for done, res in enumerate(results, start=1):
            where = (res.line.sign, slice(None), res.line.temperature, res.line.preload)
            torque[where], contacts[where], failed[where] = res.torque, res.contacts, res.failed
            static[res.line.temperature, res.line.preload] = res.static
            bar.update()
            if on_progress is not None:
                on_progress(done, len(lines), time.monotonic() - start)
        bar.close()

    if workers <= 1:
        _worker_init(config, grid)
        store(_solve_line(line) for line in lines)
    else:
        context = multiprocessing.get_context("spawn")
        inherited = niceness > 0 and sys.platform == "linux"
        if inherited:  # Linux: a thread's niceness is its own, and a process it starts inherits it
            thread = threading.get_native_id()
            os.setpriority(
                os.PRIO_PROCESS, thread, os.getpriority(os.PRIO_PROCESS, thread) + niceness
            )
        init = (config, grid, 0 if inherited else niceness)
        with context.Pool(workers, initializer=_pool_worker_init, initargs=init) as pool:
            store(pool.imap_unordered(_solve_line, lines, chunksize=2))
    if failed.any():
        _fill_failed(torque, failed)
        _fill_failed(contacts, failed)
    return SteadyMap(
        grid=grid,
        torque=torque.astype(np.float32),
        contacts=contacts[:, ::2, ::2, ::2].astype(np.float32),
        static=static[::2, ::2].astype(np.float32),
        filled=failed,
        fingerprint=config_fingerprint(config),
        orientation=config.screw.orientation,
    )


# ---------------------------------------------------------------------------------------------
# Interpolation


def catmull_rom_weights(t: float) -> FloatArray:
    """Weights of the four nodes i-1, i, i+1, i+2 at fraction ``t`` in [0, 1] of cell [i, i+1]."""
    t2, t3 = t * t, t * t * t
    return 0.5 * np.array(
        [-t3 + 2.0 * t2 - t, 3.0 * t3 - 5.0 * t2 + 2.0, -3.0 * t3 + 4.0 * t2 + t, t3 - t2]
    )


def _catmull_rom_rows(t: FloatArray) -> FloatArray:
    """(N, 4) weights of :func:`catmull_rom_weights` for each fraction of ``t`` (N,)."""
    t2, t3 = t * t, t * t * t
    return 0.5 * np.column_stack(
        [-t3 + 2.0 * t2 - t, 3.0 * t3 - 5.0 * t2 + 2.0, -3.0 * t3 + 4.0 * t2 + t, t3 - t2]
    )


def pad_axis(table: FloatArray, axis: int) -> FloatArray:
    """Add a linearly extrapolated ghost node at both ends of ``axis``."""
    first, second = np.take(table, [0], axis=axis), np.take(table, [1], axis=axis)
    last, before = np.take(table, [-1], axis=axis), np.take(table, [-2], axis=axis)
    return np.concatenate([2.0 * first - second, table, 2.0 * last - before], axis=axis)


#: Where a query falls on one axis: index of its cell (= the first node of its 4-node stencil
#: in the padded table) and the fraction of the cell [-].
AxisCell = tuple[int, float]


def axis_cell(u: float, count: int) -> AxisCell:
    """Cell and fraction of ``u`` in node units (0 .. count-1) on an axis of ``count`` nodes,
    clamped to the axis."""
    u = min(max(u, 0.0), count - 1.0)
    cell = min(int(u), count - 2)
    return cell, u - cell


def speed_node(grid: MapGrid, speed: float) -> float:
    """|speed| [rad/s] in node units of ``grid``'s speed axis (uniform in log |speed|) [-]."""
    u = math.log(max(speed, grid.speed_min) / grid.speed_min) / math.log(
        grid.speed_max / grid.speed_min
    )
    return u * (grid.speed_nodes - 1)


def temperature_node(grid: MapGrid, temperature: float) -> float:
    """The temperature [K] in node units of ``grid``'s temperature axis (uniform) [-]."""
    u = (temperature - grid.temperature_min) / (grid.temperature_max - grid.temperature_min)
    return u * (grid.temperature_nodes - 1)


def preload_node(grid: MapGrid, preload: float) -> float:
    """The equivalent preload [N] in node units of ``grid``'s preload axis (uniform in
    sqrt(preload)) [-]."""
    u = math.copysign(math.sqrt(abs(preload) / grid.preload_max), preload)
    return u * (grid.preload_nodes - 1)


class QueryCells(NamedTuple):
    """Where one query falls on the axes of one grid (one preload cell per nut)."""

    speed: AxisCell
    temperature: AxisCell
    preloads: tuple[AxisCell, ...]


def query_cells(
    grid: MapGrid, speed: float, temperature: float, preloads: tuple[float, float]
) -> QueryCells:
    """The cells of |``speed``| [rad/s], ``temperature`` [K] and each nut's equivalent preload
    [N] on ``grid``."""
    return QueryCells(
        axis_cell(speed_node(grid, speed), grid.speed_nodes),
        axis_cell(temperature_node(grid, temperature), grid.temperature_nodes),
        tuple(axis_cell(preload_node(grid, p), grid.preload_nodes) for p in preloads),
    )


@dataclass(frozen=True)
class AxisPosition:
    """A 4-node stencil on one axis: its first node in the padded table and its weights."""

    start: int
    weights: FloatArray


def _position(cell: AxisCell) -> AxisPosition:
    """The Catmull-Rom stencil of ``cell``."""
    return AxisPosition(start=cell[0], weights=catmull_rom_weights(cell[1]))


#: One nut's interpolated torque values, contact rows and standstill rows (None: not needed).
_NutStencils = tuple[FloatArray, FloatArray, FloatArray | None]


@dataclass(frozen=True)
class _Positions:
    """Stencils of one query on the three axes."""

    speed: AxisPosition
    temperature: AxisPosition
    preload: AxisPosition


def _stencil(table: FloatArray, pos: _Positions) -> FloatArray:
    """Interpolate a padded (S, T, P, nut, V) table at ``pos``: (nut, V)."""
    s, t, p = pos.speed.start, pos.temperature.start, pos.preload.start
    block = table[s : s + 4, t : t + 4, p : p + 4]
    w = np.outer(np.outer(pos.speed.weights, pos.temperature.weights), pos.preload.weights)
    return np.asarray(w.reshape(64) @ block.reshape(64, -1)).reshape(table.shape[3:])


def _stencil_2d(table: FloatArray, pos: _Positions) -> FloatArray:
    """Interpolate a padded (T, P, nut, V) table at ``pos`` (speed unused): (nut, V)."""
    t, p = pos.temperature.start, pos.preload.start
    w = np.outer(pos.temperature.weights, pos.preload.weights)
    block = table[t : t + 4, p : p + 4]
    return np.asarray(w.reshape(16) @ block.reshape(16, -1)).reshape(table.shape[2:])


def _nut_torques(values: FloatArray, blend: float) -> FloatArray:
    """(2, 6) torque per nut and mechanism [N m] from the interpolated (2, 1 + 6) values
    (asinh of the nut torque, then the mechanisms), scaled by the standstill ``blend`` [-]."""
    total = TORQUE_SCALE * np.sinh(values[:, :1])
    mechanisms = values[:, 1:]
    # Share the difference to the total out in proportion to each mechanism's size.
    magnitude = np.abs(mechanisms)
    size = magnitude.sum(axis=1, keepdims=True)
    share = np.divide(magnitude, size, out=np.zeros_like(magnitude), where=size > 0.0)
    return (mechanisms + (total - mechanisms.sum(axis=1, keepdims=True)) * share) * blend


@dataclass(frozen=True)
class MapSample:
    """Interpolated state of both nuts at one query.

    Attributes:
        torque: (2, 6) drag torque per nut and mechanism [N m] (it has the sign of the speed).
        contacts: (2, 4, F) contact quantities per nut and half groove, :data:`CONTACT_FIELDS`;
            None when the sample was taken without them.
        notes: clamping, standstill blending and filled nodes, in words.
    """

    torque: FloatArray
    contacts: FloatArray | None
    notes: tuple[str, ...] = field(default_factory=tuple)


@dataclass(frozen=True)
class SteadyMap:
    """The tables and their interpolation (see the module docstring).

    Attributes:
        grid: nodes of the torque table.
        torque: (2 signs, S, T, P, 2 nuts, 6) drag torque per mechanism [N m].
        contacts: (2, S', T', P', 2, 4, F) contact quantities (:data:`CONTACT_FIELDS`, SI) on
            ``grid.coarse()``.
        static: (T', P', 2, 4, F) contact quantities at standstill on ``grid.coarse()``.
        filled: (2, S, T, P) nodes filled from a neighbour because the solver failed there.
        fingerprint: :func:`config_fingerprint` of the parameter set the map was built for.
        orientation: screw orientation of that parameter set.
    """

    grid: MapGrid
    torque: NDArray[np.floating]
    contacts: NDArray[np.floating]
    static: NDArray[np.floating]
    filled: NDArray[np.bool_]
    fingerprint: str
    orientation: str
    _padded: dict[str, FloatArray] = field(default_factory=dict, compare=False, repr=False)
    _coarse: MapGrid | None = field(default=None, compare=False, repr=False)
    _any_filled: bool = field(default=False, compare=False, repr=False)
    _filled_window: NDArray[np.bool_] = field(
        default_factory=lambda: np.zeros((2, 1, 1, 1), dtype=bool), compare=False, repr=False
    )

    def __post_init__(self) -> None:
        self.grid.check_buildable()
        g, c = self.grid, self.grid.coarse()
        shape = (2, g.speed_nodes, g.temperature_nodes, g.preload_nodes)
        coarse = (2, c.speed_nodes, c.temperature_nodes, c.preload_nodes)
        expected = {
            "torque": (*shape, NUTS, len(MECHANISMS)),
            "contacts": (*coarse, NUTS, HALF_GROOVES, len(CONTACT_FIELDS)),
            "static": (*coarse[2:], NUTS, HALF_GROOVES, len(CONTACT_FIELDS)),
            "filled": shape,
        }
        for name, want in expected.items():
            table = getattr(self, name)
            if table.shape != want:
                raise MapError(f"steady map: {name} has shape {table.shape}, the grid needs {want}")
            if name != "filled" and not np.isfinite(table).all():
                raise MapError(f"steady map: {name} holds non-finite values")
        mechanisms = np.asarray(self.torque, dtype=np.float64)
        total = np.arcsinh(mechanisms.sum(axis=-1, keepdims=True) / TORQUE_SCALE)
        torque = np.concatenate([total, mechanisms], axis=-1)
        contacts = np.asarray(self.contacts, dtype=np.float64).copy()
        contacts[..., _LOG_FIELDS] = np.arcsinh(contacts[..., _LOG_FIELDS] / _LOG_SCALE_VALUES)
        contacts = contacts.reshape(*coarse, NUTS, -1)
        static = np.asarray(self.static, dtype=np.float64).reshape(*coarse[2:], NUTS, -1)
        for axis in (1, 2, 3):
            torque, contacts = pad_axis(torque, axis), pad_axis(contacts, axis)
        for axis in (0, 1):
            static = pad_axis(static, axis)
        self._padded.update(torque=torque, contacts=contacts, static=static)
        object.__setattr__(self, "_coarse", c)
        object.__setattr__(self, "_any_filled", bool(self.filled.any()))
        # [sign, s, t, p]: whether filled[sign, s:s+4, t:t+4, p:p+4] holds a filled node.
        ends = ((0, 0), (0, 3), (0, 3), (0, 3))
        padded_filled = np.pad(np.asarray(self.filled, dtype=bool), ends)
        window = sliding_window_view(padded_filled, (4, 4, 4), axis=(1, 2, 3))
        object.__setattr__(self, "_filled_window", window.any(axis=(-3, -2, -1)))

    @property
    def node_count(self) -> int:
        """Number of speed x temperature x preload nodes of the torque table (both signs)."""
        return int(self.filled.size)

    def _clamp_notes(
        self, speed: float, temperature: float, preloads: tuple[float, float]
    ) -> list[str]:
        g = self.grid
        notes = []
        if speed > g.speed_max:
            notes.append(
                f"speed {speed / RPM:.0f} rpm above the map's {g.speed_max / RPM:.0f} rpm: "
                "clamped to it"
            )
        if 0.0 < speed < g.speed_min:
            notes.append(
                f"speed {speed / RPM:.3g} rpm below the map's {g.speed_min / RPM:.3g} rpm: "
                "torque and contacts blended linearly to standstill"
            )
        if not g.temperature_min <= temperature <= g.temperature_max:
            notes.append(
                f"temperature {temperature - CELSIUS_ZERO:.1f} C outside the map "
                f"[{g.temperature_min - CELSIUS_ZERO:.0f}, {g.temperature_max - CELSIUS_ZERO:.0f}]"
                " C: clamped"
            )
        for name, preload in zip(NUT_NAMES, preloads, strict=True):
            if not 0.0 <= preload <= g.preload_max:
                notes.append(
                    f"{name} nut equivalent preload {preload:.0f} N outside the map "
                    f"[0, {g.preload_max:.0f}] N: clamped"
                )
        return notes

    def _filled_near(self, sign: int, cells: tuple[int, int, int]) -> bool:
        """Whether the fine stencil of the (speed, temperature, preload) ``cells`` of ``sign``
        uses a filled node (or one next to it)."""
        s, t, p = (max(cell - 1, 0) for cell in cells)
        return bool(self._filled_window[sign, s, t, p])

    def sample(
        self,
        screw_speed: float,
        temperature: float,
        preloads: tuple[float, float],
        contacts: bool = True,
        compiled: bool = True,
    ) -> MapSample:
        """Interpolate both nuts.

        Args:
            screw_speed: signed screw speed [rad/s].
            temperature: temperature [K].
            preloads: equivalent preload of the (master, slave) nut [N],
                :func:`equivalent_preloads`.
            contacts: interpolate the contact states too (False: torque only, about half the
                work; ``MapSample.contacts`` is None).
            compiled: the numba kernels of ``kernels/map_sample.py`` (~10 us); False: the numpy
                reference :meth:`_interpolate_reference` (~100 us), equal to rounding.
        """
        g, c = self.grid, self._coarse
        assert c is not None
        sign = 0 if screw_speed >= 0.0 else 1
        speed = abs(screw_speed)
        notes = self._clamp_notes(speed, temperature, preloads)
        blend = min(speed / g.speed_min, 1.0)  # 1 on the map, -> 0 at standstill
        fine = query_cells(g, speed, temperature, preloads)
        coarse = query_cells(c, speed, temperature, preloads) if contacts else None
        interpolate = self._interpolate_compiled if compiled else self._interpolate_reference
        torque, states = interpolate(sign, fine, coarse, blend)
        if self._any_filled:
            for nut, (preload_cell, _) in enumerate(fine.preloads):
                if self._filled_near(sign, (fine.speed[0], fine.temperature[0], preload_cell)):
                    notes.append(
                        f"{NUT_NAMES[nut]} nut: interpolated near map nodes where the steady "
                        "solver failed (filled from the nearest solved speed or preload)"
                    )
        return MapSample(torque, states, tuple(notes))

    def total_torque(
        self, screw_speeds: FloatArray, temperature: float, preloads: tuple[float, float]
    ) -> FloatArray:
        """Total drag torque of both nuts [N m] at many speeds [rad/s] and one temperature [K]
        and pair of equivalent preloads [N] (numpy, vectorised over the speeds; no notes).

        The same tensor Catmull-Rom of the nut torque as :meth:`sample` (its total is the sum
        of ``sample(...).torque``), for a caller that follows a measured speed trajectory;
        queries beyond the map are clamped to it as there.
        """
        g = self.grid
        speeds = np.asarray(screw_speeds, dtype=np.float64)
        magnitude = np.abs(speeds)
        u = np.log(np.maximum(magnitude, g.speed_min) / g.speed_min) / math.log(
            g.speed_max / g.speed_min
        )
        u = np.clip(u * (g.speed_nodes - 1), 0.0, g.speed_nodes - 1.0)
        cell = np.minimum(u.astype(np.int64), g.speed_nodes - 2)
        ws = _catmull_rom_rows(u - cell)
        t_cell, t_fraction = axis_cell(temperature_node(g, temperature), g.temperature_nodes)
        wt = catmull_rom_weights(t_fraction)
        total = np.zeros(len(speeds))
        sign = (speeds < 0.0).astype(np.int64)
        offsets = np.arange(4)
        for nut, preload in enumerate(preloads):
            p_cell, p_fraction = axis_cell(preload_node(g, preload), g.preload_nodes)
            wp = catmull_rom_weights(p_fraction)
            # (S, T, P) columns of asinh(nut torque) around the temperature and preload cells.
            table = self._padded["torque"][:, :, t_cell : t_cell + 4, p_cell : p_cell + 4, nut, 0]
            plane = np.einsum("abjk,j,k->ab", table, wt, wp)  # (sign, speed node)
            rows = plane[sign[:, None], cell[:, None] + offsets[None, :]]  # (N, 4)
            total += TORQUE_SCALE * np.sinh(np.sum(rows * ws, axis=1))
        blend = np.minimum(magnitude / g.speed_min, 1.0)
        return np.asarray(total * blend)

    def _interpolate_reference(
        self, sign: int, fine: QueryCells, coarse: QueryCells | None, blend: float
    ) -> tuple[FloatArray, FloatArray | None]:
        """(2, 6) torques [N m] and (2, 4, F) contact states, or None without ``coarse``, of
        speed ``sign`` (0: >= 0) at the query's cells on the fine (torque) and coarse
        (contact) grids, with the standstill ``blend`` [-]: the readable numpy reference."""
        torque_table = self._padded["torque"][sign]
        speed, temperature = _position(fine.speed), _position(fine.temperature)
        values = np.empty((NUTS, len(MECHANISMS) + 1))
        if coarse is None:
            stencils: dict[AxisCell, FloatArray] = {}
            for nut, cell in enumerate(fine.preloads):
                if cell not in stencils:  # one stencil when the nuts' loads agree
                    pos = _Positions(speed, temperature, _position(cell))
                    stencils[cell] = _stencil(torque_table, pos)
                values[nut] = stencils[cell][nut]
            return _nut_torques(values, blend), None
        coarse_speed, coarse_temperature = _position(coarse.speed), _position(coarse.temperature)
        rows = np.empty((NUTS, HALF_GROOVES * len(CONTACT_FIELDS)))
        still = np.empty_like(rows)
        solved: dict[tuple[AxisCell, AxisCell], _NutStencils] = {}
        for nut, cells in enumerate(zip(fine.preloads, coarse.preloads, strict=True)):
            if cells not in solved:  # both nuts at once; one stencil when the loads agree
                pos = _Positions(speed, temperature, _position(cells[0]))
                coarse_pos = _Positions(coarse_speed, coarse_temperature, _position(cells[1]))
                solved[cells] = (
                    _stencil(torque_table, pos),
                    _stencil(self._padded["contacts"][sign], coarse_pos),
                    _stencil_2d(self._padded["static"], coarse_pos) if blend < 1.0 else None,
                )
            nut_values, nut_rows, nut_still = solved[cells]
            values[nut], rows[nut] = nut_values[nut], nut_rows[nut]
            if nut_still is not None:
                still[nut] = nut_still[nut]
        torque = _nut_torques(values, blend)
        states = rows.reshape(NUTS, HALF_GROOVES, len(CONTACT_FIELDS))
        states[..., _LOG_FIELDS] = _LOG_SCALE_VALUES * np.sinh(states[..., _LOG_FIELDS])
        if blend < 1.0:
            states = states * blend + still.reshape(states.shape) * (1.0 - blend)
        np.maximum(states, _LOWER_BOUND, out=states)
        return torque, states

    def _interpolate_compiled(
        self, sign: int, fine: QueryCells, coarse: QueryCells | None, blend: float
    ) -> tuple[FloatArray, FloatArray | None]:
        """As :meth:`_interpolate_reference`, by the kernels of ``kernels/map_sample.py``."""
        from ..kernels import map_sample

        cells = np.array([cell for cell, _ in fine.preloads], dtype=np.int64)
        fractions = np.array([fraction for _, fraction in fine.preloads])
        torque = map_sample.nut_torques(
            self._padded["torque"][sign],
            fine.speed,
            fine.temperature,
            cells,
            fractions,
            blend,
            TORQUE_SCALE,
        )
        if coarse is None:
            return torque, None
        cells = np.array([cell for cell, _ in coarse.preloads], dtype=np.int64)
        fractions = np.array([fraction for _, fraction in coarse.preloads])
        states = map_sample.contact_states(
            self._padded["contacts"][sign],
            self._padded["static"],
            coarse.speed,
            coarse.temperature,
            cells,
            fractions,
            blend,
            _LOG_FIELDS,
            _LOG_SCALES_FULL,
            _LOWER_BOUND,
        )
        return torque, states

    # ------------------------------------------------------------------ files

    def save(self, path: str | Path) -> None:
        """Write the map as a compressed ``.npz`` file."""
        np.savez_compressed(
            Path(path),
            format_version=np.array(FORMAT_VERSION),
            grid=self.grid.as_array(),
            torque=np.asarray(self.torque, dtype=np.float32),
            contacts=np.asarray(self.contacts, dtype=np.float32),
            static=np.asarray(self.static, dtype=np.float32),
            filled=self.filled,
            fingerprint=np.array(self.fingerprint),
            orientation=np.array(self.orientation),
            contact_fields=np.array(CONTACT_FIELDS),
            mechanisms=np.array(MECHANISMS),
        )


def load_map(path: str | Path | None = None) -> SteadyMap:
    """Read a map written by :meth:`SteadyMap.save` (default: the committed one).

    Raises:
        MapError: the file is missing, unreadable, of another format version, tabulates other
            quantities or holds inconsistent tables.
    """
    file = Path(path) if path is not None else DEFAULT_MAP_PATH
    try:
        with np.load(file, allow_pickle=False) as data:
            version = int(data["format_version"])
            if version != FORMAT_VERSION:
                raise MapError(f"{file}: format_version = {version}, expected {FORMAT_VERSION}")
            fields_ = tuple(str(x) for x in data["contact_fields"])
            mechanisms = tuple(str(x) for x in data["mechanisms"])
            if fields_ != CONTACT_FIELDS or mechanisms != tuple(MECHANISMS):
                raise MapError(f"{file}: tabulates other quantities than this version reads")
            return SteadyMap(
                grid=MapGrid.from_array(data["grid"]),
                torque=np.asarray(data["torque"]),
                contacts=np.asarray(data["contacts"]),
                static=np.asarray(data["static"]),
                filled=np.asarray(data["filled"], dtype=bool),
                fingerprint=str(data["fingerprint"]),
                orientation=str(data["orientation"]),
            )
    except MapError as err:
        if str(file) in str(err):
            raise
        raise MapError(f"{file}: {err}") from err
    except (OSError, KeyError, ValueError, TypeError, EOFError) as err:
        raise MapError(f"{file}: not a readable steady map ({err})") from err
