"""Figures of ``ballscrew-twin detect``: the residuals, the detectors' statistics, the classes.

Each takes a :class:`~ballscrew_twin.health.offline.DetectionResult` and writes PNG files into
the output folder; times are seconds since the bag's first message.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from ..health.monitor_settings import DETECTORS
from ..health.offline import DetectionResult
from ..health.verdicts import FAULT, OK, UNKNOWN, WARN


def plot(result: DetectionResult, out: Path, truth: dict[str, Any] | None) -> list[Path]:
    """Residual and statistic plots (PNG) into ``out``."""
    from matplotlib.figure import Figure  # matplotlib: imported when a figure is drawn

    from .save import save_png

    samples = result.samples
    t = np.array([s.time - result.start for s in samples])
    onsets = [float(f["onset_s"]) for f in (truth or {}).get("faults") or []]
    alarm = result.monitor.alarm

    warmup_end = result.monitor.settings.warmup + (t[0] if len(t) else 0.0)

    def marks(ax: Any) -> None:
        for onset in onsets:
            ax.axvline(onset, color="k", ls=":", lw=1, label="true onset")
        if alarm is not None:
            ax.axvline(alarm.time - result.start, color="r", ls="--", lw=1, label="alarm")
        if len(t):
            ax.axvspan(t[0], warmup_end, color="0.85", label="warm-up")

    fig = Figure(figsize=(9, 8))
    axes = fig.subplots(3, 1, sharex=True)
    axes[0].plot(t, [s.measured * 1e3 for s in samples], lw=0.8, label="measured (block mean)")
    axes[0].plot(t, [s.predicted * 1e3 for s in samples], lw=0.8, label="twin")
    axes[0].set_ylabel("drive torque [mN m]")
    axes[1].plot(t, [s.normalized_residual for s in samples], lw=0.8)
    axes[1].set_ylabel("residual / sigma [-]")
    axes[2].plot(t, [s.innovation for s in samples], lw=0.8)
    axes[2].set_ylabel("innovation / sigma [-]")
    axes[2].set_xlabel("time since bag start [s]")
    for ax in axes:
        marks(ax)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    residual_png = save_png(fig, out / "residuals.png")

    fig = Figure(figsize=(9, 6))
    axes = fig.subplots(2, 1, sharex=True)
    for name in DETECTORS:
        ratio = [
            s.statistics[name][0] / s.statistics[name][1] if name in s.statistics else math.nan
            for s in samples
        ]
        axes[0].plot(t, ratio, lw=0.8, label=name)
    axes[0].axhline(1.0, color="r", lw=1, label="threshold")
    axes[0].set_yscale("symlog", linthresh=1.0)
    axes[0].set_ylim(bottom=0.0)
    axes[0].set_ylabel("statistic / its threshold [-]")
    axes[0].legend(fontsize=8)
    # OK < WARN < FAULT upwards; UNKNOWN (warm-up, gated, no prediction) drawn apart below
    level = {OK: 1, WARN: 2, FAULT: 3, UNKNOWN: 0}
    axes[1].step(t, [level[s.verdict] for s in samples], where="mid")
    axes[1].set_yticks([0, 1, 2, 3], ["UNKNOWN", "OK", "WARN", "FAULT"])
    axes[1].set_ylim(-0.5, 3.5)
    axes[1].set_ylabel("verdict [-]")
    axes[1].set_xlabel("time since bag start [s]")
    for ax in axes:
        marks(ax)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    stats_png = save_png(fig, out / "statistics.png")
    return [residual_png, stats_png, *plot_classification(result, out)]


def plot_classification(result: DetectionResult, out: Path) -> list[Path]:
    """PNG of each class's log-likelihood ratio and fitted severity while the alarm's class is
    refined (nothing without an alarm)."""
    from matplotlib.figure import Figure  # matplotlib: imported when a figure is drawn

    from .save import save_png

    history = result.monitor.classifications
    if not history:
        return []
    t = np.array([time - result.start for time, _ in history])
    names = sorted({n for _, c in history for n in (*c.scores, *c.severities)})
    fig = Figure(figsize=(9, 6))
    axes = fig.subplots(2, 1, sharex=True)
    for name in names:
        axes[0].plot(t, [c.scores.get(name, math.nan) for _, c in history], label=name)
        axes[1].plot(t, [c.severities.get(name, math.nan) for _, c in history], label=name)
    axes[0].set_ylabel("class score: log-likelihood ratio [-]")
    axes[0].set_yscale("symlog", linthresh=10.0)
    axes[1].set_ylabel("fitted severity [-]")
    axes[1].set_xlabel("time since bag start [s]")
    final = history[-1][1]
    named = final.fault_class or f"unclassified ({final.reason})"
    axes[0].set_title(f"class after the alarm: {named}, confidence {final.confidence:.2f}")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    return [save_png(fig, out / "classification.png")]
