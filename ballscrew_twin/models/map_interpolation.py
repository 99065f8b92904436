"""Tensor Catmull-Rom interpolation on the steady map's grid (numpy, the readable reference).

Each axis is a sequence of nodes; a query falls in a cell of each axis (:func:`axis_cell`, in
node units: :func:`speed_node`, :func:`temperature_node`, :func:`preload_node`) and is the
weighted sum of the 4 x 4 x 4 nodes around it (:func:`catmull_rom_weights`; C1). The edge cells
use a linearly extrapolated ghost node: a padded table (:func:`pad_axis`, :func:`stencil`) or,
where the values are transformed between the axes, the ghost's weight folded onto the two
nodes it is extrapolated from (:func:`folded_position`, :func:`torque_stencil`). Along the
preload the torque table takes the same cubic with its slopes limited where the data are steep
or flat (:func:`preload_line`). The compiled twin is ``kernels/map_sample.py``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from .map_grid import TORQUE_SCALE, MapGrid, preload_coordinate, temperature_coordinate

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


def catmull_rom_weights(t: float) -> FloatArray:
    """Weights of the four nodes i-1, i, i+1, i+2 at fraction ``t`` in [0, 1] of cell [i, i+1]."""
    t2, t3 = t * t, t * t * t
    return 0.5 * np.array(
        [-t3 + 2.0 * t2 - t, 3.0 * t3 - 5.0 * t2 + 2.0, -3.0 * t3 + 4.0 * t2 + t, t3 - t2]
    )


def catmull_rom_rows(t: FloatArray) -> FloatArray:
    """(N, 4) weights of :func:`catmull_rom_weights` for each fraction of ``t`` (N,)."""
    t2, t3 = t * t, t * t * t
    rows = np.empty((len(t), 4))
    rows[:, 0] = -t3 + 2.0 * t2 - t
    rows[:, 1] = 3.0 * t3 - 5.0 * t2 + 2.0
    rows[:, 2] = -3.0 * t3 + 4.0 * t2 + t
    rows[:, 3] = t3 - t2
    return 0.5 * rows


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
    """The temperature [K] in node units of ``grid``'s temperature axis (uniform in
    :func:`~.map_grid.temperature_coordinate`) [-]; clamped to the axis first, as
    :func:`axis_cell` clamps it (the coordinate has a pole at 138 K)."""
    clamped = min(max(temperature, grid.temperature_min), grid.temperature_max)
    low = temperature_coordinate(grid.temperature_min)
    u = (temperature_coordinate(clamped) - low) / (
        temperature_coordinate(grid.temperature_max) - low
    )
    return u * (grid.temperature_nodes - 1)


def preload_node(grid: MapGrid, preload: float) -> float:
    """The equivalent preload [N] in node units of ``grid``'s preload axis (uniform in
    :func:`~.map_grid.preload_coordinate`) [-]."""
    u = math.copysign(preload_coordinate(abs(preload)), preload) / preload_coordinate(
        grid.preload_max
    )
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


def stencil_position(cell: AxisCell) -> AxisPosition:
    """The Catmull-Rom stencil of ``cell``."""
    return AxisPosition(start=cell[0], weights=catmull_rom_weights(cell[1]))


@dataclass(frozen=True)
class Positions:
    """Stencils of one query on the three axes."""

    speed: AxisPosition
    temperature: AxisPosition
    preload: AxisPosition


def folded_rows(cells: IntArray, fractions: FloatArray, count: int) -> tuple[IntArray, FloatArray]:
    """The Catmull-Rom stencils of many cells on an unpadded axis of ``count`` >= 4 nodes: the
    first node of each (N,) and the (N, 4) weights of that node and the next three.

    In an edge cell the ghost node (linearly extrapolated, ``2 * first - second``) is not
    stored; its weight goes to the two nodes it is made of, so ``start`` stays inside the axis
    (a node of the four beyond the stencil gets weight 0).
    """
    folded = catmull_rom_rows(fractions)
    first, last = cells == 0, cells == count - 2
    if first.any():
        a = folded[first].T  # the weights of nodes i-1, i, i+1, i+2 of those cells
        # Ghost before node 0 (weight a[0]): nodes 0, 1, 2, 3.
        folded[first] = np.column_stack([a[1] + 2.0 * a[0], a[2] - a[0], a[3], np.zeros_like(a[0])])
    if last.any():
        b = folded[last].T
        # Ghost after node count-1 (weight b[3]): nodes count-4 .. count-1.
        folded[last] = np.column_stack([np.zeros_like(b[0]), b[0], b[1] - b[3], b[2] + 2.0 * b[3]])
    return np.clip(cells - 1, 0, count - 4), folded


def folded_position(cell: AxisCell, count: int) -> AxisPosition:
    """The stencil of one ``cell`` as :func:`folded_rows` makes it, in the same arithmetic on
    plain floats (the same weights to the bit, without the cost of (1,) arrays: the map's
    drag along a trajectory takes three of these per call)."""
    index, t = cell
    t2, t3 = t * t, t * t * t
    w = (
        0.5 * (-t3 + 2.0 * t2 - t),
        0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
        0.5 * (-3.0 * t3 + 4.0 * t2 + t),
        0.5 * (t3 - t2),
    )
    if index == 0:
        w = (w[1] + 2.0 * w[0], w[2] - w[0], w[3], 0.0)
    elif index == count - 2:
        w = (0.0, w[0], w[1] - w[3], w[2] + 2.0 * w[3])
    return AxisPosition(min(max(index - 1, 0), count - 4), np.array(w))


#: Largest ratio of a node's slope to the smaller of its two secants along the preload where
#: the data are monotone (Fritsch and Carlson 1980; Hyman 1983: at <= 3 the cubic between
#: monotone nodes is monotone).
SLOPE_LIMIT = 3.0


def preload_line(block: FloatArray, axis: int, cell: AxisCell) -> FloatArray:
    """Shape-preserving cubic Hermite along ``axis`` of ``block`` (the whole preload axis) in
    ``cell``, the axis removed.

    Catmull-Rom slopes (the central differences of the nodes beside each end of the cell; an
    edge cell's ghost node is linearly extrapolated, as :func:`folded_position`'s) limited as
    Hyman's filter does: where the two secants at a node have the same sign, to SLOPE_LIMIT
    times the smaller one; where they differ or one is zero, to zero. Equal to
    :func:`folded_position`'s weights wherever no limit binds. Why: a nut's torque along the
    preload can fall steeply over one cell and be flat beside it (the master nut of
    ``config/screw_32x10.yaml`` at 15-23 N), and a node the solver could not solve is filled
    from a neighbour (a flat step); the plain cubic overshoots there, 3.6 % at 0.3 rpm / 47.6 C
    / 28.7 N and a torque of the wrong sign at 20 N (issue 14).
    """
    index, t = cell
    count = block.shape[axis]
    low, high = np.take(block, index, axis=axis), np.take(block, index + 1, axis=axis)
    before = np.take(block, index - 1, axis=axis) if index > 0 else 2.0 * low - high
    after = np.take(block, index + 2, axis=axis) if index + 2 < count else 2.0 * high - low
    slope_low = _limited_slope(low - before, high - low)
    slope_high = _limited_slope(high - low, after - high)
    t2, t3 = t * t, t * t * t
    return np.asarray(
        (2.0 * t3 - 3.0 * t2 + 1.0) * low
        + (t3 - 2.0 * t2 + t) * slope_low
        + (3.0 * t2 - 2.0 * t3) * high
        + (t3 - t2) * slope_high
    )


def _limited_slope(left: FloatArray, right: FloatArray) -> FloatArray:
    """A node's Catmull-Rom slope (left + right) / 2 from the secants on either side of it,
    limited as :func:`preload_line` says."""
    slope = 0.5 * (left + right)
    bound = SLOPE_LIMIT * np.minimum(np.abs(left), np.abs(right))
    monotone = left * right > 0.0
    return np.where(monotone, np.clip(slope, -bound, bound), 0.0)


def torque_stencil(
    table: FloatArray, speed: AxisPosition, temperature: AxisPosition, preload: AxisCell
) -> FloatArray:
    """Interpolate an unpadded (S, T, P, nut, 1 + M) torque table (the nut torque [N m], then
    its M mechanisms) at the :func:`folded_position` stencils of ``speed`` and ``temperature``
    and the ``preload`` cell: (nut, 1 + M), the nut torque as
    asinh(torque / :data:`~.map_grid.TORQUE_SCALE`).

    The preload axis first, on the torques as they are (:func:`preload_line`); then speed and
    temperature on asinh(nut torque / scale) (the mechanisms as they are). Along the preload a
    light nut's torque can pass near zero or change sign (docs/model.md 11), where its
    logarithm has no cubic to follow; along speed and temperature it follows power laws of the
    film and the viscosity, which the logarithm makes nearly linear.
    """
    s, t = speed.start, temperature.start
    lines = preload_line(table[s : s + 4, t : t + 4], 2, preload)
    lines[..., 0] = np.arcsinh(lines[..., 0] / TORQUE_SCALE)
    return np.asarray(np.einsum("ijnv,i,j->nv", lines, speed.weights, temperature.weights))


def stencil(table: FloatArray, pos: Positions) -> FloatArray:
    """Interpolate a padded (S, T, P, nut, V) table at ``pos``: (nut, V)."""
    s, t, p = pos.speed.start, pos.temperature.start, pos.preload.start
    block = table[s : s + 4, t : t + 4, p : p + 4]
    w = np.outer(np.outer(pos.speed.weights, pos.temperature.weights), pos.preload.weights)
    return np.asarray(w.reshape(64) @ block.reshape(64, -1)).reshape(table.shape[3:])


def stencil_2d(table: FloatArray, pos: Positions) -> FloatArray:
    """Interpolate a padded (T, P, nut, V) table at ``pos`` (speed unused): (nut, V)."""
    t, p = pos.temperature.start, pos.preload.start
    w = np.outer(pos.temperature.weights, pos.preload.weights)
    block = table[t : t + 4, p : p + 4]
    return np.asarray(w.reshape(16) @ block.reshape(16, -1)).reshape(table.shape[2:])
