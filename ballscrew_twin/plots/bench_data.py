"""Figure of a generated bench bag: the recorded channels, the twin's drag, the fault onsets."""

from __future__ import annotations

from pathlib import Path

from ..health.bench_data import BenchData
from ..units import CELSIUS_ZERO


def plot_bench_data(data: BenchData, path: str | Path) -> Path:
    """PNG of the four recorded channels, the twin's drag torque and the fault onsets."""
    from matplotlib.figure import Figure  # matplotlib: imported when a figure is drawn

    from .save import save_png

    fig = Figure(figsize=(9, 9))
    axes = fig.subplots(4, 1, sharex=True)
    ax = axes[0]
    ax.plot(data.torque_time, data.torque * 1e3, lw=0.5, label="torque meter")
    ax.plot(data.model_time, data.model_torque * 1e3, "k", lw=1, label="twin drag (faulted)")
    ax.set_ylabel("torque [N mm]")
    ax.legend(loc="best")
    axes[1].plot(data.speed_time, data.speed, lw=0.7)
    axes[1].set_ylabel("speed [rad/s]")
    axes[2].plot(data.temperature_time, data.temperature - CELSIUS_ZERO, lw=0.7)
    axes[2].set_ylabel("temperature [C]")
    axes[3].plot(data.preload_time, data.preload, lw=0.7)
    axes[3].set_ylabel("load cell [N]")
    axes[3].set_xlabel("time [s]")
    for spec in data.faults:
        for a in axes:
            a.axvline(spec.onset, color="r", ls="--", lw=1)
        axes[0].annotate(
            spec.fault_class,
            (spec.onset, 0.95),
            xycoords=("data", "axes fraction"),
            color="r",
            fontsize=8,
        )
    fig.suptitle(f"bench data {data.name} (seed {data.seed})")
    fig.tight_layout()
    return save_png(fig, path, dpi=100)
