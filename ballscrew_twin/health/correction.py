"""The commissioned unit's residual surface: what the adjusted twin still misses, over speed and
temperature.

After the parametric fit of :mod:`.commission` (gain, bias, preload scale, temperature shift,
inertia, a two-term speed shape), a unit's drag still departs from the twin by a few percent in
a pattern that is smooth in speed and temperature: its own viscosity, mu_dry and Eyring stress
bend the drag-speed curve in ways two shape coefficients cannot follow (training units of
``bench detection``: block means of a healthy run 3-4 % off at 3-30 rad/s and 34 C, systematic,
with 0.3-1.4 % scatter). The surface c(x, T) with x = log10(|w| / 30 rad/s) is learnt from the
relative block residuals of the healthy recording, as values at the nodes of a tensor grid with
bilinear interpolation (a penalised spline of degree 1), minimising

    sum_j (r_j - sum_k A_jk c_k)^2 + lambda_x |D_x c|^2 + lambda_T |D_T c|^2 + lambda_0 |c|^2,

r_j the relative residual of block j, A_jk the block's drag-weighted mean of the basis function
of node k over its speed samples, D first differences along each axis: where the recording has
no data the surface continues flat from the nearest data and relaxes to zero over a few nodes
(sqrt(lambda / lambda_0)). The monitor multiplies the twin's drag by 1 + c (queries beyond the
grid are clamped to its edge). The support of each node (how many blocks lie nearer to it than
to any other node, :func:`nearest_nodes`) says where the surface was learnt; the monitor widens
its error by the share of a query's value that comes from thin nodes
(:meth:`ResidualSurface.unlearnt_share`).

Support counts the nearest node, not the basis weight: a node whose cell holds data on its far
side only is not taught by it. Its value there is the slope of the near data carried across the
cell. Unit 22011 of ``bench detection`` (round 23 of issue 13, commissioned on its cold start
and a service run): thousands of service blocks at 18-21 C made the 15 C node count as learnt
through its basis weights, its value was carried to a later run at 12.9 C, 4.4-4.7 % off the
unit, and the CUSUM alarmed.

All quantities SI: rad/s, K; c and r relative [-].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..errors import ConfigError
from ..params import check_number, positive

FloatArray = NDArray[np.float64]

#: Speed about which x = log10(|w| / SPEED_REFERENCE) is taken [rad/s].
SPEED_REFERENCE = 30.0
#: Grid of the surface: x nodes (log10 of |w| / 30 rad/s, 0.3 to 530 rad/s) [-] and
#: temperature nodes (-40 to 100 C) [K].
LOG_SPEED_NODES = tuple(float(v) for v in np.arange(-2.0, 1.2501, 0.25))
TEMPERATURE_NODES = tuple(float(v) for v in np.arange(233.15, 373.1501, 5.0))
_X = np.array(LOG_SPEED_NODES)
_T = np.array(TEMPERATURE_NODES)
#: Penalty weights of first differences along x and T, and of the values [-] (relative to one
#: block's squared relative residual).
SMOOTH_SPEED = 2.0
SMOOTH_TEMPERATURE = 2.0
SHRINK = 0.05
#: Support [blocks] from which the surface counts as learnt at a query; below, the monitor's
#: error rises towards the baseline's ``unseen_error``.
MIN_SUPPORT = 10.0


def _axis_weights(nodes: FloatArray, values: FloatArray) -> tuple[NDArray[np.int64], FloatArray]:
    """Lower node index and weight of the upper node of linear interpolation, clamped."""
    clipped = np.clip(values, nodes[0], nodes[-1])
    low = np.clip(np.searchsorted(nodes, clipped, side="right") - 1, 0, len(nodes) - 2)
    fraction = (clipped - nodes[low]) / (nodes[low + 1] - nodes[low])
    return low.astype(np.int64), np.asarray(fraction, dtype=np.float64)


def log_speed(speed: FloatArray) -> FloatArray:
    """x = log10(|w| / 30 rad/s) [-] of ``speed`` [rad/s] (|w| floored at 1e-6 rad/s)."""
    return np.asarray(np.log10(np.maximum(np.abs(speed), 1e-6) / SPEED_REFERENCE))


def basis(speed: FloatArray, temperature: FloatArray) -> FloatArray:
    """Bilinear basis functions of every node at each (speed [rad/s], temperature [K]) pair:
    an array (samples, nodes), rows summing to one (node k = i_x * len(T nodes) + i_T)."""
    ix, fx = _axis_weights(_X, log_speed(np.asarray(speed, dtype=np.float64)))
    it, ft = _axis_weights(_T, np.asarray(temperature, dtype=np.float64))
    count = len(_T)
    out = np.zeros((len(ix), len(_X) * count))
    rows = np.arange(len(ix))
    for dx, wx in ((0, 1.0 - fx), (1, fx)):
        for dt, wt in ((0, 1.0 - ft), (1, ft)):
            np.add.at(out, (rows, (ix + dx) * count + it + dt), wx * wt)
    return out


def nearest_nodes(speed: FloatArray, temperature: FloatArray) -> FloatArray:
    """Each (speed [rad/s], temperature [K]) pair's nearest node (in x and in T, clamped to the
    grid) as indicator rows (samples, nodes) [-], in the node order of :func:`basis`."""
    ix, fx = _axis_weights(_X, log_speed(np.asarray(speed, dtype=np.float64)))
    it, ft = _axis_weights(_T, np.asarray(temperature, dtype=np.float64))
    node = (ix + (fx >= 0.5)) * len(_T) + it + (ft >= 0.5)
    out = np.zeros((len(ix), len(_X) * len(_T)))
    out[np.arange(len(ix)), node] = 1.0
    return out


def _differences(size_x: int, size_t: int) -> tuple[FloatArray, FloatArray]:
    """First-difference operators along x and along T of the node vector."""
    n = size_x * size_t
    index = np.arange(n).reshape(size_x, size_t)
    along_x = np.zeros(((size_x - 1) * size_t, n))
    for row, (a, b) in enumerate(zip(index[:-1].ravel(), index[1:].ravel(), strict=True)):
        along_x[row, a], along_x[row, b] = -1.0, 1.0
    along_t = np.zeros((size_x * (size_t - 1), n))
    for row, (a, b) in enumerate(zip(index[:, :-1].ravel(), index[:, 1:].ravel(), strict=True)):
        along_t[row, a], along_t[row, b] = -1.0, 1.0
    return along_x, along_t


@dataclass(frozen=True, eq=False)
class ResidualSurface:
    """c(x, T) on the grid of :data:`LOG_SPEED_NODES` x :data:`TEMPERATURE_NODES`.

    Attributes:
        values: c at the nodes, shape (x nodes, T nodes) [-].
        support: how many of the fitted blocks lie nearest to each node [blocks] (a
            commissioned baseline stores the support both folds of its cross-validation
            gave, :func:`~ballscrew_twin.health.commission.validated_support`).
    """

    values: FloatArray
    support: FloatArray

    def __post_init__(self) -> None:
        shape = (len(LOG_SPEED_NODES), len(TEMPERATURE_NODES))
        for name in ("values", "support"):
            array = np.asarray(getattr(self, name), dtype=np.float64)
            if array.shape != shape:
                raise ConfigError(f"residual surface: {name} has shape {array.shape}, not {shape}")
            if not np.all(np.isfinite(array)):
                raise ConfigError(f"residual surface: {name} is not finite")
        if np.any(np.asarray(self.support) < 0.0):
            raise ConfigError("residual surface: support must be >= 0")
        if np.any(np.abs(np.asarray(self.values)) >= 1.0):
            raise ConfigError("residual surface: |c| must be < 1 (a correction, not a new model)")

    def __eq__(self, other: object) -> bool:
        """Equal node values and support."""
        if not isinstance(other, ResidualSurface):
            return NotImplemented
        same = np.array_equal(self.values, other.values)
        return bool(same and np.array_equal(self.support, other.support))

    __hash__ = None  # type: ignore[assignment]

    def at(self, speed: FloatArray, temperature: float) -> FloatArray:
        """c [-] at each ``speed`` [rad/s] and one ``temperature`` [K] (bilinear, the same as
        :func:`basis` times the node values, without forming the basis)."""
        return _bilinear(self.values, np.asarray(speed, dtype=np.float64), temperature)

    def support_at(self, speed: float, temperature: float) -> float:
        """Interpolated support [blocks] at one ``speed`` [rad/s] and ``temperature`` [K]."""
        return float(_bilinear(self.support, np.array([speed], dtype=np.float64), temperature)[0])

    def unlearnt_share(self, speed: float, temperature: float) -> float:
        """How much of c at one ``speed`` [rad/s] and ``temperature`` [K] comes from nodes the
        recording did not teach [-]: the bilinear weights of the nodes, each times its thinness
        max(1 - support / MIN_SUPPORT, 0). 0 where every node interpolated from was learnt, 1
        where none was. Not the thinness of the interpolated support: a query 80 % of the way
        from a node with 90 blocks to one with none has an interpolated support of 18 blocks,
        "learnt", while 80 % of its value is the surface's flat continuation (unit 5022 of
        ``bench detection`` round 6: a commissioning whose cold part ran at 41 rad/s only, a
        later run 7.9 % above the surface at 85 rad/s and 1.3 C, a false alarm)."""
        return float(_bilinear(self.thinness, np.array([speed], dtype=np.float64), temperature)[0])

    @property
    def thinness(self) -> FloatArray:
        """Each node's thinness max(1 - support / MIN_SUPPORT, 0) [-]: 0 where the recording
        taught the node, 1 where it did not touch it (a block's unlearnt share is its row of
        :func:`basis` times these)."""
        return np.maximum(1.0 - np.asarray(self.support) / MIN_SUPPORT, 0.0)


def _bilinear(grid: FloatArray, speed: FloatArray, temperature: float) -> FloatArray:
    """Bilinear interpolation of node ``grid`` (x nodes, T nodes) at each ``speed`` [rad/s]
    and one ``temperature`` [K], clamped to the grid."""
    ix, fx = _axis_weights(_X, log_speed(speed))
    t = min(max(temperature, _T[0]), _T[-1])
    j = min(int((t - _T[0]) // (_T[1] - _T[0])), len(_T) - 2)
    g = (t - _T[j]) / (_T[j + 1] - _T[j])
    low = grid[ix, j] * (1.0 - g) + grid[ix, j + 1] * g
    high = grid[ix + 1, j] * (1.0 - g) + grid[ix + 1, j + 1] * g
    return np.asarray(low * (1.0 - fx) + high * fx)


def fit_surface(
    design: FloatArray,
    residual: FloatArray,
    nearness: FloatArray,
    weight: FloatArray | None = None,
) -> ResidualSurface:
    """The penalised least-squares surface (see the module docstring).

    Args:
        design: A, (blocks, nodes): each block's drag-weighted mean basis (rows of
            :func:`basis` averaged over the block's samples with the drag as weight).
        residual: r, each block's relative residual [-].
        nearness: (blocks, nodes), each block's share of samples nearest to each node (rows
            of :func:`nearest_nodes` averaged the same way) [-]; their sum is the support.
        weight: per-block weight [-] (default one; robust reweighting passes smaller ones).
    """
    a = np.asarray(design, dtype=np.float64)
    r = np.asarray(residual, dtype=np.float64)
    near = np.asarray(nearness, dtype=np.float64)
    if a.ndim != 2 or a.shape[0] != len(r) or not np.all(np.isfinite(r)) or near.shape != a.shape:
        raise ConfigError(
            "residual surface: design, nearness and residuals disagree or are not finite"
        )
    w = np.ones(len(r)) if weight is None else np.asarray(weight, dtype=np.float64)
    size_x, size_t = len(LOG_SPEED_NODES), len(TEMPERATURE_NODES)
    along_x, along_t = _differences(size_x, size_t)
    normal = (
        a.T @ (a * w[:, None])
        + SMOOTH_SPEED * along_x.T @ along_x
        + SMOOTH_TEMPERATURE * along_t.T @ along_t
        + SHRINK * np.eye(a.shape[1])
    )
    values = np.linalg.solve(normal, a.T @ (w * r))
    values = np.clip(values, -0.5, 0.5)
    support = np.sum(near, axis=0)
    return ResidualSurface(values.reshape(size_x, size_t), support.reshape(size_x, size_t))


def robust_fit(
    design: FloatArray, residual: FloatArray, nearness: FloatArray, scale: float
) -> ResidualSurface:
    """:func:`fit_surface` with two Huber reweightings at ``scale`` [-] (a block across a
    preload step or a hard acceleration does not bend the surface)."""
    check_number(scale, positive("-"), "residual surface: scale", text=False)
    surface = fit_surface(design, residual, nearness)
    for _ in range(2):
        misfit = np.abs(residual - design @ np.ravel(surface.values))
        weight = np.minimum(1.0, scale / np.maximum(misfit, 1e-12))
        surface = fit_surface(design, residual, nearness, weight)
    return surface
