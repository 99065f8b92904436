"""Compiled interpolation of the real-time map (numba).

The compiled twin of the numeric part of :meth:`ballscrew_twin.models.steady_map.SteadyMap.sample`
(the readable reference; read it and the module docstring of ``steady_map`` first): tensor
Catmull-Rom stencils over 4 x 4 x 4 nodes of the padded tables, the asinh back-transform of the
nut torque and of the power-law contact fields, the share-out of the torque over the mechanisms,
the blend to standstill and the lower bounds. Where the query falls on each axis (cell and
fraction), the clamping and the notes stay in Python and are shared with the reference, so only
the arithmetic is duplicated; test/kernels/test_map_sample_kernel.py checks the two agree to
rounding (the reference sums the 64 stencil terms in BLAS order, the kernel in loop order).

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
def nut_torques(
    table: FloatArray,
    speed: tuple[int, float],
    temperature: tuple[int, float],
    preload_cells: IntArray,
    preload_fractions: FloatArray,
    blend: float,
    torque_scale: float,
) -> FloatArray:
    """(2, M) drag torque per nut and mechanism [N m] from the padded (S, T, P, 2, 1 + M) torque
    table of one speed sign (asinh(nut torque / ``torque_scale``), then the M mechanisms).

    Args:
        speed, temperature: (cell, fraction) of the query on those axes.
        preload_cells, preload_fractions: (2,) cell and fraction of each nut's equivalent
            preload.
        blend: standstill factor, 1 on the map, -> 0 at standstill [-].
        torque_scale: ``map_grid.TORQUE_SCALE`` [N m].
    """
    width = table.shape[4]
    ws = np.empty(4)
    wt = np.empty(4)
    wp = np.empty(4)
    _catmull_rom(speed[1], ws)
    _catmull_rom(temperature[1], wt)
    values = np.empty(width)
    out = np.empty((2, width - 1))
    for nut in range(2):
        _catmull_rom(preload_fractions[nut], wp)
        cells = (speed[0], temperature[0], preload_cells[nut])
        _stencil_3d(table, cells, (ws, wt, wp), nut, values)
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
