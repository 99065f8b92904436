"""``ballscrew-twin detect BAG --out DIR``: the health monitor run offline on a recorded bag.

The bag's bench topics are read with :func:`.bags.read_bench_bag` (damaged bags: everything
readable is used, what was skipped is listed), fed to the same :class:`.monitor.HealthMonitor`
the live node runs, in stamp order, and the result is written to ``DIR``:

- ``verdict.json``: verdict (FAULT if any alarm, else OK/WARN/UNKNOWN of the last block),
  fault class and confidence, alarm time and detector, estimated onset, the class scores, and,
  when the bag has a ground truth (``<bag>.truth.json``), the true fault, the detection delay
  (alarm time minus true onset [s]) and whether the class is right. Times are in seconds since
  the bag's first message.
- ``residuals.png``: measured and predicted torque, normalised residual and innovation.
- ``statistics.png``: each detector's statistic over its threshold, the verdicts, the onset.
- ``samples.csv``: the per-block results.

Exit status: 0 (OK, WARN or UNKNOWN), 1 (FAULT), 2 (the bag or the settings are unusable).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..bags.bench import read_bench_bag
from ..bags.recording import BenchRecording, BenchTopics
from ..errors import BallscrewTwinError, ConfigError
from ..params import TwinConfig, load_config
from .baseline import Baseline, load_baseline
from .monitor import (
    DETECTORS,
    FAULT,
    OK,
    UNKNOWN,
    VERDICT_NAMES,
    WARN,
    HealthMonitor,
    HealthSample,
    MonitorSettings,
    feed,
)
from .residuals import FloatArray, TwinPredictor, shared_predictor
from .uncompared import why_nothing_compared

#: Channels the monitor needs from a bag.
CHANNELS = ("torque", "speed", "temperature", "preload")


@dataclass(frozen=True)
class DetectionResult:
    """Outcome of one run of the monitor over a recording.

    Attributes:
        verdict: overall verdict (FAULT if there was an alarm) [-].
        samples: per-block results.
        monitor: the monitor after the run.
        start: absolute time of the recording's first message [s].
    """

    verdict: int
    samples: list[HealthSample]
    monitor: HealthMonitor
    start: float


def overall_verdict(monitor: HealthMonitor, samples: Sequence[HealthSample]) -> int:
    """FAULT after an alarm; else WARN if any block warned; OK if any block was compared;
    UNKNOWN if none was."""
    if monitor.alarm is not None:
        return FAULT
    verdicts = {s.verdict for s in samples}
    if WARN in verdicts:
        return WARN
    return OK if OK in verdicts else UNKNOWN


def run_monitor(
    channels: dict[str, tuple[FloatArray, FloatArray]],
    config: TwinConfig,
    settings: MonitorSettings | None = None,
    start: float = 0.0,
    predictor: TwinPredictor | None = None,
    baseline: Baseline | None = None,
) -> DetectionResult:
    """Run a fresh monitor over channels of absolute stamps [s] (see :func:`.monitor.feed`);
    ``predictor`` shares the twin's cache between runs; ``baseline``: the commissioned unit
    (default: the nominal twin)."""
    monitor = HealthMonitor(config, settings, predictor=predictor, baseline=baseline)
    samples = feed(monitor, channels)
    return DetectionResult(overall_verdict(monitor, samples), samples, monitor, start)


def recording_channels(recording: BenchRecording) -> dict[str, tuple[FloatArray, FloatArray]]:
    """The four channels of a recording with absolute stamps [s] (bag start + time)."""
    start = recording.start_ns * 1e-9
    out = {}
    for name in CHANNELS:
        if name not in recording.channels:
            raise ConfigError(
                f"{recording.path}: the {name} channel is missing; the monitor needs torque, "
                "speed, temperature and preload"
            )
        series = recording.series(name)
        out[name] = (start + np.asarray(series.time, float), np.asarray(series.value, float))
    return out


def summary(result: DetectionResult, truth: dict[str, Any] | None) -> dict[str, Any]:
    """JSON-ready verdict (times in seconds since the recording's start)."""
    monitor = result.monitor
    alarm = monitor.alarm
    data: dict[str, Any] = {
        "verdict": VERDICT_NAMES[result.verdict],
        "fault_class": alarm.classification.fault_class if alarm else "",
        "confidence": alarm.classification.confidence if alarm else None,
        "alarm": None,
        "blocks": len(result.samples),
        "blocks_compared": sum(1 for s in result.samples if math.isfinite(s.innovation)),
        "sensor_noise_Nm": math.sqrt(monitor.sensor_variance or math.nan),
        "thresholds": monitor.thresholds,
        "false_alarm_rate_per_h": monitor.settings.false_alarm_rate,
        "model": monitor.twin_name,
        "model_note": monitor.twin_note,
        "baseline": monitor.baseline.source,
        "gated_s": monitor.gated_time,
        "compared_s": monitor.compared_time,
    }
    if alarm is not None:
        data["alarm"] = {
            "time_s": alarm.time - result.start,
            "detector": alarm.detector,
            "onset_estimate_s": alarm.onset - result.start,
            "scores": alarm.classification.scores,
            "severities": alarm.classification.severities,
            "unclassified_reason": alarm.classification.reason,
        }
    if truth is not None:
        faults = truth.get("faults") or []
        data["truth"] = faults
        if faults:
            first = min(faults, key=lambda f: float(f["onset_s"]))
            data["true_class"] = first["class"]
            if alarm is not None:
                data["detection_delay_s"] = alarm.time - result.start - float(first["onset_s"])
                data["class_correct"] = data["fault_class"] == first["class"]
        else:
            data["true_class"] = ""
            data["false_alarm"] = alarm is not None
    return data


def plot(result: DetectionResult, out: Path, truth: dict[str, Any] | None) -> list[Path]:
    """Residual and statistic plots (PNG) into ``out``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

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

    fig, axes = plt.subplots(3, 1, figsize=(9, 8), sharex=True)
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
    residual_png = out / "residuals.png"
    fig.savefig(residual_png, dpi=110)
    plt.close(fig)

    fig, axes = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
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
    stats_png = out / "statistics.png"
    fig.savefig(stats_png, dpi=110)
    plt.close(fig)
    return [residual_png, stats_png, *plot_classification(result, out)]


def plot_classification(result: DetectionResult, out: Path) -> list[Path]:
    """PNG of each class's log-likelihood ratio and fitted severity while the alarm's class is
    refined (nothing without an alarm)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    history = result.monitor.classifications
    if not history:
        return []
    t = np.array([time - result.start for time, _ in history])
    names = sorted({n for _, c in history for n in (*c.scores, *c.severities)})
    fig, axes = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
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
    path = out / "classification.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return [path]


def write_csv(result: DetectionResult, path: Path) -> None:
    """Per-block results as CSV (times since the recording's start [s], SI units)."""
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(
            [
                "time_s",
                "measured_Nm",
                "predicted_Nm",
                "residual_Nm",
                "normalized_residual",
                "innovation",
                "test_statistic",
                "threshold",
                "verdict",
                "fault_class",
                "confidence",
            ]
        )
        for s in result.samples:
            writer.writerow(
                [
                    f"{s.time - result.start:.4f}",
                    s.measured,
                    s.predicted,
                    s.residual,
                    s.normalized_residual,
                    s.innovation,
                    s.test_statistic,
                    s.threshold,
                    VERDICT_NAMES[s.verdict],
                    s.fault_class,
                    s.confidence,
                ]
            )


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``detect``."""
    parser.add_argument("bag", help="bag folder or file (mcap or sqlite3)")
    parser.add_argument("--out", required=True, help="output directory (created)")
    parser.add_argument("--config", default=None, help="screw parameter YAML (default: paper)")
    parser.add_argument(
        "--baseline",
        default=None,
        help="baseline of the commissioned unit (ballscrew-twin commission); default: the "
        "nominal twin with its default model error",
    )
    parser.add_argument(
        "--false-alarm-rate",
        type=float,
        default=MonitorSettings.false_alarm_rate,
        help="target false alarms per hour [1/h]",
    )
    parser.add_argument(
        "--detectors",
        default=",".join(MonitorSettings.detectors),
        help="comma-separated detectors that may raise an alarm, some of "
        f"{','.join(DETECTORS)} (docs/model.md section 15)",
    )
    parser.add_argument(
        "--warmup",
        type=float,
        default=MonitorSettings.warmup,
        help="healthy warm-up at the start [s]",
    )
    add_topic_arguments(parser)
    parser.add_argument("--no-plots", action="store_true", help="skip the PNG plots")


def add_topic_arguments(parser: argparse.ArgumentParser) -> None:
    """The bench topics of a bag and the screw's joint (``detect``, ``commission``)."""
    parser.add_argument("--torque-topic", default=BenchTopics.torque)
    parser.add_argument("--speed-topic", default=BenchTopics.speed)
    parser.add_argument("--temperature-topic", default=BenchTopics.temperature)
    parser.add_argument("--preload-topic", default=BenchTopics.preload)
    parser.add_argument("--joint", default=BenchTopics.joint_name, help="joint of the screw")


def read_recording(args: argparse.Namespace) -> BenchRecording:
    """The bag of ``args.bag`` with the topics of :func:`add_topic_arguments`."""
    topics = BenchTopics(
        torque=args.torque_topic,
        speed=args.speed_topic,
        temperature=args.temperature_topic,
        preload=args.preload_topic,
        joint_name=args.joint,
    )
    return read_bench_bag(args.bag, topics, required=CHANNELS)


def run(args: argparse.Namespace) -> int:
    """Run the detector over the bag; print the verdict; exit 0 (1 for a FAULT verdict)."""
    recording = read_recording(args)
    settings = MonitorSettings(
        false_alarm_rate=args.false_alarm_rate,
        warmup=args.warmup,
        detectors=tuple(name.strip() for name in args.detectors.split(",") if name.strip()),
    )
    config = load_config(args.config)
    out = Path(args.out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise BallscrewTwinError(f"cannot create output directory {out}: {err}") from err
    start = recording.start_ns * 1e-9
    predictor = shared_predictor(config, settings.residual)
    baseline = load_baseline(args.baseline) if args.baseline else None
    result = run_monitor(
        recording_channels(recording), config, settings, start, predictor, baseline
    )
    data = summary(result, recording.truth)
    data["bag"] = str(recording.path)
    data["issues"] = list(recording.issues)
    if result.verdict == UNKNOWN:
        data["unknown_reason"] = why_nothing_compared(recording, result.samples, settings)
    (out / "verdict.json").write_text(json.dumps(data, indent=2) + "\n")
    write_csv(result, out / "samples.csv")
    if not args.no_plots:
        plot(result, out, recording.truth)
    for issue in recording.issues:
        print(f"note: {issue}")
    line = f"{data['verdict']}"
    if "unknown_reason" in data:
        line += f": {data['unknown_reason']}"
    if data["alarm"]:
        line += (
            f": {data['fault_class'] or 'unclassified'} (confidence {data['confidence']:.2f}), "
            f"alarm at {data['alarm']['time_s']:.2f} s by {data['alarm']['detector']}"
        )
        if not data["fault_class"]:
            line += f" ({data['alarm']['unclassified_reason']})"
    if "detection_delay_s" in data:
        line += f", delay {data['detection_delay_s']:.2f} s after the true onset"
    print(line)
    print(f"wrote {out / 'verdict.json'}")
    return 1 if result.verdict == FAULT else 0
