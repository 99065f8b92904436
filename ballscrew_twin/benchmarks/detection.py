"""``ballscrew-twin bench detection``: the health monitor on real duty cycles of real units.

Evaluation data must not be the model under test. Every run here is made by a **drawn unit**
(:mod:`ballscrew_twin.health.bench_units`: its own preload, viscosity, mu_dry and Eyring
stress within the production spreads, a torque sensor with gain and bias, its own inertia,
Dahl presliding through reversals and a Stribeck rise at low speed) driven through a
**random EMA duty cycle**
(:mod:`ballscrew_twin.health.duty_cycles`: sinusoidal position commands at 0.2-5 Hz,
trapezoidal moves with dwells, speed steps up to 3000 rpm, slow reversals; ambient or cold
start from -20 C), while the monitor predicts with the nominal real-time map commissioned to the
unit on a **separate** healthy recording of it (:mod:`ballscrew_twin.health.commission`).

Units are numbered; their number seeds the unit, its duty cycles, faults and noise. Tuning
(the monitor's error scale, gates, thresholds) may use only the training range
(``--units 0:30``); the reported figures come from the test range (``--units 2000:2030``, the
default), printed with the range. Units 1000-1029 were the test range of round 2 of issue 13;
their run list was read afterwards to see where misses fell, so they are no longer held out.
Per unit: one commissioning recording (``--commission`` s, a cold start warming through the
temperatures the unit will see: commission through a warm-up), one healthy recording
(``--healthy`` s, a new duty cycle, 1 in 4 a cold start) and ``--faults`` fault recordings
(``--fault-length`` s, onset uniform in the middle third) of the classes in turn at the
severities of :data:`SEVERITIES`. ``--service`` s adds a second healthy recording, an ambient
run of new duty cycles with seeds of its own, commissioned together with the first (every
other recording stays as it was: the two plans compare on the same runs). ``--compare-setting``
runs further monitors on the same recordings, each with a setting of the monitor changed or a
keyword of the commissioning (the unit is then commissioned again for that monitor).

Measured: false alarms per hour on the healthy recordings with their one-sided 95 % upper
bound (:func:`false_alarm_upper_bound`), the share of time gated; per class x severity:
detected within :data:`DELAY_GOAL` s, median and max delay, class named right; the confusion
matrix; ROC per class; the smallest severity detected in >= 95 % of runs; among alarms named
with confidence >= 0.9 the share right.

Which faults a torque monitor can see at all: every fault recording is generated a second time
without its fault (same duty cycle, same noise seed; the two are equal sample for sample
before the onset), and the fault's **effect** is the RMS of the difference of the measured
torque over the :data:`DELAY_GOAL` s after the onset relative to the RMS torque there. A
20 % thinner oil, for one, changes the paper screw's drag by less than 0.3 % near 30 rad/s
at 14 C and near 60 rad/s at 31 C (steady model, 1500 N): the thinner film's lower rolling
resistance (hydrodynamic, Eqs. 39-41) cancels its higher shear, spin and asperity friction.
No test on the torque finds it there. The report counts detections within the goal by bands
of effect (:data:`EFFECT_BANDS`), and apart the runs gated for most of that window; the
headline tables count every run. Each run also carries its **effect where compared**: the
same RMS over only the samples of that window whose block the monitor compared (not gated,
past its warm-up), over the same RMS torque; a fault that changes the torque only through a
reversal or near standstill has a large effect and a small one where compared. The runs not
detected within the goal are listed with both. ``--out DIR`` writes ``detection.md``, ``roc.png``,
``delays.png``, ``effects.png``, ``runs.json`` (with ``--compare-setting`` also
``runs_compared.json``, and in the report the runs each compared monitor judged otherwise:
:mod:`.detection_changes`). ``--quick``: two units, short recordings (a
smoke test, not a result).
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import multiprocessing
import sys
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, cast

import numpy as np
import numpy.typing as npt
from scipy.stats import chi2

from ..errors import ConfigError
from ..health.baseline import Baseline
from ..health.bench_data import START_NS, BenchData, generate_unit_data
from ..health.classify import FAULT_CLASSES
from ..health.commission import Channels, CommissionKeywords, commission
from ..health.duty_cycles import Trajectory, draw_trajectory
from ..health.fault_profiles import DEFAULT_GROWTH, FaultSpec
from ..health.monitor import HealthMonitor, feed
from ..health.monitor_settings import DETECTORS, MonitorSettings
from ..health.residuals import FloatArray, UnitTwin
from ..health.sensors import sensors_from_mapping
from ..health.verdicts import UNKNOWN, HealthSample
from ..params import TwinConfig, load_config
from .detection_changes import changes_report
from .detection_plan import (
    TRAINING_UNITS,
    Contender,
    Keywords,
    Plan,
    commissioning_trajectory,
    healthy_trajectory,
    unit_draw,
    with_preload,
)
from .detection_plan import add_arguments as add_arguments
from .detection_plan import comparison_settings as comparison_settings
from .detection_plan import requested_plan as requested_plan

#: One-line help of this benchmark.
DESCRIPTION = "fault detection on drawn units and EMA duty cycles, held-out test units"

#: Detection-delay goal of issue 13 [s].
DELAY_GOAL = 5.0
#: Severities per class: the goal's first (fraction lost; peak ripple relative to the torque;
#: rise of mu_dry and roughness), then twice it.
SEVERITIES: dict[str, tuple[float, ...]] = {
    "preload_loss": (0.05, 0.1),
    "lubricant_degradation": (0.2, 0.4),
    "raceway_defect": (0.02, 0.04),
    "sphere_defect": (0.02, 0.04),
    "jam_onset": (0.3, 0.6),
}
#: Share of a fault run's length gated from which the run counts as one the monitor is blind
#: to [-].
BLIND_SHARE = 0.9
#: Upper edges of the bands of a fault's effect on the torque in the reported table [-]: below
#: 0.3 % the change is under the resolution of the monitor's finest test (the local test's
#: floor, :data:`ballscrew_twin.health.memory.FLOOR`); 1-3 % is the commissioned twin's error
#: band where the commissioning saw the regime; above it a fault moves the torque by more than
#: the twin is trusted to anywhere it was commissioned.
EFFECT_BANDS = (0.003, 0.01, 0.03)
#: Confidence from which a named class is counted as a confident call [-].
CONFIDENT = 0.9
SENSORS = {
    "torque": {"rate": 1000.0, "noise": 2.0e-4, "bias": 0.0, "resolution": 1.0e-5},
    "speed": {"rate": 100.0, "noise": 0.01, "ripple": 0.005, "ripple_order": 1.0},
    "temperature": {"rate": 10.0, "noise": 0.05, "drift": 1.0e-3, "resolution": 0.01},
    "preload": {"rate": 20.0, "noise": 5.0, "bias": 0.0, "resolution": 0.5},
}


@dataclass(frozen=True)
class Run:
    """One recording through the monitor.

    Attributes:
        unit: unit number.
        kind: "healthy" or the fault class.
        seed: noise seed.
        true_class: fault class, "" for healthy.
        severity: fault severity [-].
        growth: growth profile of the fault.
        onset: true onset [s] (nan for healthy).
        duration: length of the recording [s].
        alarm: alarm time [s] since the start (nan: none).
        detector: detector that fired first.
        fault_class: class named by the monitor ("" unclassified).
        confidence: its confidence [-].
        reason: why no class was named.
        gated: time the monitor was gated [s].
        compared: time the monitor compared [s].
        scores: max statistic/threshold ratio per DELAY_GOAL window after the onset (fault
            runs: one value) or in each window (healthy runs) [-].
        effect: the fault's RMS change of the measured torque over DELAY_GOAL s after the
            onset relative to the RMS torque there without it [-] (nan for healthy runs).
        window_gated: share of those DELAY_GOAL s that the monitor was gated [-] (nan for
            healthy runs).
        effect_compared: the same RMS change over only the samples of that window in blocks
            the monitor compared, relative to the same RMS torque [-] (nan for healthy runs
            and when it compared none).
        window_error: RMS of the commissioned twin's 1-sigma relative error
            (:meth:`.Baseline.error_at`, which rises towards the unseen error where the
            residual surface was not taught) over the blocks of that window the monitor
            compared [-] (nan for healthy runs and when it compared none): an effect where
            compared well below about 2.5 times it cannot move the CUSUM.
        window_sigma: RMS of the monitor's whole 1-sigma over those blocks, relative to their
            predicted torque [-]: the steady error, the sensor noise and the transient terms
            (inertia, lag, near standstill: :meth:`.HealthMonitor.block_sigma`), read as
            residual / normalised residual (nan as ``window_error``).
    """

    unit: int
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
    reason: str
    gated: float
    compared: float
    scores: tuple[float, ...]
    effect: float = math.nan
    window_gated: float = math.nan
    effect_compared: float = math.nan
    window_error: float = math.nan
    window_sigma: float = math.nan

    @property
    def delay(self) -> float:
        """Alarm time minus true onset [s] (nan without alarm or for healthy runs)."""
        return self.alarm - self.onset


def channels_of(data: BenchData) -> dict[str, tuple[FloatArray, FloatArray]]:
    """The four channels of ``data`` with absolute stamps [s], as a bag of it would give them."""
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


def fault_effect(
    data: BenchData, clean: BenchData, compared: npt.NDArray[np.bool_] | None = None
) -> float:
    """The fault's RMS change of the measured torque over DELAY_GOAL s after its onset,
    relative to the RMS torque of ``clean`` (the same recording without the fault) there [-];
    with ``compared`` (one flag per torque sample, :func:`compared_samples`) the change's RMS
    is over the flagged samples of that window only (nan when none is), the RMS torque still
    over the whole window.

    Raises:
        ConfigError: ``data`` has no fault, or the recordings differ before the onset (then
            the difference is not the fault's).
    """
    faults = data.truth["faults"]
    if not faults or len(clean.torque) != len(data.torque):
        raise ConfigError("fault effect: needs a fault recording and its clean counterpart")
    onset = float(faults[0]["onset_s"])
    before = data.torque_time < onset
    if not np.array_equal(data.torque[before], clean.torque[before]):
        raise ConfigError("fault effect: the recordings differ before the onset")
    window = (data.torque_time >= onset) & (data.torque_time < onset + DELAY_GOAL)
    if not np.any(window):
        return math.nan
    size = math.sqrt(float(np.mean(clean.torque[window] ** 2)))
    counted = window if compared is None else window & compared
    if size <= 0.0 or not np.any(counted):
        return math.nan
    change = data.torque[counted] - clean.torque[counted]
    return math.sqrt(float(np.mean(change**2))) / size


def compared_samples(monitor: HealthMonitor, data: BenchData) -> npt.NDArray[np.bool_]:
    """Per torque sample of ``data`` that ``monitor`` ran over: whether it lies in a block the
    monitor compared with the twin (a verdict other than UNKNOWN: not gated, not in the
    warm-up) [-]. A block spans its mid time +- half its span (of the samples it compared: a
    block compared on its stroke past the gate spans less than the block duration)."""
    start = START_NS * 1e-9
    duration = monitor.settings.residual.block_duration
    mids = np.array([each.time - start for each in monitor.samples])
    looked = np.array([each.verdict != UNKNOWN for each in monitor.samples], dtype=bool)
    if len(mids) == 0:
        return np.zeros(len(data.torque_time), dtype=bool)
    spans = np.array([each.span for each in monitor.samples])
    half = 0.5 * np.where(np.isfinite(spans), spans, duration)
    block = np.clip(np.searchsorted(mids - half, data.torque_time, side="right") - 1, 0, None)
    inside = np.abs(data.torque_time - mids[block]) <= half[block]
    return inside & looked[block]


def _window_gated(monitor: HealthMonitor, start: float, onset: float) -> float:
    """Share of the DELAY_GOAL s after ``onset`` [s since ``start``] that were gated [-]."""
    block = monitor.settings.residual.block_duration
    gated = sum(
        block
        for s in monitor.samples
        if onset <= s.time - start < onset + DELAY_GOAL and s.note.startswith("gated")
    )
    return min(gated / DELAY_GOAL, 1.0)


def _compared_in_window(monitor: HealthMonitor, start: float, onset: float) -> list[HealthSample]:
    """The monitor's samples of the blocks it compared (a verdict other than UNKNOWN) in the
    DELAY_GOAL s after ``onset`` [s since ``start``]."""
    return [
        s
        for s in monitor.samples
        if onset <= s.time - start < onset + DELAY_GOAL and s.verdict != UNKNOWN
    ]


def _rms(values: list[float]) -> float:
    """Root mean square of ``values`` (nan when there are none)."""
    return math.sqrt(float(np.mean(np.square(values)))) if values else math.nan


def _window_error(monitor: HealthMonitor, start: float, onset: float) -> float:
    """RMS of the baseline's 1-sigma relative twin error over the blocks compared in the
    DELAY_GOAL s after ``onset`` [s since ``start``] [-] (nan when none was compared)."""
    points = [s.operating_point for s in _compared_in_window(monitor, start, onset)]
    error_at = monitor.baseline.error_at
    return _rms([error_at(p.screw_speed, p.temperature) for p in points if p is not None])


def _window_sigma(monitor: HealthMonitor, start: float, onset: float) -> float:
    """RMS of the monitor's 1-sigma relative to the predicted torque over the blocks compared
    in the DELAY_GOAL s after ``onset`` [s since ``start``] [-] (nan when none was)."""
    relative = [
        abs(s.residual / s.normalized_residual / s.predicted)
        for s in _compared_in_window(monitor, start, onset)
        if s.normalized_residual != 0.0 and s.predicted != 0.0
    ]
    return _rms([r for r in relative if math.isfinite(r)])


def score(
    data: BenchData,
    monitor: HealthMonitor,
    unit: int,
    warmup: float,
    effect: float = math.nan,
    effect_compared: float = math.nan,
) -> Run:
    """Score a monitor that has run over ``data`` (``effect`` and ``effect_compared``:
    :func:`fault_effect` over all and over the compared samples)."""
    start = START_NS * 1e-9
    times = np.array([s.time - start for s in monitor.samples])
    ratios = np.array(
        [
            max(
                (s.statistics[d][0] / s.statistics[d][1] for d in DETECTORS if d in s.statistics),
                default=0.0,
            )
            for s in monitor.samples
        ]
    )
    faults = data.truth["faults"]
    if faults:
        onset = float(faults[0]["onset_s"])
        scores: tuple[float, ...] = (_window_scores(times, ratios, onset, onset + DELAY_GOAL),)
    else:
        onset = math.nan
        edges = np.arange(warmup, data.duration - DELAY_GOAL + 1e-9, DELAY_GOAL)
        scores = tuple(_window_scores(times, ratios, a, a + DELAY_GOAL) for a in edges)
    alarm = monitor.alarm
    return Run(
        unit=unit,
        seed=data.seed,
        true_class=faults[0]["class"] if faults else "",
        severity=float(faults[0]["severity"]) if faults else 0.0,
        growth=str(faults[0]["growth"]) if faults else "",
        onset=onset,
        duration=data.duration,
        alarm=alarm.time - start if alarm else math.nan,
        detector=alarm.detector if alarm else "",
        fault_class=alarm.classification.fault_class if alarm else "",
        confidence=alarm.classification.confidence if alarm else 0.0,
        reason=alarm.classification.reason if alarm else "",
        gated=monitor.gated_time,
        compared=monitor.compared_time,
        scores=scores,
        effect=effect,
        window_gated=_window_gated(monitor, start, onset) if faults else math.nan,
        effect_compared=effect_compared,
        window_error=_window_error(monitor, start, onset) if faults else math.nan,
        window_sigma=_window_sigma(monitor, start, onset) if faults else math.nan,
    )


def _fault(number: int, k: int, length: float, rng: np.random.Generator) -> FaultSpec:
    cls = FAULT_CLASSES[(number + k) % len(FAULT_CLASSES)]
    severities = SEVERITIES[cls]
    severity = severities[(number // len(FAULT_CLASSES) + k) % len(severities)]
    growth = DEFAULT_GROWTH[cls]
    return FaultSpec(
        fault_class=cls,
        onset=float(rng.uniform(length / 3.0, 2.0 * length / 3.0)),
        severity=severity,
        growth=growth,
        growth_time=0.0 if growth == "step" else 1.0,
    )


def false_alarm_upper_bound(alarms: int, hours: float) -> float:
    """One-sided 95 % upper bound of a false-alarm rate [1/h] after ``alarms`` alarms in
    ``hours`` [h] of healthy data (exact Poisson, Garwood: chi-square quantile 0.95 with 2
    (alarms + 1) degrees of freedom over 2 hours; 3.00 / hours with none, 4.74 / hours with
    one); nan without data."""
    if not hours > 0.0:
        return math.nan
    return float(chi2.ppf(0.95, 2 * (alarms + 1))) / (2.0 * hours)


def run_unit(
    number: int, plan: Plan, config: TwinConfig, contenders: tuple[Contender, ...]
) -> list[list[Run]]:
    """Commission unit ``number`` on a recording of its own (and a service recording, see
    :class:`.detection_plan.Plan`), then run a monitor of each of ``contenders`` over its
    healthy and fault recordings (the same recordings for each: a side by side comparison;
    the unit commissioned once per distinct set of commissioning keywords); one list of runs
    per contender, and with a service recording one more: the first contender with the unit
    commissioned on its cold start alone."""
    twin = UnitTwin(config)
    sensors = sensors_from_mapping(SENSORS, "bench detection sensors")
    draw = unit_draw(number, plan.faults)
    unit, set_preload, seeds, rng = draw.unit, draw.preload, draw.seeds, draw.rng
    commissioning = commissioning_trajectory(draw, plan)
    healthy_recordings = [
        generate_unit_data(
            config, unit, commissioning, sensors=sensors, seed=seeds[1], name="commissioning"
        )
    ]
    if plan.service > 0.0:  # its own seeds: the plan of every other recording stays the same
        trajectory_seed, noise_seed = np.random.default_rng([number, 0x5E41CE]).integers(
            0, 2**31, 2
        )
        service = with_preload(
            draw_trajectory(int(trajectory_seed), plan.service, cold_start=False), set_preload
        )
        healthy_recordings.append(
            generate_unit_data(
                config, unit, service, sensors=sensors, seed=int(noise_seed), name="service"
            )
        )
    channels = [channels_of(data) for data in healthy_recordings]
    residual = contenders[0].settings.residual

    def commissioned(recordings: Sequence[Channels], keywords: Keywords) -> Baseline:
        # the names were checked against KEYWORD_LIMITS when the setting was parsed
        given = cast(CommissionKeywords, dict(keywords))
        return commission(recordings, config, residual, twin=twin, **given).baseline

    baselines: dict[Keywords, Baseline] = {}
    for each in contenders:
        if each.commissioning not in baselines:
            baselines[each.commissioning] = commissioned(channels, each.commissioning)
    monitors = [(each.settings, baselines[each.commissioning]) for each in contenders]
    if len(channels) > 1:  # beside it, on the same recordings: the cold start alone
        alone = commissioned(channels[:1], contenders[0].commissioning)
        monitors.append((contenders[0].settings, alone))
    runs: list[list[Run]] = [[] for _ in monitors]
    healthy = healthy_trajectory(draw, plan)
    recordings: list[tuple[Trajectory, tuple[FaultSpec, ...], int]] = [(healthy, (), seeds[2])]
    for k in range(plan.faults):
        trajectory = with_preload(draw_trajectory(seeds[3 + 2 * k], plan.fault_length), set_preload)
        recordings.append(
            (trajectory, (_fault(number, k, plan.fault_length, rng),), seeds[4 + 2 * k])
        )
    for trajectory, faults, seed in recordings:
        data = generate_unit_data(
            config, unit, trajectory, faults=faults, sensors=sensors, seed=seed, name="run"
        )
        clean = None
        effect = math.nan
        if faults:
            clean = generate_unit_data(
                config, unit, trajectory, sensors=sensors, seed=seed, name="run"
            )
            effect = fault_effect(data, clean)
        for k, (settings, used) in enumerate(monitors):
            monitor = HealthMonitor(config, settings, baseline=used, twin=twin)
            feed(monitor, channels_of(data))
            visible = math.nan
            if clean is not None:
                visible = fault_effect(data, clean, compared_samples(monitor, data))
            runs[k].append(score(data, monitor, number, settings.warmup, effect, visible))
    return runs


def _worker(job: tuple[int, Plan, TwinConfig, tuple[Contender, ...]]) -> list[list[Run]]:
    return run_unit(*job)


def run_units(
    units: range,
    plan: Plan,
    config: TwinConfig,
    contenders: tuple[Contender, ...],
    workers: int,
) -> Iterator[list[list[Run]]]:
    """Runs of every unit, in parallel processes when ``workers`` > 1."""
    jobs = [(n, plan, config, contenders) for n in units]
    if workers <= 1:
        yield from map(_worker, jobs)
        return
    context = multiprocessing.get_context("spawn")
    with context.Pool(workers) as pool:
        yield from pool.imap_unordered(_worker, jobs)


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


def report(runs: list[Run], units: range, plan: Plan, settings: MonitorSettings) -> str:
    """Markdown tables of the results."""
    healthy = [r for r in runs if not r.true_class]
    hours = sum(r.duration - settings.warmup for r in healthy) / 3600.0
    gated = sum(r.gated for r in runs)
    looked = sum(r.gated + r.compared for r in runs)
    lines = [
        f"Units {units.start}..{units.stop - 1} ({len(units)} units; tuning used only units "
        f"{TRAINING_UNITS[0]}..{TRAINING_UNITS[1] - 1}); per unit: commissioning "
        f"{plan.commission:g} s"
        + (f" + an ambient service run of {plan.service:g} s" if plan.service else "")
        + f", healthy {plan.healthy:g} s, {plan.faults} fault run(s) of "
        f"{plan.fault_length:g} s. Target false-alarm rate {settings.false_alarm_rate:g}/h, "
        f"warm-up {settings.warmup:g} s, blocks of {settings.residual.block_duration:g} s.",
        "",
        "| class | severity | runs | detected <= 5 s | missed | early | median delay [s] "
        "| max delay [s] | class right |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    smallest: dict[str, float] = {}
    for cls in FAULT_CLASSES:
        for severity in sorted({r.severity for r in runs if r.true_class == cls}):
            group = [r for r in runs if r.true_class == cls and r.severity == severity]
            delays = np.array([r.delay for r in group if r.delay >= 0.0])
            on_time = int(np.sum(delays <= DELAY_GOAL))
            missed = sum(1 for r in group if math.isnan(r.alarm))
            early = sum(1 for r in group if r.alarm < r.onset)
            right = sum(1 for r in group if r.fault_class == cls and r.alarm >= r.onset)
            detected = len(delays)
            if group and on_time >= 0.95 * len(group) and cls not in smallest:
                smallest[cls] = severity
            lines.append(
                f"| {cls} | {severity:g} | {len(group)} | {on_time} | {missed} | {early} | "
                f"{np.median(delays) if detected else math.nan:.2f} | "
                f"{np.max(delays) if detected else math.nan:.2f} | {right}/{detected} |"
            )
    alarms = sum(1 for r in healthy if not math.isnan(r.alarm))
    rate = alarms / hours if hours > 0 else math.nan
    bound = false_alarm_upper_bound(alarms, hours)
    faulty = [r for r in runs if r.true_class]
    before = sum(max(r.onset - settings.warmup, 0.0) for r in faulty) / 3600.0
    early = sum(1 for r in faulty if r.alarm < r.onset)
    lines += [
        "",
        f"Healthy data: {hours:.2f} h in {len(healthy)} recordings, {alarms} false alarm(s): "
        f"{rate:.3g}/h (95 % upper bound {bound:.3g}/h)",
        f"Before the onset of the fault runs: {before:.2f} h, {early} alarm(s) before the onset "
        f"(also false alarms; with the healthy data: {alarms + early} in {hours + before:.2f} h)",
        f"Time gated (near standstill or within the gate angle of a reversal): "
        f"{gated / max(looked, 1e-9):.1%} of the time after the warm-up.",
        "",
        "Smallest severity detected within 5 s in >= 95 % of its runs: "
        + (", ".join(f"{c} {v:g}" for c, v in smallest.items()) or "none"),
        "",
        "Confusion (rows: true class; columns: class named at the alarm; '-' unclassified):",
        "",
        "| true \\ named | " + " | ".join(FAULT_CLASSES) + " | - |",
        "| --- |" + " --- |" * (len(FAULT_CLASSES) + 1),
    ]
    for cls in FAULT_CLASSES:
        group = [r for r in runs if r.true_class == cls and r.alarm >= r.onset]
        counts = [sum(1 for r in group if r.fault_class == c) for c in FAULT_CLASSES]
        counts.append(sum(1 for r in group if r.fault_class not in FAULT_CLASSES))
        lines.append(f"| {cls} | " + " | ".join(map(str, counts)) + " |")
    by_detector: dict[str, list[int]] = {}
    for r in runs:
        if r.detector:
            counts = by_detector.setdefault(r.detector, [0, 0])
            counts[0 if r.true_class and r.alarm >= r.onset else 1] += 1
    blind = [r for r in faulty if r.gated >= BLIND_SHARE * r.duration]
    lines += [
        "",
        "First alarms by detector (fault runs after the onset / false alarms): "
        + ", ".join(f"{k} {v[0]}/{v[1]}" for k, v in sorted(by_detector.items())),
        f"Fault runs gated for >= {BLIND_SHARE:.0%} of their length (a duty cycle the monitor "
        f"is blind to: fast sines near standstill): {len(blind)} of {len(faulty)}, "
        f"{sum(1 for r in blind if math.isnan(r.alarm))} of them missed",
    ]
    lines += ["", *_effect_table(faulty), "", *_late_table(faulty)]
    confident = [r for r in runs if r.true_class and r.fault_class and r.confidence >= CONFIDENT]
    right = sum(1 for r in confident if r.fault_class == r.true_class)
    reasons: dict[str, int] = {}
    for r in runs:
        if r.true_class and not math.isnan(r.alarm) and not r.fault_class:
            key = r.reason.split(":")[0] if r.reason else "(none)"
            reasons[key] = reasons.get(key, 0) + 1
    lines += [
        "",
        f"Alarms named with confidence >= {CONFIDENT:g}: {len(confident)}, right: {right}"
        + (f" ({right / len(confident):.0%})" if confident else ""),
        "Unclassified alarms by reason: "
        + (", ".join(f"{k} ({v})" for k, v in reasons.items()) or "none"),
        "",
        "| class | ROC AUC (detection within 5 s vs healthy 5 s windows) |",
        "| --- | --- |",
    ]
    for cls in FAULT_CLASSES:
        lines.append(f"| {cls} | {roc(runs, cls)[2]:.3f} |")
    return "\n".join(lines)


def effect_band(effect: float) -> int:
    """Index of the band of :data:`EFFECT_BANDS` that ``effect`` [-] falls in (0 below the
    first edge, len(EFFECT_BANDS) above the last)."""
    return int(np.searchsorted(np.array(EFFECT_BANDS), effect, side="right"))


def _effect_table(faulty: list[Run]) -> list[str]:
    """Detections within DELAY_GOAL by class and band of the fault's effect on the torque, the
    runs gated for >= BLIND_SHARE of the window apart (markdown lines)."""
    edges = [100.0 * e for e in EFFECT_BANDS]
    labels = [
        f"< {edges[0]:g} %",
        *(f"{a:g}-{b:g} %" for a, b in itertools.pairwise(edges)),
        f">= {edges[-1]:g} %",
    ]
    lines = [
        f"Detected within {DELAY_GOAL:g} s by the fault's effect on the torque in the "
        f"{DELAY_GOAL:g} s after its onset (RMS change / RMS torque, from the same recording "
        f"without the fault); runs gated for >= {BLIND_SHARE:.0%} of those {DELAY_GOAL:g} s "
        "apart:",
        "",
        "| class | " + " | ".join(labels) + " | gated window |",
        "| --- |" + " --- |" * (len(labels) + 1),
    ]
    for name in (*FAULT_CLASSES, "all"):
        group = [r for r in faulty if name in ("all", r.true_class) and math.isfinite(r.effect)]
        cells = [[0, 0] for _ in range(len(labels) + 1)]
        for r in group:
            column = len(labels) if r.window_gated >= BLIND_SHARE else effect_band(r.effect)
            cells[column][0] += 0.0 <= r.delay <= DELAY_GOAL
            cells[column][1] += 1
        lines.append(f"| {name} | " + " | ".join(f"{a}/{n}" if n else "-" for a, n in cells) + " |")
    return lines


def _late_table(faulty: list[Run]) -> list[str]:
    """The fault runs not detected within DELAY_GOAL, each with its effect over the whole
    window and where compared, and the window's share gated (markdown lines)."""
    late = [r for r in faulty if not 0.0 <= r.delay <= DELAY_GOAL]
    lines = [
        f"Fault runs not detected within {DELAY_GOAL:g} s ({len(late)} of {len(faulty)}); "
        f"effect over the {DELAY_GOAL:g} s after the onset, and over the samples of it the "
        "monitor compared; the twin's steady 1-sigma error there after commissioning (RMS over "
        "the compared blocks; it rises towards the unseen error where the commissioning did "
        "not teach the residual surface), and the monitor's whole 1-sigma there (with the "
        "sensor noise and the transient and near-standstill terms):",
    ]
    if not late:
        return lines
    lines += [
        "",
        "| unit | fault class | severity | growth | delay [s] | effect [%] "
        "| effect where compared [%] | twin error there [%] | sigma there [%] | window gated |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in sorted(late, key=lambda r: (r.true_class, r.severity, r.unit)):
        delay = "never" if math.isnan(r.alarm) else f"{r.delay:.2f}"
        lines.append(
            f"| {r.unit} | {r.true_class} | {r.severity:g} | {r.growth} | {delay} | "
            f"{100.0 * r.effect:.2f} | {100.0 * r.effect_compared:.2f} | "
            f"{100.0 * r.window_error:.2f} | {100.0 * r.window_sigma:.2f} | "
            f"{r.window_gated:.0%} |"
        )
    return lines


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
    roc_png = _saved(fig, out / "roc.png")

    fig, ax = plt.subplots(figsize=(8, 4))
    for i, cls in enumerate(FAULT_CLASSES):
        delays = [r.delay for r in runs if r.true_class == cls and r.delay >= 0.0]
        ax.scatter(np.full(len(delays), i) + np.linspace(-0.2, 0.2, len(delays)), delays, s=8)
    ax.axhline(DELAY_GOAL, color="r", lw=1, label="goal 5 s")
    ax.set_xticks(range(len(FAULT_CLASSES)), FAULT_CLASSES, rotation=15, fontsize=8)
    ax.set_yscale("log")
    ax.set_ylabel("detection delay [s]")
    ax.legend()
    delay_png = _saved(fig, out / "delays.png")

    fig, ax = plt.subplots(figsize=(8, 5))
    faulty = [r for r in runs if r.true_class and math.isfinite(r.effect) and r.effect > 0.0]
    never = max((r.duration - r.onset for r in faulty), default=DELAY_GOAL) * 1.5
    for i, cls in enumerate(FAULT_CLASSES):
        group = [r for r in faulty if r.true_class == cls]
        effect = np.array([100.0 * r.effect for r in group])
        delay = np.array([r.delay if r.delay >= 0.0 else never for r in group])
        hollow = np.array([r.window_gated >= BLIND_SHARE for r in group], dtype=bool)
        ax.scatter(effect[~hollow], delay[~hollow], s=14, color=f"C{i}", label=cls)
        ax.scatter(effect[hollow], delay[hollow], s=30, facecolors="none", edgecolors=f"C{i}")
    ax.axhline(DELAY_GOAL, color="r", lw=1, label=f"goal {DELAY_GOAL:g} s")
    ax.axhline(never, color="k", lw=0.6, ls=":", label="never (or before the onset)")
    for edge in EFFECT_BANDS:
        ax.axvline(100.0 * edge, color="0.7", lw=0.6)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(f"fault's effect: RMS torque change in the {DELAY_GOAL:g} s after onset [%]")
    ax.set_ylabel("detection delay [s] (hollow: gated >= 90 % of those seconds)")
    ax.legend(fontsize=7)
    return [roc_png, delay_png, _saved(fig, out / "effects.png")]


def _saved(fig: Any, path: Path) -> Path:
    """Lay out ``fig``, write it to ``path`` (PNG) and close it."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _records(runs: Sequence[Run]) -> list[dict[str, object]]:
    """``runs`` as JSON records (NaN as null)."""
    return [
        {k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in r.__dict__.items()}
        for r in runs
    ]


def run(args: argparse.Namespace) -> int:
    """Generate, commission, detect, score; print the markdown report (and write it)."""
    from tqdm import tqdm

    config = load_config(args.config)
    extra = comparison_settings(args)
    contenders = (Contender(), *(each for _, each in extra))
    units, plan = requested_plan(args)
    reported = [(title, each.settings, plan) for title, each in extra]
    if plan.service:
        alone = replace(plan, service=0.0)
        reported.append(
            ("the unit commissioned on its cold start alone", contenders[0].settings, alone)
        )
    every: list[list[Run]] = [[] for _ in range(1 + len(reported))]
    for unit_runs in tqdm(
        run_units(units, plan, config, contenders, args.workers),
        total=len(units),
        desc="units",
        file=sys.stderr,
    ):
        for k, each in enumerate(unit_runs):
            every[k].extend(each)
    runs = every[0]
    text = report(runs, units, plan, contenders[0].settings)
    for (title, each, used), other in zip(reported, every[1:], strict=True):
        text += f"\n\n### The same recordings, {title}\n\n" + report(other, units, used, each)
        text += "\n\n" + changes_report(runs, other)
    print(text)
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        (out / "detection.md").write_text(text + "\n")
        (out / "runs.json").write_text(json.dumps(_records(runs), indent=1) + "\n")
        if reported:
            compared = [
                {"monitor": title, "runs": _records(other)}
                for (title, _, _), other in zip(reported, every[1:], strict=True)
            ]
            (out / "runs_compared.json").write_text(json.dumps(compared, indent=1) + "\n")
        for path in plot(runs, out):
            print(f"wrote {path}")
    return 0
