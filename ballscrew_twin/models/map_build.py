"""Building the steady map: every node solved by the symmetric steady model, in worker processes.

Each task is one line of speeds (one sign, temperature and preload node), solved from standstill
upwards, each speed warm-started from the last (:func:`build_map`). Nodes where the solver fails,
even cold, are filled from their nearest solved neighbour and flagged (:func:`fill_failed`); a
standstill state the solver misses takes the nearest solved preload's
(:func:`fill_failed_static`).
``ballscrew-twin map build`` runs it; the twin node builds a new screw's table in the background.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..errors import MapError, SolverError
from ..params import TwinConfig, config_fingerprint
from .base import MECHANISMS, OperatingPoint
from .map_grid import CONTACT_FIELDS, HALF_GROOVES, NUTS, MapGrid
from .steady import SteadyStateModel
from .steady_map import SteadyMap

FloatArray = NDArray[np.float64]

#: Steady-solver tolerance of the map's nodes (scaled residual) [-]: the steady model's default,
#: so that each node is the model's own answer. Where the model has several states the one its
#: start-up path reaches can depend on the tolerance: at 1e-9 (the tolerance before) the paper
#: screw's node -15 C / 86 N / 3686 rpm was 36.0 mN m, at 1e-10 to 1e-12 30.5 mN m.
MAP_TOLERANCE = 1e-10
#: Niceness of the worker processes of a build (the real-time ticks of a node go first).
WORKER_NICENESS = 10


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
    static: FloatArray  # (2, 4, F), NaN where the standstill solve failed


_WORKER: dict[str, SteadyStateModel | MapGrid] = {}


def _pool_worker_init(config: TwinConfig, grid: MapGrid, niceness: int, follow_folds: bool) -> None:
    """Initialiser of a worker process (never of the calling process: its handler stays)."""
    # Ctrl-C reaches the whole process group: the parent alone stops the build (it terminates
    # the pool), so a worker does not print a KeyboardInterrupt traceback of its own.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if niceness:
        os.nice(niceness)
    _worker_init(config, grid, follow_folds)


def _worker_init(config: TwinConfig, grid: MapGrid, follow_folds: bool) -> None:
    _WORKER["model"] = SteadyStateModel(
        config, mode="symmetric", tolerance=MAP_TOLERANCE, follow_folds=follow_folds
    )
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
    try:
        static = node_values(model, static_op).contacts
    except SolverError:
        # Measured: the 32 mm screw's standstill at 8.0-9.0 N, where the preload about
        # equals the nut's weight (8.3 N), at every temperature.
        model.forget_warm_start()
        static = np.full((NUTS, HALF_GROOVES, len(CONTACT_FIELDS)), np.nan)
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


def fill_failed(table: FloatArray, failed: NDArray[np.bool_]) -> None:
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


def fill_failed_static(static: FloatArray) -> None:
    """Replace the NaN rows of a (T, P, ...) standstill table (a failed standstill solve) by
    the nearest solved preload's at the same temperature (ties go down), in place.

    Raises:
        MapError: no preload solved at some temperature.
    """
    failed = np.asarray(np.isnan(static).any(axis=tuple(range(2, static.ndim))))
    count = failed.shape[1]
    for t, p in zip(*np.nonzero(failed), strict=True):
        for q in sorted(range(count), key=lambda k: abs(k - p)):
            if not failed[t, q]:
                static[t, p] = static[t, q]
                break
        else:
            raise MapError(f"steady map: the standstill solve failed at every preload of {t = }")


#: Progress callback of :func:`build_map`: (lines done, lines in all, seconds elapsed).
Progress = Callable[[int, int, float], None]


def build_map(
    config: TwinConfig,
    grid: MapGrid | None = None,
    workers: int = 2,
    on_progress: Progress | None = None,
    niceness: int = 0,
    follow_folds: bool = True,
) -> SteadyMap:
    """Solve every node of ``grid`` with the symmetric steady model.

    Args:
        config: parameter set.
        grid: nodes (default :class:`MapGrid()`).
        workers: worker processes (1: solve in this process).
        on_progress: called after each line of nodes (see :data:`Progress`; ``map build``
            draws its progress bar with it).
        niceness: added to the worker processes' niceness (with ``workers`` > 1). On Linux it
            is added to the calling thread's niceness before the workers start, so that they
            start niced (their imports included; a dedicated build thread stays niced);
            elsewhere each worker lowers its own priority once started.
        follow_folds: solve with the fold rule (``SteadyStateModel(follow_folds=)``; False
            for the preview table, a cheaper stopgap).
    """
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
        for done, res in enumerate(results, start=1):
            where = (res.line.sign, slice(None), res.line.temperature, res.line.preload)
            torque[where], contacts[where], failed[where] = res.torque, res.contacts, res.failed
            static[res.line.temperature, res.line.preload] = res.static
            if on_progress is not None:
                on_progress(done, len(lines), time.monotonic() - start)

    if workers <= 1:
        _worker_init(config, grid, follow_folds)
        store(_solve_line(line) for line in lines)
    else:
        context = multiprocessing.get_context("spawn")
        inherited = niceness > 0 and sys.platform == "linux"
        if inherited:  # Linux: a thread's niceness is its own, and a process it starts inherits it
            thread = threading.get_native_id()
            os.setpriority(
                os.PRIO_PROCESS, thread, os.getpriority(os.PRIO_PROCESS, thread) + niceness
            )
        init = (config, grid, 0 if inherited else niceness, follow_folds)
        with context.Pool(workers, initializer=_pool_worker_init, initargs=init) as pool:
            store(pool.imap_unordered(_solve_line, lines, chunksize=2))
    if failed.any():
        fill_failed(torque, failed)
        fill_failed(contacts, failed)
    fill_failed_static(static)
    return SteadyMap(
        grid=grid,
        torque=torque.astype(np.float32),
        contacts=contacts[:, ::2, ::2, ::2].astype(np.float32),
        static=static[::2, ::2].astype(np.float32),
        filled=failed,
        fingerprint=config_fingerprint(config),
        orientation=config.screw.orientation,
    )
