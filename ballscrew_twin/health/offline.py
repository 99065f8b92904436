"""The health monitor run offline on a recorded bag (``ballscrew-twin detect BAG --out DIR``).

The bag's bench topics are read with :func:`ballscrew_twin.bags.bench.read_bench_bag` (damaged
bags: everything readable is used, what was skipped is listed), fed to the same
:class:`.monitor.HealthMonitor` the live node runs, in stamp order, and the result is written to
``DIR`` (by :mod:`ballscrew_twin.commands.detect`):

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

import csv
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..bags.recording import BenchRecording
from ..errors import ConfigError
from ..params import TwinConfig
from .baseline import Baseline
from .monitor import HealthMonitor, feed
from .monitor_settings import MonitorSettings
from .residuals import FloatArray, TwinPredictor
from .verdicts import FAULT, OK, UNKNOWN, VERDICT_NAMES, WARN, HealthSample

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
