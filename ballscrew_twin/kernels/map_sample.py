"""Compiled interpolation of the real-time map (numba).

The compiled twin of the numeric part of :meth:`ballscrew_twin.models.steady_map.SteadyMap.sample`
(the readable reference; read it and the module docstring of ``steady_map`` first): tensor
Catmull-Rom stencils over 4 x 4 x 4 nodes of the tables (the torque table along the preload
first, its slopes limited, then along speed and temperature on asinh of the nut torque; the
contact tables padded),
the asinh back-transform of the nut torque and of the power-law contact fields, the share-out
of the torque over the mechanisms, the blend to standstill and the lower bounds. Where the
query falls on each axis (cell and fraction), the clamping and the notes stay in Python and are
shared with the reference, so only the arithmetic is duplicated (the torque table's stencils,
``_folded``, follow ``map_interpolation.folded_rows``, and ``_preload_hermite`` follows
``map_interpolation.preload_line``); test/kernels/test_map_sample_kernel.py
checks the two agree to rounding (the reference sums the 64 stencil terms in BLAS order, the
kernel in loop order).

Why: the reference takes ~110 us per new command (torque only) and ~160 us with the contact
states, nearly all of it the overhead of small numpy calls; a bench that streams its speed at
1 kHz gives the node a new command on every tick (docs/benchmarks.md, "Real-time node").
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]


@njit(cache=True, inline="always")
def _catmull_rom(t: float, out: FloatArray) -> None:
    """Weights of the nodes i-1, i, i+1, i+2 at fraction ``t`` of cell [i, i+1] into ``out``
    (as ``map_interpolation.catmull_rom_weights``)."""
    t2 = t * t
    t3 = t * t * t
    out[0] = 0.5 * (-t3 + 2.0 * t2 - t)
    out[1] = 0.5 * (3.0 * t3 - 5.0 * t2 + 2.0)
    out[2] = 0.5 * (-3.0 * t3 + 4.0 * t2 + t)
    out[3] = 0.5 * (t3 - t2)


@njit(cache=True)
def _stencil_3d(
    table: FloatArray,
    cells: tuple[int, int, int],
    weights: tuple[FloatArray, FloatArray, FloatArray],
    nut: int,
    out: FloatArray,
) -> None:
    """``out[v]`` = sum over the 4 x 4 x 4 stencil at ``cells`` of the padded (S, T, P, nut, V)
    ``table``, row ``nut``, weighted by the product of the axes' ``weights``."""
    s, t, p = cells
    ws, wt, wp = weights
    out[:] = 0.0
    for i in range(4):
        for j in range(4):
            wij = ws[i] * wt[j]
            for k in range(4):
                w = wij * wp[k]
                row = table[s + i, t + j, p + k, nut]
                for v in range(out.size):
                    out[v] += w * row[v]


@njit(cache=True)
def _stencil_2d(
    table: FloatArray,
    cells: tuple[int, int],
    weights: tuple[FloatArray, FloatArray],
    nut: int,
    out: FloatArray,
) -> None:
    """As :func:`_stencil_3d` on a padded (T, P, nut, V) table (no speed axis)."""
    t, p = cells
    wt, wp = weights
    out[:] = 0.0
    for j in range(4):
        for k in range(4):
            w = wt[j] * wp[k]
            row = table[t + j, p + k, nut]
            for v in range(out.size):
                out[v] += w * row[v]


@njit(cache=True)
def _folded(cell: int, t: float, count: int, out: FloatArray) -> int:
    """Weights of the stencil of ``cell`` at fraction ``t`` on an unpadded axis of ``count``
    nodes into ``out``; returns its first node (as ``map_interpolation.folded_rows``: an edge
    cell's ghost node weight folded onto the two nodes it is extrapolated from)."""
    _catmull_rom(t, out)
    if cell == 0:
        ghost = out[0]
        out[0] = out[1] + 2.0 * ghost
        out[1] = out[2] - ghost
        out[2] = out[3]
        out[3] = 0.0
        return 0
    if cell == count - 2:
        ghost = out[3]
        out[3] = out[2] + 2.0 * ghost
        out[2] = out[1] - ghost
        out[1] = out[0]
        out[0] = 0.0
        return count - 4
    return cell - 1


@njit(cache=True, inline="always")
def _hermite_basis(t: float, out: FloatArray) -> None:
    """Cubic Hermite basis at fraction ``t`` of a unit cell into ``out``: the weights of the
    value and the slope at its low end, then of the value and the slope at its high end."""
    t2 = t * t
    t3 = t * t * t
    out[0] = 2.0 * t3 - 3.0 * t2 + 1.0
    out[1] = t3 - 2.0 * t2 + t
    out[2] = 3.0 * t2 - 2.0 * t3
    out[3] = t3 - t2


@njit(cache=True, inline="always")
def _limited_slope(left: float, right: float, limit: float) -> float:
    """A node's slope from its two secants (as ``map_interpolation._limited_slope``)."""
    if left * right <= 0.0:
        return 0.0
    slope = 0.5 * (left + right)
    bound = limit * min(abs(left), abs(right))
    return min(max(slope, -bound), bound)


@njit(cache=True)
def _preload_hermite(line: FloatArray, cell: int, hermite: FloatArray, limit: float) -> float:
    """One ``line``'s value (the whole preload axis) in ``cell``, with the ``hermite`` basis of
    the cell's fraction (as ``map_interpolation.preload_line``)."""
    y1 = line[cell]
    y2 = line[cell + 1]
    y0 = line[cell - 1] if cell > 0 else 2.0 * y1 - y2
    y3 = line[cell + 2] if cell + 2 < line.size else 2.0 * y2 - y1
    low = _limited_slope(y1 - y0, y2 - y1, limit)
    high = _limited_slope(y2 - y1, y3 - y2, limit)
    return hermite[0] * y1 + hermite[1] * low + hermite[2] * y2 + hermite[3] * high


@njit(cache=True)
def nut_torques(
    table: FloatArray,
    speed: tuple[int, float],
    temperature: tuple[int, float],
    preload_cells: IntArray,
    preload_fractions: FloatArray,
    blend: float,
    torque_scale: float,
    slope_limit: float,
) -> FloatArray:
    """(2, M) drag torque per nut and mechanism [N m] from the unpadded (S, T, P, 2, 1 + M)
    torque table of one speed sign (the nut torque, then the M mechanisms): the preload axis
    first (the limited Hermite cubic of ``map_interpolation.preload_line``), then speed and
    temperature on asinh(nut torque / ``torque_scale``) (as
    ``map_interpolation.torque_stencil``).

    Args:
        speed, temperature: (cell, fraction) of the query on those axes.
        preload_cells, preload_fractions: (2,) cell and fraction of each nut's equivalent
            preload.
        blend: standstill factor, 1 on the map, -> 0 at standstill [-].
        torque_scale: ``map_grid.TORQUE_SCALE`` [N m].
        slope_limit: ``map_interpolation.SLOPE_LIMIT`` [-].
    """
    width = table.shape[4]
    ws = np.empty(4)
    wt = np.empty(4)
    s = _folded(speed[0], speed[1], table.shape[0], ws)
    t = _folded(temperature[0], temperature[1], table.shape[1], wt)
    hermite = np.empty(4)
    line = np.empty(width)
    values = np.empty(width)
    out = np.empty((2, width - 1))
    for nut in range(2):
        cell = preload_cells[nut]
        _hermite_basis(preload_fractions[nut], hermite)
        values[:] = 0.0
        for i in range(4):
            for j in range(4):
                nodes = table[s + i, t + j, :, nut]
                for v in range(width):
                    line[v] = _preload_hermite(nodes[:, v], cell, hermite, slope_limit)
                line[0] = math.asinh(line[0] / torque_scale)
                wij = ws[i] * wt[j]
                for v in range(width):
                    values[v] += wij * line[v]
        total = torque_scale * math.sinh(values[0])
        mechanism_sum = 0.0
        size = 0.0
        for m in range(1, width):
            mechanism_sum += values[m]
            size += abs(values[m])
        rest = total - mechanism_sum
        for m in range(1, width):
            share = abs(values[m]) / size if size > 0.0 else 0.0
            out[nut, m - 1] = (values[m] + rest * share) * blend
    return out


@njit(cache=True)
def contact_states(
    table: FloatArray,
    static: FloatArray,
    speed: tuple[int, float],
    temperature: tuple[int, float],
    preload_cells: IntArray,
    preload_fractions: FloatArray,
    blend: float,
    log_fields: BoolArray,
    log_scales: FloatArray,
    lower_bounds: FloatArray,
) -> FloatArray:
    """(2, H, F) contact quantities per nut and half groove (SI) from the padded coarse
    (S', T', P', 2, H * F) table of one speed sign and the padded (T', P', 2, H * F) standstill
    table.

    Args:
        speed, temperature, preload_cells, preload_fractions, blend: as :func:`nut_torques`,
            on the coarse grid.
        log_fields: (F,) fields tabulated as asinh(value / scale).
        log_scales: (F,) their scales (any value where ``log_fields`` is False).
        lower_bounds: (F,) lower bound of each field after interpolation (-inf: none).
    """
    fields = log_fields.size
    width = table.shape[4]
    grooves = width // fields
    ws = np.empty(4)
    wt = np.empty(4)
    wp = np.empty(4)
    _catmull_rom(speed[1], ws)
    _catmull_rom(temperature[1], wt)
    row = np.empty(width)
    still = np.zeros(width)
    out = np.empty((2, grooves, fields))
    for nut in range(2):
        _catmull_rom(preload_fractions[nut], wp)
        cells = (speed[0], temperature[0], preload_cells[nut])
        _stencil_3d(table, cells, (ws, wt, wp), nut, row)
        if blend < 1.0:
            _stencil_2d(static, (temperature[0], preload_cells[nut]), (wt, wp), nut, still)
        for h in range(grooves):
            for f in range(fields):
                x = row[h * fields + f]
                if log_fields[f]:
                    x = log_scales[f] * math.sinh(x)
                if blend < 1.0:
                    x = x * blend + still[h * fields + f] * (1.0 - blend)
                out[nut, h, f] = max(x, lower_bounds[f])
    return out
