"""Plot of a sweep: drag torque as curves over a grid, or as a heat map of random draws.

- Every varying dimension takes listed values (a grid, or random choices among lists): the
  drag torque against the first varying dimension, one curve per value of the second, one
  panel per combination of the others (at most :data:`MAX_PANELS`; the title says when some
  are left out). Repeated points (random choices) are averaged.
- A dimension drawn from a continuous range: with one varying dimension, the torque against
  it; with more, a heat map of the mean torque over the first two varying dimensions in
  :data:`HEAT_BINS` x :data:`HEAT_BINS` cells (the others averaged over, as the title says).

Speeds are shown in rpm, temperatures in deg C, torques in mN m; every other dimension in its
SI unit.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from ..units import CELSIUS_ZERO, RPM
from .save import save_png

FloatArray = NDArray[np.float64]
#: Most panels drawn for the combinations of the dimensions beyond the second.
MAX_PANELS = 12
#: Cells per axis of the heat map of random draws.
HEAT_BINS = 12


class SweptDimension(Protocol):
    """What the plot needs of a swept dimension (see ``ballscrew_twin.sweep.Dimension``)."""

    @property
    def name(self) -> str: ...
    @property
    def unit(self) -> str: ...
    @property
    def values(self) -> tuple[float, ...]: ...
    @property
    def log(self) -> bool: ...
    @property
    def is_range(self) -> bool: ...


def display(name: str, unit: str) -> tuple[str, Callable[[FloatArray], FloatArray]]:
    """Axis label and SI -> shown conversion of a dimension."""
    if name == "screw_speed":
        return "screw speed [rpm]", lambda v: v / RPM
    if name == "temperature":
        return "temperature [°C]", lambda v: v - CELSIUS_ZERO
    return f"{name.replace('_', ' ')} [{unit}]", lambda v: v


def plot_sweep(
    rows: Sequence[Mapping[str, Any]],
    dimensions: Sequence[SweptDimension],
    columns: Mapping[str, str],
    title: str,
    path: str | Path,
) -> Path | None:
    """Write the sweep's PNG; None when no dimension varies or no point succeeded.

    Args:
        rows: result rows (``status``, ``drag_torque_Nm`` [N m] and one column per dimension).
        dimensions: the swept dimensions, in sweep order.
        columns: column of a dimension in ``rows`` when not its name (operating point).
        title: figure title.
        path: PNG file.
    """
    from matplotlib.figure import Figure

    ok = [r for r in rows if r["status"] == "ok"]
    varying = [d for d in dimensions if d.is_range or len(d.values) > 1]
    if not varying or not ok:
        return None
    torque = np.array([float(r["drag_torque_Nm"]) for r in ok]) * 1e3
    data = {d.name: np.array([float(r[columns.get(d.name, d.name)]) for r in ok]) for d in varying}
    if any(d.is_range for d in varying):
        fig = Figure(figsize=(7.5, 5.5), layout="constrained")
        ax = fig.subplots()
        if len(varying) == 1:
            _draw_samples(ax, varying[0], data, torque)
        else:
            title += _draw_heat_map(fig, ax, varying, data, torque)
    else:
        fig, note = _draw_curves(varying, data, torque)
        title += note
    fig.suptitle(title)
    return save_png(fig, path)


def _draw_samples(
    ax: Any, dim: SweptDimension, data: dict[str, FloatArray], torque: FloatArray
) -> None:
    label, shown = display(dim.name, dim.unit)
    order = np.argsort(data[dim.name])
    ax.plot(shown(data[dim.name][order]), torque[order], "o-", ms=3, lw=0.8)
    ax.set_xlabel(label)
    ax.set_ylabel("drag torque [mN m]")
    ax.grid(True, alpha=0.3)


def _draw_heat_map(
    fig: Any,
    ax: Any,
    varying: Sequence[SweptDimension],
    data: dict[str, FloatArray],
    torque: FloatArray,
) -> str:
    (x_label, x_shown), (y_label, y_shown) = (display(d.name, d.unit) for d in varying[:2])
    x, y = x_shown(data[varying[0].name]), y_shown(data[varying[1].name])
    x_edges, y_edges = _edges(x, varying[0]), _edges(y, varying[1])
    total, _, _ = np.histogram2d(x, y, bins=(x_edges, y_edges), weights=torque)
    count, _, _ = np.histogram2d(x, y, bins=(x_edges, y_edges))
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(count > 0, total / count, np.nan)
    mesh = ax.pcolormesh(x_edges, y_edges, mean.T, shading="flat", cmap="viridis")
    fig.colorbar(mesh, ax=ax, label="mean drag torque [mN m]")
    ax.set_xlabel(x_label)
    ax.set_ylabel(y_label)
    others = [d.name for d in varying[2:]]
    note = f", {len(torque)} random points"
    return note + (f", averaged over {', '.join(others)}" if others else "")


def _edges(values: FloatArray, dim: SweptDimension) -> FloatArray:
    """Cell edges: around each listed value, or :data:`HEAT_BINS` equal cells of a range."""
    if not dim.is_range:
        centres = np.unique(values)
        if len(centres) == 1:
            return np.array([centres[0] - 0.5, centres[0] + 0.5])
        middle = 0.5 * (centres[1:] + centres[:-1])
        return np.concatenate(
            [[2 * centres[0] - middle[0]], middle, [2 * centres[-1] - middle[-1]]]
        )
    lo, hi = float(np.min(values)), float(np.max(values))
    if dim.log and lo > 0.0:
        return np.geomspace(lo, hi * (1 + 1e-12), HEAT_BINS + 1)
    return np.linspace(lo, hi + 1e-12 * max(abs(hi), 1.0), HEAT_BINS + 1)


def _draw_curves(
    varying: Sequence[SweptDimension], data: dict[str, FloatArray], torque: FloatArray
) -> tuple[Any, str]:
    from matplotlib.figure import Figure

    x_dim, colour_dim = varying[0], (varying[1] if len(varying) > 1 else None)
    panel_dims = list(varying[2:])
    combos = list(itertools.product(*(np.unique(data[d.name]) for d in panel_dims)))
    note = ""
    if len(combos) > MAX_PANELS:
        note = f" (first {MAX_PANELS} of {len(combos)} panels)"
        combos = combos[:MAX_PANELS]
    columns = min(len(combos), 3)
    rows = math.ceil(len(combos) / columns)
    fig = Figure(figsize=(5.0 * columns + 1.0, 4.0 * rows), layout="constrained")
    axes = np.atleast_1d(fig.subplots(rows, columns, squeeze=False, sharex=True, sharey=True))
    x_label, x_shown = display(x_dim.name, x_dim.unit)
    colour_values = np.unique(data[colour_dim.name]) if colour_dim else np.array([math.nan])
    for ax, combo in zip(axes.flat, combos, strict=False):
        in_panel = np.ones(len(torque), dtype=bool)
        for d, v in zip(panel_dims, combo, strict=True):
            in_panel &= data[d.name] == v
        for k, c in enumerate(colour_values):
            chosen = in_panel & ((data[colour_dim.name] == c) if colour_dim else True)
            xs = np.unique(data[x_dim.name][chosen])
            means = [float(np.mean(torque[chosen & (data[x_dim.name] == v)])) for v in xs]
            label = _value_text(colour_dim, c) if colour_dim else None
            ax.plot(x_shown(xs), means, "o-", ms=4, color=f"C{k % 10}", label=label)
        ax.set_title(", ".join(_value_text(d, v) for d, v in zip(panel_dims, combo, strict=True)))
        ax.set_ylabel("drag torque [mN m]")
        ax.set_xlabel(x_label)
        ax.grid(True, alpha=0.3)
        if colour_dim is not None:
            ax.legend(loc="best", fontsize="small")
    for ax in list(axes.flat)[len(combos) :]:
        ax.set_visible(False)
    return fig, note


def _value_text(dim: SweptDimension, value: float) -> str:
    """``name = value unit`` in the shown unit."""
    label, shown = display(dim.name, dim.unit)
    name, _, unit = label.partition(" [")
    return f"{name} = {float(shown(np.array(value))):.4g} {unit.rstrip(']')}"
