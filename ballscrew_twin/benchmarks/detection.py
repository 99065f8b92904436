"""``ballscrew-twin bench detection``: how well the health monitor finds and names faults.

Recordings are generated in memory by the bench-data generator
(:func:`ballscrew_twin.health.bench_data.generate`: the steady-state twin with the fault
injected, sensor noise, bias, quantisation, speed ripple, temperature drift) over operating
profiles, seeds, severities, onset times and growth profiles, and each goes through the same
:class:`~ballscrew_twin.health.monitor.HealthMonitor` as the node and ``detect``. Measured:

- detection delay (alarm time minus true onset) per class and severity, and the share
  detected within :data:`DELAY_GOAL` seconds;
- missed detections (no alarm by the end of the run) and early alarms (before the onset);
- false alarms per hour on healthy recordings (with the 95 % upper bound of the rate when
  none is seen: 3 / hours, the "rule of three");
- classification accuracy and the confusion matrix;
- ROC curves per class: the largest statistic/threshold ratio of any detector within
  :data:`DELAY_GOAL` s after the onset (fault runs) against the same in every
  :data:`DELAY_GOAL` s window of the healthy runs, swept over the threshold scale (PNG).

``--out DIR`` writes ``detection.md`` (the tables), ``roc.png``, ``delays.png`` and
``runs.json``. ``--quick``: one short run per class and one minute of healthy data (smoke test).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigError
from ..health.bench_data import START_NS, BenchData, generate
from ..health.bench_scene import bench_scene_from_mapping
from ..health.classify import FAULT_CLASSES
from ..health.detect import run_monitor
from ..health.monitor import DETECTORS, MonitorSettings
from ..health.residuals import FloatArray, TwinPredictor, shared_predictor
from ..params import load_config

#: One-line help of this benchmark.
DESCRIPTION = "fault detection: delay, false alarms/h, misses, classification, ROC per class"

RPM = 2.0 * math.pi / 60.0  # rad/s per rpm
CELSIUS_ZERO = 273.15  # K
#: Detection-delay goal of issue 7 [s].
DELAY_GOAL = 5.0
#: Onsets are drawn uniformly from this range [s] (after the 5 s warm-up).
ONSET_RANGE = (8.0, 16.0)
#: Severities per class (fraction lost; peak ripple relative to the torque; mu_dry rise).
SEVERITIES: dict[str, tuple[float, ...]] = {
    "preload_loss": (0.1, 0.2, 0.3),
    "lubricant_degradation": (0.15, 0.3, 0.5),
    "raceway_defect": (0.02, 0.05, 0.1),
    "sphere_defect": (0.02, 0.05, 0.1),
    "jam_onset": (1.0, 2.0, 4.0),
}
#: The issue's headline cases: (class, severity) that must be detected within DELAY_GOAL.
GOALS = (("preload_loss", 0.2), ("lubricant_degradation", 0.3))
SENSORS = {
    "torque": {"rate": 200.0, "noise": 2.0e-4, "bias": 2.0e-4, "resolution": 1.0e-5},
    "speed": {"rate": 100.0, "noise": 0.01, "ripple": 0.005, "ripple_order": 1.0},
    "temperature": {"rate": 10.0, "noise": 0.05, "drift": 1.0e-3, "resolution": 0.01},
    "preload": {"rate": 20.0, "noise": 5.0, "bias": 0.0, "resolution": 0.5},
}


def _point(time: float, rpm: float, celsius: float, preload: float = 1500.0) -> dict[str, float]:
    return {
        "time": time,
        "speed": rpm * RPM,
        "temperature": celsius + CELSIUS_ZERO,
        "preload": preload,
    }


def profiles(duration: float) -> dict[str, list[dict[str, float]]]:
    """Operating profiles (piecewise linear) of ``duration`` [s]."""
    d = duration
    return {
        "constant_100rpm": [_point(0.0, 100.0, 20.0), _point(d, 100.0, 21.0)],
        "steps_100_300rpm": [
            _point(0.0, 100.0, 20.0),
            _point(0.3 * d, 100.0, 20.5),
            _point(0.3 * d + 1.0, 200.0, 20.6),
            _point(0.6 * d, 200.0, 21.0),
            _point(0.6 * d + 1.0, 300.0, 21.1),
            _point(d, 300.0, 21.5),
        ],
        "warming_300rpm": [_point(0.0, 300.0, 20.0), _point(d, 300.0, 35.0)],
    }


@dataclass(frozen=True)
class Run:
    """One recording through the monitor.

    Attributes:
        profile: operating profile name.
        seed: noise seed.
        true_class: fault class, "" for healthy.
        severity: fault severity [-].
        growth: growth profile of the fault.
        onset: true onset [s] (nan for healthy).
        duration: length of the recording [s].
        alarm: alarm time [s] since the start (nan: none).
        detector: detector that fired first.
        fault_class: class named by the monitor.
        confidence: its confidence [-].
        scores: max statistic/threshold ratio per DELAY_GOAL window after the onset (fault
            runs: one value) or in each window (healthy runs) [-].
    """

    profile: str
    seed: int
    true_class: str
    severity: float
    growth: str
    onset: float
    duration: float
    alarm: float
    detector: str
    fault_class: str
    confidence: float
    scores: tuple[float, ...]

    @property
    def delay(self) -> float:
        """Alarm time minus true onset [s] (nan without alarm or for healthy runs)."""
        return self.alarm - self.onset


def _scene(
    profile: list[dict[str, float]],
    duration: float,
    seed: int,
    faults: list[dict[str, Any]],
    model_step: float,
) -> Any:
    return bench_scene_from_mapping(
        {
            "name": "bench_detection",
            "duration": duration,
            "seed": seed,
            "model_step": model_step,
            "profile": profile,
            "sensors": SENSORS,
            "faults": faults,
        },
        "bench detection scene",
    )


def _channels(data: BenchData) -> dict[str, tuple[FloatArray, FloatArray]]:
    start = START_NS * 1e-9
    return {
        "torque": (start + data.torque_time, data.torque),
        "speed": (start + data.speed_time, data.speed),
        "temperature": (start + data.temperature_time, data.temperature),
        "preload": (start + data.preload_time, data.preload),
    }


def _window_scores(times: FloatArray, ratios: FloatArray, start: float, stop: float) -> float:
    inside = (times >= start) & (times < stop)
    return float(np.max(ratios[inside])) if np.any(inside) else 0.0


def run_one(
    data: BenchData,
    predictor: TwinPredictor,
    settings: MonitorSettings,
    profile: str,
) -> Run:
    """Run the monitor over a generated recording and score it."""
    result = run_monitor(_channels(data), predictor.config, settings, START_NS * 1e-9, predictor)
    start = START_NS * 1e-9
    times = np.array([s.time - start for s in result.samples])
    ratios = np.array(
        [
            max(
                (s.statistics[d][0] / s.statistics[d][1] for d in DETECTORS if d in s.statistics),
                default=0.0,
            )
            for s in result.samples
        ]
    )
    faults = data.truth["faults"]
    if faults:
        onset = float(faults[0]["onset_s"])
        scores: tuple[float, ...] = (_window_scores(times, ratios, onset, onset + DELAY_GOAL),)
    else:
        onset = math.nan
        edges = np.arange(settings.warmup, data.scene.duration - DELAY_GOAL + 1e-9, DELAY_GOAL)
        scores = tuple(_window_scores(times, ratios, a, a + DELAY_GOAL) for a in edges)
    alarm = result.monitor.alarm
    return Run(
        profile=profile,
        seed=data.seed,
        true_class=faults[0]["class"] if faults else "",
        severity=float(faults[0]["severity"]) if faults else 0.0,
        growth=str(faults[0]["growth"]) if faults else "",
        onset=onset,
        duration=data.scene.duration,
        alarm=alarm.time - start if alarm else math.nan,
        detector=alarm.detector if alarm else "",
        fault_class=alarm.classification.fault_class if alarm else "",
        confidence=alarm.classification.confidence if alarm else 0.0,
        scores=scores,
    )


def plan(quick: bool, runs_per_case: int, seed: int, scale: float = 1.0) -> list[dict[str, Any]]:
    """The fault runs: every class x severity (x ``scale``) x profile, ``runs_per_case``
    seeds each."""
    rng = np.random.default_rng(seed)
    names = list(profiles(1.0))
    cases = []
    for cls in FAULT_CLASSES:
        severities = SEVERITIES[cls][1:2] if quick else SEVERITIES[cls]
        for severity in severities:
            for p, profile in enumerate(names[:1] if quick else names):
                for k in range(runs_per_case):
                    growth = "step" if (k + p) % 2 == 0 else "ramp"
                    cases.append(
                        {
                            "profile": profile,
                            "seed": int(rng.integers(0, 2**31)),
                            "fault": {
                                "class": cls,
                                "onset": float(rng.uniform(*ONSET_RANGE)),
                                "severity": severity * scale,
                                "growth": growth,
                                "growth_time": 2.0 if growth == "ramp" else 0.0,
                            },
                        }
                    )
    return cases


def roc(runs: list[Run], cls: str) -> tuple[FloatArray, FloatArray, float]:
    """False- and true-positive rates over the threshold scale, and the area under the curve."""
    positives = np.array([r.scores[0] for r in runs if r.true_class == cls])
    negatives = np.array([s for r in runs if not r.true_class for s in r.scores])
    if len(positives) == 0 or len(negatives) == 0:
        return np.array([0.0, 1.0]), np.array([0.0, 1.0]), math.nan
    levels = np.unique(np.concatenate([positives, negatives, [0.0, np.inf]]))[::-1]
    tpr = np.array([np.mean(positives >= v) for v in levels])
    fpr = np.array([np.mean(negatives >= v) for v in levels])
    return fpr, tpr, float(np.trapezoid(tpr, fpr))


def report(runs: list[Run], healthy_hours: float, settings: MonitorSettings) -> str:
    """Markdown tables of the results."""
    lines = [
        f"Target false-alarm rate {settings.false_alarm_rate:g}/h (all detectors), warm-up "
        f"{settings.warmup:g} s, blocks of {settings.residual.block_duration:g} s.",
        "",
        "| class | severity | runs | detected <= 5 s | missed | early | median delay [s] "
        "| max delay [s] | class right |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for cls in FAULT_CLASSES:
        for severity in sorted({r.severity for r in runs if r.true_class == cls}):
            group = [r for r in runs if r.true_class == cls and r.severity == severity]
            delays = np.array([r.delay for r in group if r.delay >= 0.0])
            on_time = int(np.sum(delays <= DELAY_GOAL))
            missed = sum(1 for r in group if math.isnan(r.alarm))
            early = sum(1 for r in group if r.alarm < r.onset)
            right = sum(1 for r in group if r.fault_class == cls and r.alarm >= r.onset)
            detected = len(delays)
            lines.append(
                f"| {cls} | {severity:g} | {len(group)} | {on_time} | {missed} | {early} | "
                f"{np.median(delays) if detected else math.nan:.2f} | "
                f"{np.max(delays) if detected else math.nan:.2f} | {right}/{detected} |"
            )
    healthy = [r for r in runs if not r.true_class]
    alarms = sum(1 for r in healthy if not math.isnan(r.alarm))
    rate = alarms / healthy_hours if healthy_hours > 0 else math.nan
    bound = (3.0 if alarms == 0 else math.nan) / healthy_hours if healthy_hours > 0 else math.nan
    lines += [
        "",
        f"Healthy data: {healthy_hours:.2f} h in {len(healthy)} recordings, {alarms} false "
        f"alarm(s): {rate:.3g}/h" + (f" (95 % upper bound {bound:.3g}/h)" if alarms == 0 else ""),
        "",
        "Confusion (rows: true class; columns: class named at the alarm; '-' none):",
        "",
        "| true \\ named | " + " | ".join(FAULT_CLASSES) + " | - |",
        "| --- |" + " --- |" * (len(FAULT_CLASSES) + 1),
    ]
    for cls in FAULT_CLASSES:
        group = [r for r in runs if r.true_class == cls and r.alarm >= r.onset]
        counts = [sum(1 for r in group if r.fault_class == c) for c in FAULT_CLASSES]
        counts.append(sum(1 for r in group if r.fault_class not in FAULT_CLASSES))
        lines.append(f"| {cls} | " + " | ".join(map(str, counts)) + " |")
    lines += [
        "",
        "| class | ROC AUC (detection within 5 s vs healthy 5 s windows) |",
        "| --- | --- |",
    ]
    for cls in FAULT_CLASSES:
        lines.append(f"| {cls} | {roc(runs, cls)[2]:.3f} |")
    lines += ["", "Goals of issue 7:"]
    for cls, severity in GOALS:
        group = [r for r in runs if r.true_class == cls and r.severity == severity]
        on_time = sum(1 for r in group if 0.0 <= r.delay <= DELAY_GOAL)
        lines.append(f"- {cls} {severity:g}: {on_time}/{len(group)} detected within 5 s")
    lines.append(
        f"- false alarms in healthy data: {alarms} in {healthy_hours:.2f} h (goal: 0 in 10 h)"
    )
    return "\n".join(lines)


def plot(runs: list[Run], out: Path) -> list[Path]:
    """ROC curves per class and detection delays (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 5))
    for cls in FAULT_CLASSES:
        fpr, tpr, auc = roc(runs, cls)
        ax.step(fpr, tpr, where="post", label=f"{cls} (AUC {auc:.3f})")
    ax.plot([0, 1], [0, 1], "k:", lw=0.8)
    ax.set_xlabel("false-positive rate (healthy 5 s windows) [-]")
    ax.set_ylabel("true-positive rate (detected within 5 s) [-]")
    ax.set_title("ROC of fault detection per class")
    ax.legend(fontsize=7)
    fig.tight_layout()
    roc_png = out / "roc.png"
    fig.savefig(roc_png, dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(8, 4))
    for i, cls in enumerate(FAULT_CLASSES):
        delays = [r.delay for r in runs if r.true_class == cls and r.delay >= 0.0]
        ax.scatter(np.full(len(delays), i) + np.linspace(-0.2, 0.2, len(delays)), delays, s=8)
    ax.axhline(DELAY_GOAL, color="r", lw=1, label="goal 5 s")
    ax.set_xticks(range(len(FAULT_CLASSES)), FAULT_CLASSES, rotation=15, fontsize=8)
    ax.set_yscale("log")
    ax.set_ylabel("detection delay [s]")
    ax.legend()
    fig.tight_layout()
    delay_png = out / "delays.png"
    fig.savefig(delay_png, dpi=110)
    plt.close(fig)
    return [roc_png, delay_png]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``bench detection``."""
    parser.add_argument("--out", default=None, help="directory for detection.md, PNGs, JSON")
    parser.add_argument("--quick", action="store_true", help="smoke test: few, short runs")
    parser.add_argument(
        "--runs", type=int, default=2, help="seeds per class x severity x profile (0: none) [-]"
    )
    parser.add_argument(
        "--healthy-hours",
        type=float,
        default=1.0,
        help="hours of healthy data for the false-alarm rate [h]",
    )
    parser.add_argument(
        "--severity-scale",
        type=float,
        default=1.0,
        help="multiplies every severity (e.g. 0.1 to find the detection limits) [-]",
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of the plan (onsets, seeds)")
    parser.add_argument("--config", default=None, help="screw parameter YAML (default: paper)")


def run(args: argparse.Namespace) -> int:
    """Generate, detect, score; print the markdown report (and write it with --out)."""
    from tqdm import tqdm

    config = load_config(args.config)
    settings = MonitorSettings()
    predictor = shared_predictor(config, settings.residual)
    duration = 24.0 if args.quick else 30.0
    if args.runs < 0 or not (math.isfinite(args.healthy_hours) and args.healthy_hours >= 0.0):
        raise ConfigError(
            f"--runs = {args.runs} and --healthy-hours = {args.healthy_hours} h must be >= 0"
        )
    runs_per_case = 1 if args.quick else args.runs
    if not (math.isfinite(args.severity_scale) and args.severity_scale > 0.0):
        raise ConfigError(f"--severity-scale = {args.severity_scale} must be > 0")
    cases = plan(args.quick, runs_per_case, args.seed, args.severity_scale)
    healthy_hours = 1.0 / 60.0 if args.quick else args.healthy_hours
    segment = 60.0 if args.quick else 600.0
    n_healthy = math.ceil(healthy_hours * 3600.0 / segment) if healthy_hours > 0 else 0
    shapes = profiles(duration)
    runs: list[Run] = []
    for case in tqdm(cases, desc="fault runs", file=sys.stderr):
        scene = _scene(shapes[case["profile"]], duration, case["seed"], [case["fault"]], 0.1)
        runs.append(run_one(generate(scene), predictor, settings, case["profile"]))
    names = list(shapes)
    rng = np.random.default_rng(args.seed + 1)
    for k in tqdm(range(n_healthy), desc="healthy runs", file=sys.stderr):
        profile = names[k % len(names)]
        scene = _scene(profiles(segment)[profile], segment, int(rng.integers(0, 2**31)), [], 0.5)
        runs.append(run_one(generate(scene), predictor, settings, profile))
    hours = sum(r.duration - settings.warmup for r in runs if not r.true_class) / 3600.0
    text = report(runs, hours, settings)
    print(text)
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        (out / "detection.md").write_text(text + "\n")
        records = [
            {
                k: (None if isinstance(v, float) and math.isnan(v) else v)
                for k, v in r.__dict__.items()
            }
            for r in runs
        ]
        (out / "runs.json").write_text(json.dumps(records, indent=1) + "\n")
        for path in plot(runs, out):
            print(f"wrote {path}")
    return 0
