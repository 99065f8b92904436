"""``ballscrew-twin detect BAG --out DIR``: the health monitor run offline on a recorded bag.

What it writes and how: :mod:`ballscrew_twin.health.offline`. Exit status: 0 (OK, WARN or
UNKNOWN), 1 (FAULT), 2 (the bag or the settings are unusable). :func:`add_topic_arguments` and
:func:`bench_topics` are shared with ``commission`` and ``calibrate``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from ..bags.bench import read_bench_bag
from ..bags.recording import BenchRecording, BenchTopics
from ..errors import BallscrewTwinError
from ..health.baseline import load_baseline
from ..health.monitor_settings import DETECTORS, MonitorSettings
from ..health.offline import CHANNELS, recording_channels, run_monitor, summary, write_csv
from ..health.residuals import shared_predictor
from ..health.uncompared import why_nothing_compared
from ..health.verdicts import FAULT, UNKNOWN
from ..params import load_config
from ..plots.detection import plot
from .map import ensure_friction_response


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


def bench_topics(args: argparse.Namespace) -> BenchTopics:
    """The bench topics and joint of :func:`add_topic_arguments`."""
    return BenchTopics(
        torque=args.torque_topic,
        speed=args.speed_topic,
        temperature=args.temperature_topic,
        preload=args.preload_topic,
        joint_name=args.joint,
    )


def read_recording(args: argparse.Namespace) -> BenchRecording:
    """The bag of ``args.bag`` with the topics of :func:`add_topic_arguments`."""
    return read_bench_bag(args.bag, bench_topics(args), required=CHANNELS)


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
    if baseline is not None and (baseline.dry_friction_scale, baseline.eyring_scale) != (1, 1):
        ensure_friction_response(config)
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
