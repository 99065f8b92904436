"""Figure of ``ballscrew-twin commission``: the fit of a unit to its healthy recording."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..health.commission import CommissioningResult
from ..health.correction import (
    LOG_SPEED_NODES,
    MIN_SUPPORT,
    SPEED_REFERENCE,
    TEMPERATURE_NODES,
    ResidualSurface,
)
from ..units import CELSIUS_ZERO, RPM


def plot_commissioning(result: CommissioningResult, path: str | Path) -> Path:
    """PNG at ``path``: measured and predicted block means [mN m], relative residuals [%],
    the speed [rpm], the fitted values and, with a residual surface, the surface over speed
    and temperature."""
    from matplotlib.figure import Figure  # matplotlib: imported when a figure is drawn

    from .save import save_png

    t = np.array([b.time for b in result.blocks])
    t = t - t[0]
    measured = np.array([b.measured for b in result.blocks])
    fig = Figure(figsize=(9, 9))
    axes = fig.subplots(3, 1, sharex=True)
    axes[0].plot(t, measured * 1e3, ".", ms=2, label="measured (block mean)")
    axes[0].plot(t, result.nominal * 1e3, ".", ms=2, label="nominal twin")
    axes[0].plot(t, result.fitted * 1e3, ".", ms=2, label="commissioned twin")
    axes[0].set_ylabel("drive torque [mN m]")
    axes[0].legend(fontsize=8, markerscale=4)
    # signed: a twin too low reads positive in both directions of rotation
    scale = np.where(np.abs(measured) > 1e-6, measured, 1e-6)
    axes[1].plot(t, (measured - result.nominal) / scale * 100, ".", ms=2, label="nominal")
    axes[1].plot(t, (measured - result.fitted) / scale * 100, ".", ms=2, label="commissioned")
    e = result.baseline.error_relative * 100
    axes[1].axhline(e, color="k", ls=":", lw=1, label=f"+-e_rel ({e:.2f} %)")
    axes[1].axhline(-e, color="k", ls=":", lw=1)
    axes[1].set_ylabel("(measured - twin) / measured [%]")
    axes[1].legend(fontsize=8, markerscale=4)
    axes[2].plot(t, [b.speeds.mean() / RPM for b in result.blocks], ".", ms=2)
    axes[2].set_ylabel("screw speed [rpm]")
    axes[2].set_xlabel("time since the first fitted block [s]")
    b, u = result.baseline, result.uncertainty
    text = "\n".join(
        [
            f"gain g = {b.torque_gain:.4f} +- {u['torque_gain']:.4f}",
            f"bias b = {b.torque_bias * 1e3:.3f} +- {u['torque_bias'] * 1e3:.3f} mN m",
            f"preload scale k_F = {b.preload_scale:.3f} +- {u['preload_scale']:.3f}",
            f"temperature shift dT = {b.temperature_shift:.2f} +- {u['temperature_shift']:.2f} K",
            f"inertia J = {b.inertia * 1e6:.3f} +- {u['inertia'] * 1e6:.3f} g m^2 x 1e-3",
            f"mu_dry scale k_mu = {b.dry_friction_scale:.3f} +- {u['dry_friction_scale']:.3f}",
            f"tau_0 scale k_tau = {b.eyring_scale:.3f} +- {u['eyring_scale']:.3f}",
        ]
    )
    axes[0].text(
        0.01,
        0.02,
        text,
        transform=axes[0].transAxes,
        fontsize=8,
        family="monospace",
        bbox={"facecolor": "white", "alpha": 0.8},
    )
    for ax in axes:
        ax.grid(alpha=0.3)
    fig.suptitle(f"commissioning on {b.source or 'recording'} ({b.blocks} blocks)")
    fig.tight_layout()
    if b.surface is not None:
        _draw_surface(fig, b.surface)
    return save_png(fig, path)


def _draw_surface(fig: Any, surface: ResidualSurface) -> None:
    """A fourth panel: the residual surface c over speed and temperature, hatched where it
    was not learnt (support below MIN_SUPPORT blocks)."""
    fig.set_size_inches(9, 12)
    fig.subplots_adjust(bottom=0.3)
    ax = fig.add_axes((0.1, 0.04, 0.72, 0.18))
    speeds = SPEED_REFERENCE * 10.0 ** np.array(LOG_SPEED_NODES) / RPM
    celsius = np.array(TEMPERATURE_NODES) - CELSIUS_ZERO
    image = ax.pcolormesh(
        speeds, celsius, surface.values.T * 100.0, cmap="coolwarm", vmin=-5.0, vmax=5.0
    )
    ax.contourf(
        speeds,
        celsius,
        surface.support.T,
        levels=[-1.0, MIN_SUPPORT],
        colors="none",
        hatches=["////"],
    )
    ax.set_xscale("log")
    ax.set_xlabel("screw speed [rpm]")
    ax.set_ylabel("temperature [C]")
    ax.set_title("residual surface c (hatched: not learnt, support < 10 blocks)", fontsize=9)
    bar = fig.colorbar(image, cax=fig.add_axes((0.85, 0.04, 0.02, 0.18)))
    bar.set_label("c [%]")
