"""Smoke test of ``ballscrew-twin bench detection``: it runs (two units in two worker processes,
each commissioned on a recording of its own) and writes its outputs, with a comparison monitor
on the same recordings.

The recordings are shorter than ``--quick``'s (commissioning 25 s instead of 120 s, healthy 20 s
instead of 60 s, one fault run of 15 s instead of 30 s): the commissioning fit, which uses up
to 600 blocks, was two thirds of the time, and the outputs are the same files and tables
(122 s -> 24 s measured back to back).
"""

from __future__ import annotations

import argparse
import json
import math
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from ballscrew_twin.benchmarks import detection
from ballscrew_twin.benchmarks.detection import Run, false_alarm_upper_bound
from ballscrew_twin.cli import main
from ballscrew_twin.errors import ConfigError
from ballscrew_twin.health.baseline import Baseline
from ballscrew_twin.health.bench_data import BenchData, generate_unit_data
from ballscrew_twin.health.bench_units import draw_unit
from ballscrew_twin.health.classify import FAULT_CLASSES
from ballscrew_twin.health.commission import UNSEEN_ERROR
from ballscrew_twin.health.duty_cycles import draw_trajectory
from ballscrew_twin.health.fault_profiles import FaultSpec
from ballscrew_twin.health.monitor import HealthMonitor
from ballscrew_twin.health.monitor_settings import MonitorSettings
from ballscrew_twin.health.sensors import sensors_from_mapping
from ballscrew_twin.health.verdicts import FAULT, OK, UNKNOWN
from ballscrew_twin.params import TwinConfig, load_config

#: Two units, each: commissioning, healthy and one fault recording [s] (see the module doc).
PLAN = ["--units", "0:2", "--commission", "25", "--healthy", "20", "--faults", "1"]


def test_short_detection_benchmark_writes_its_tables_and_plots(tmp_path: Path) -> None:
    argv = ["bench", "detection", *PLAN, "--fault-length", "15", "--out", str(tmp_path)]
    compare = ["--compare-detectors", "cusum,spectral", "--compare-setting", "warn_fraction=0.6"]
    assert main([*argv, *compare]) == 0
    table = (tmp_path / "detection.md").read_text()
    assert "| class |" in table
    # the comparison monitor's report follows, on the same recordings (same hours of data)
    first, _, rest = table.partition("### The same recordings, detectors cusum, spectral only")
    second, _, third = rest.partition("### The same recordings, warn_fraction = 0.6")
    header = "| class | severity |"
    assert third and first.count(header) == second.count(header) == third.count(header) == 1
    hours = [line.split(" in ")[0] for line in table.splitlines() if line.startswith("Healthy")]
    assert len(hours) == 3 and len(set(hours)) == 1
    runs = json.loads((tmp_path / "runs.json").read_text())
    assert runs, "no run recorded"
    # each compared monitor's runs, paired with the default's, and its changes run by run
    compared = json.loads((tmp_path / "runs_compared.json").read_text())
    titles = ["detectors cusum, spectral only", "warn_fraction = 0.6"]
    assert [c["monitor"] for c in compared] == titles
    assert all([r["seed"] for r in c["runs"]] == [r["seed"] for r in runs] for c in compared)
    assert second.count("Runs judged otherwise than by the default") == 1
    assert third.count("Runs judged otherwise than by the default") == 1
    assert (tmp_path / "roc.png").stat().st_size > 0
    assert (tmp_path / "effects.png").stat().st_size > 0
    faulty = [r for r in runs if r["true_class"]]
    assert faulty and all(r["effect"] is not None and r["effect"] >= 0.0 for r in faulty)
    assert "by the fault's effect on the torque" in first
    assert "Fault runs not detected within 5 s" in first
    assert all("effect_compared" in r for r in faulty)
    assert all(r["window_error"] is None or r["window_error"] > 0.0 for r in faulty)
    assert all(r["window_sigma"] is None or r["window_sigma"] > 0.0 for r in faulty)


def _arguments(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    detection.add_arguments(parser)
    return parser.parse_args(list(argv))


def test_a_compared_setting_is_one_numeric_setting_changed() -> None:
    argv = ("--compare-setting", "classification_patience=8", "--compare-setting", "warmup=2")
    extra = detection.comparison_settings(_arguments(*argv))
    assert [title for title, _ in extra] == ["classification_patience = 8", "warmup = 2"]
    assert extra[0][1].settings.classification_patience == 8.0
    assert extra[1][1].settings.warmup == 2.0
    assert extra[0][1].commissioning == extra[1][1].commissioning == ()
    for bad, reason in (("detectors=cusum", "NAME"), ("warmup=soon", "VALUE"), ("x", "NAME")):
        with pytest.raises(ConfigError, match=reason):
            detection.comparison_settings(_arguments("--compare-setting", bad))
    with pytest.raises(ConfigError, match="warmup"):  # the settings' own check
        detection.comparison_settings(_arguments("--compare-setting", "warmup=-1"))


def test_a_compared_monitor_may_change_residual_settings_and_several_at_once() -> None:
    item = "residual.partial_share=1, cusum_min_weight=1"
    ((title, contender),) = detection.comparison_settings(_arguments("--compare-setting", item))
    settings = contender.settings
    assert title == "residual.partial_share = 1, cusum_min_weight = 1"
    assert settings.residual.partial_share == 1.0 and settings.cusum_min_weight == 1.0
    assert settings.residual.gate_angle == detection.MonitorSettings().residual.gate_angle
    with pytest.raises(
        ConfigError, match=r"partial_share = 2\.0 is outside the allowed range \(0, 1\]"
    ):
        detection.comparison_settings(_arguments("--compare-setting", "residual.partial_share=2"))


def test_a_compared_monitor_may_turn_a_switch() -> None:
    item = "unit_friction_responses=1"
    ((title, contender),) = detection.comparison_settings(_arguments("--compare-setting", item))
    assert title == "unit_friction_responses = 1"
    assert contender.settings.unit_friction_responses is True
    assert detection.MonitorSettings().unit_friction_responses is False
    with pytest.raises(ConfigError, match="unit_friction_responses is a switch: 0 or 1"):
        detection.comparison_settings(_arguments("--compare-setting", "unit_friction_responses=2"))


def test_a_compared_monitor_may_change_tracker_settings() -> None:
    item = "tracker.temperature_prior=1,tracker.temperature_drift=0.02"
    ((_, contender),) = detection.comparison_settings(_arguments("--compare-setting", item))
    settings = contender.settings
    assert settings.tracker.temperature_prior == 1.0
    assert settings.tracker.temperature_drift == 0.02
    assert settings.tracker.scale_drift == detection.MonitorSettings().tracker.scale_drift
    with pytest.raises(ConfigError, match="temperature_drift"):
        detection.comparison_settings(
            _arguments("--compare-setting", "tracker.temperature_drift=-1")
        )


def test_a_compared_monitor_may_change_its_units_commissioning() -> None:
    item = "commission.unseen_error=0.015, warmup=2, commission.error_scale=2"
    ((_, contender),) = detection.comparison_settings(_arguments("--compare-setting", item))
    assert contender.commissioning == (("error_scale", 2.0), ("unseen_error", 0.015))
    assert contender.settings == replace(MonitorSettings(), warmup=2.0)
    for bad in ("commission.unseen_error=0", "commission.error_scale=-1"):
        with pytest.raises(
            ConfigError, match=r"commission\.\w+ = -?[01]\.0 is outside the allowed range \(0, "
        ):
            detection.comparison_settings(_arguments("--compare-setting", bad))
    quantile = "commission.unseen_quantile=0.95"
    ((_, contender),) = detection.comparison_settings(_arguments("--compare-setting", quantile))
    assert contender.commissioning == (("unseen_quantile", 0.95),)
    with pytest.raises(
        ConfigError, match=r"unseen_quantile = 1\.5 is outside the allowed range \(0, 1\]"
    ):
        detection.comparison_settings(
            _arguments("--compare-setting", "commission.unseen_quantile=1.5")
        )
    with pytest.raises(ConfigError, match="NAME"):  # not a keyword of the commissioning
        detection.comparison_settings(_arguments("--compare-setting", "commission.source=1"))


def test_quick_asks_for_two_training_units_and_short_recordings() -> None:
    units, plan = detection.requested_plan(_arguments("--quick", "--units", "5000:5030"))
    assert units == range(2)  # --quick overrides --units: a smoke test on training units
    assert plan == detection.Plan(commission=120.0, healthy=60.0, faults=1, fault_length=30.0)
    units, plan = detection.requested_plan(_arguments(*PLAN))
    assert units == range(0, 2) and plan == detection.Plan(25.0, 20.0, 1, 60.0)
    _, plan = detection.requested_plan(_arguments(*PLAN, "--service", "300"))
    assert plan == detection.Plan(25.0, 20.0, 1, 60.0, service=300.0)


@pytest.mark.parametrize(
    "argv",
    [
        ("--faults", "-1"),
        ("--healthy", "10"),
        ("--commission", "5"),
        ("--units", "3:1"),
        ("--service", "5"),
        ("--service", "-20"),
    ],
)
def test_a_plan_that_cannot_run_is_refused_with_its_reason(argv: tuple[str, ...]) -> None:
    with pytest.raises(ConfigError):
        detection.requested_plan(_arguments(*argv))


@pytest.fixture(scope="module")
def paper() -> TwinConfig:
    return load_config(None)


def test_a_service_run_joins_the_commissioning_and_leaves_the_other_recordings_alone(
    paper: TwinConfig, monkeypatch: pytest.MonkeyPatch
) -> None:
    """With ``--service`` the unit is commissioned on two healthy recordings, the second an
    ambient run with seeds of its own, and beside it on the cold start alone; the healthy and
    fault recordings are those of the same plan without it (the two compare on the same
    runs)."""
    made: list[tuple[str, int, float, float]] = []
    fitted: list[int] = []
    generate = detection.generate_unit_data

    def recorded(*args: object, **kwargs: object) -> BenchData:
        trajectory = args[2]
        assert isinstance(trajectory, detection.Trajectory)
        name, seed = str(kwargs["name"]), int(kwargs["seed"])  # type: ignore[call-overload]
        made.append((name, seed, float(trajectory.time[-1]), float(trajectory.temperature[0])))
        return generate(*args, **kwargs)  # type: ignore[arg-type]

    def nominal(channels: list[object], config: TwinConfig, *_: object, **__: object) -> object:
        fitted.append(len(channels))
        return SimpleNamespace(baseline=Baseline.nominal(config))

    monkeypatch.setattr(detection, "generate_unit_data", recorded)
    monkeypatch.setattr(detection, "commission", nominal)
    plan = detection.Plan(commission=25.0, healthy=20.0, faults=1, fault_length=15.0)
    runs = {}
    for service in (0.0, 30.0):
        made.clear()
        runs[service] = (
            detection.run_unit(1, replace(plan, service=service), paper, (detection.Contender(),)),
            list(made),
        )
    assert fitted == [1, 2, 1]  # with the service run, and beside it the cold start alone
    without, with_service = runs[0.0][1], runs[30.0][1]
    names = [m[0] for m in with_service]
    assert names == ["commissioning", "service", "run", "run", "run"]
    assert with_service[1][2] == pytest.approx(30.0, abs=0.01)  # its length
    assert with_service[1][3] > 273.15 + 5.0  # ambient (10-35 C), not a cold start from <= 5 C
    assert [m for m in with_service if m[0] != "service"] == without
    # the same runs, scored alike by every monitor (each with the nominal baseline here)
    assert len(runs[0.0][0]) == 1 and len(runs[30.0][0]) == 2
    assert runs[0.0][0][0] == runs[30.0][0][0] == runs[30.0][0][1]


def test_each_set_of_commissioning_keywords_commissions_the_unit_once(
    paper: TwinConfig, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Monitors that differ only in their settings share one commissioning; a monitor with a
    commissioning keyword of its own gets the unit commissioned again with it, and its
    monitor runs on that baseline."""
    asked: list[dict[str, float]] = []
    used: list[float] = []

    def nominal(channels: list[object], config: TwinConfig, *_: object, **given: Any) -> object:
        del given["twin"]
        asked.append(given)
        unseen = given.get("unseen_error", UNSEEN_ERROR)
        return SimpleNamespace(baseline=replace(Baseline.nominal(config), unseen_error=unseen))

    class Seen(HealthMonitor):
        def __init__(self, *args: Any, baseline: Baseline, **kwargs: Any) -> None:
            used.append(baseline.unseen_error)
            super().__init__(*args, baseline=baseline, **kwargs)

    monkeypatch.setattr(detection, "commission", nominal)
    monkeypatch.setattr(detection, "HealthMonitor", Seen)
    plan = detection.Plan(commission=25.0, healthy=20.0, faults=0, fault_length=15.0)
    contenders = (
        detection.Contender(),
        detection.Contender(replace(MonitorSettings(), warmup=2.0)),
        detection.Contender(commissioning=(("unseen_error", 0.015),)),
        detection.Contender(commissioning=(("unseen_quantile", 0.9),)),
    )
    runs = detection.run_unit(1, plan, paper, contenders)
    # the default's commissioning passes no keyword: commission's own defaults hold
    assert asked == [{}, {"unseen_error": 0.015}, {"unseen_quantile": 0.9}]
    assert used == [UNSEEN_ERROR, UNSEEN_ERROR, 0.015, UNSEEN_ERROR]
    assert len(runs) == 4


@pytest.mark.parametrize("fault_class", FAULT_CLASSES)
def test_a_faults_effect_is_the_change_of_the_same_recording(
    paper: TwinConfig, fault_class: str
) -> None:
    """The clean counterpart of a fault recording draws the same noise, so the two agree
    before the onset and the difference after it is the fault's alone: zero for a fault too
    small to matter, and growing with the severity."""
    unit = draw_unit(3)
    trajectory = draw_trajectory(11, 12.0, kinds=("steps",))
    sensors = sensors_from_mapping(detection.SENSORS, "test sensors")

    def recording(severity: float | None) -> BenchData:
        faults = (
            ()
            if severity is None
            else (FaultSpec(fault_class=fault_class, onset=4.0, severity=severity, growth="step"),)
        )
        return generate_unit_data(paper, unit, trajectory, faults=faults, sensors=sensors, seed=5)

    clean = recording(None)
    small, large = (
        detection.fault_effect(recording(severity), clean)
        for severity in detection.SEVERITIES[fault_class]
    )
    assert 0.0 < small < large
    assert detection.fault_effect(recording(1e-9), clean) < 1e-6


def test_a_fault_effect_refuses_recordings_that_differ_before_the_onset(
    paper: TwinConfig,
) -> None:
    unit = draw_unit(3)
    trajectory = draw_trajectory(11, 12.0, kinds=("steps",))
    fault = FaultSpec(fault_class="preload_loss", onset=4.0, severity=0.1, growth="step")
    data = generate_unit_data(paper, unit, trajectory, faults=(fault,), seed=5)
    with pytest.raises(ConfigError, match="differ before the onset"):
        detection.fault_effect(data, generate_unit_data(paper, unit, trajectory, seed=6))
    with pytest.raises(ConfigError, match="needs a fault recording"):
        detection.fault_effect(data.__class__(**{**data.__dict__, "truth": {"faults": []}}), data)


def test_the_effect_where_compared_counts_only_the_flagged_samples(paper: TwinConfig) -> None:
    """A change of 1 % of the RMS torque over the window's first half and 3 % over its second
    (added to a clean recording by hand): 3 % where only the second half is compared, the RMS
    of both where all is, nan where nothing in the window is."""
    clean = generate_unit_data(
        paper, draw_unit(3), draw_trajectory(11, 12.0, kinds=("steps",)), seed=5
    )
    onset = 4.0
    t = clean.torque_time
    window = (t >= onset) & (t < onset + detection.DELAY_GOAL)
    size = math.sqrt(float(np.mean(clean.torque[window] ** 2)))
    second = window & (t >= onset + 0.5 * detection.DELAY_GOAL)
    change = np.where(second, 0.03, 0.01) * size * window
    truth = {"faults": [{"onset_s": onset}]}
    data = clean.__class__(**{**clean.__dict__, "torque": clean.torque + change, "truth": truth})
    assert detection.fault_effect(data, clean, second) == pytest.approx(0.03, rel=1e-9)
    both = math.sqrt(float(np.mean(np.where(second[window], 0.03, 0.01) ** 2)))
    assert detection.fault_effect(data, clean, np.ones_like(window)) == pytest.approx(both)
    assert detection.fault_effect(data, clean) == pytest.approx(both)
    assert math.isnan(detection.fault_effect(data, clean, t < onset))


def test_the_compared_samples_are_those_of_blocks_with_a_verdict() -> None:
    """Blocks of 0.1 s from 10.0 s (since the recording's start): the first compared, the
    second gated, the third compared on its stroke of the samples at 10.25, 10.27 and 10.29 s
    alone (mid time 10.27 s, span three sample intervals, 0.06 s); samples every 0.02 s from
    9.99 to 10.33."""
    start = detection.START_NS * 1e-9
    blocks = ((10.05, OK, math.nan), (10.15, UNKNOWN, math.nan), (10.27, FAULT, 0.06))
    monitor = SimpleNamespace(
        settings=MonitorSettings(),
        samples=[SimpleNamespace(time=start + t, verdict=v, span=w) for t, v, w in blocks],
    )
    data = SimpleNamespace(torque_time=9.99 + 0.02 * np.arange(18))
    flags = detection.compared_samples(monitor, data)  # type: ignore[arg-type]
    expected = [(10.0 <= t < 10.1 or 10.24 <= t <= 10.3) for t in data.torque_time]
    assert flags.tolist() == expected


def test_the_runs_not_detected_in_time_are_listed_with_both_effects() -> None:
    runs = [
        replace(
            _run("preload_loss", 0.02, math.nan),
            effect_compared=0.001,
            window_error=0.03,
            window_sigma=0.05,
            unit=7,
        ),
        replace(
            _run("jam_onset", 0.05, 6.5, window_gated=0.4),
            effect_compared=0.03,
            window_error=0.007,
            window_sigma=0.0125,
            unit=8,
        ),
        _run("jam_onset", 0.05, 1.0),
    ]
    table = detection._late_table(runs)
    assert table[0].startswith("Fault runs not detected within 5 s (2 of 3)")
    rows = [line for line in table if line.startswith("| ") and line[2].isdigit()]
    assert rows == [
        "| 8 | jam_onset | 0.1 | step | 6.50 | 5.00 | 3.00 | 0.70 | 1.25 | 40% |",
        "| 7 | preload_loss | 0.1 | step | never | 2.00 | 0.10 | 3.00 | 5.00 | 0% |",
    ]


def test_the_twin_error_of_a_window_is_the_rms_over_its_compared_blocks() -> None:
    """Four blocks after an onset at 10 s: two compared at 2 % and 1 % error, one gated and
    one past the window; the error is their RMS, sqrt((4 + 1) / 2) %, and nan with none."""
    start = detection.START_NS * 1e-9
    by_speed = {10.0: 0.02, 20.0: 0.01, 30.0: 0.5, 40.0: 0.5}
    baseline = SimpleNamespace(error_at=lambda speed, temperature: by_speed[speed])

    def block(at: float, speed: float, verdict: int) -> SimpleNamespace:
        point = SimpleNamespace(screw_speed=speed, temperature=300.0)
        return SimpleNamespace(time=start + at, verdict=verdict, operating_point=point)

    samples = [block(10.5, 10.0, OK), block(11.5, 20.0, FAULT), block(12.5, 30.0, UNKNOWN)]
    samples.append(block(10.0 + detection.DELAY_GOAL + 0.5, 40.0, OK))
    monitor = SimpleNamespace(baseline=baseline, samples=samples)
    error = detection._window_error(monitor, start, 10.0)  # type: ignore[arg-type]
    assert error == pytest.approx(math.sqrt((0.02**2 + 0.01**2) / 2.0), rel=1e-12)
    assert math.isnan(detection._window_error(monitor, start, 100.0))  # type: ignore[arg-type]


def test_the_sigma_of_a_window_is_residual_over_normalised_residual_on_the_prediction() -> None:
    """Blocks after an onset at 10 s: a residual of 2 and 1 mN m at 4 and 2 sigma on a
    predicted 0.1 N m (sigmas 0.5 %), one of -3 mN m at -1 sigma on 0.1 N m (3 %), one gated
    and one with a zero normalised residual (left out); the RMS of 0.5, 0.5 and 3 %."""
    start = detection.START_NS * 1e-9

    def block(at: float, residual: float, normalised: float, verdict: int) -> SimpleNamespace:
        return SimpleNamespace(
            time=start + at,
            verdict=verdict,
            residual=residual,
            normalized_residual=normalised,
            predicted=0.1,
        )

    samples = [
        block(10.5, 2e-3, 4.0, OK),
        block(11.0, 1e-3, 2.0, OK),
        block(11.5, -3e-3, -1.0, FAULT),
        block(12.0, 5e-3, 0.5, UNKNOWN),
        block(12.5, 0.0, 0.0, OK),
    ]
    monitor = SimpleNamespace(samples=samples)
    sigma = detection._window_sigma(monitor, start, 10.0)  # type: ignore[arg-type]
    assert sigma == pytest.approx(math.sqrt((0.005**2 * 2 + 0.03**2) / 3.0), rel=1e-12)
    assert math.isnan(detection._window_sigma(monitor, start, 100.0))  # type: ignore[arg-type]


def _run(true_class: str, effect: float, delay: float, window_gated: float = 0.0) -> Run:
    return Run(
        unit=0,
        seed=0,
        true_class=true_class,
        severity=0.1,
        growth="step",
        onset=20.0,
        duration=60.0,
        alarm=20.0 + delay,
        detector="cusum",
        fault_class=true_class,
        confidence=1.0,
        reason="",
        gated=0.0,
        compared=60.0,
        scores=(1.0,),
        effect=effect,
        window_gated=window_gated,
    )


def test_the_effect_table_counts_each_run_in_its_band() -> None:
    assert [detection.effect_band(e) for e in (0.0, 0.0029, 0.003, 0.02, 0.5)] == [0, 0, 1, 2, 3]
    runs = [
        _run("preload_loss", 0.001, math.nan),  # invisible, missed
        _run("preload_loss", 0.02, 1.0),  # within the goal
        _run("preload_loss", 0.02, 7.0),  # late
        _run("preload_loss", 0.05, 0.5, window_gated=0.95),  # blind in the window
        _run("jam_onset", 0.05, 0.2),
    ]
    table = detection._effect_table(runs)
    rows = {line.split(" | ")[0].strip("| "): line for line in table if line.startswith("| ")}
    assert rows["preload_loss"] == "| preload_loss | 0/1 | - | 1/2 | - | 1/1 |"
    assert rows["jam_onset"] == "| jam_onset | - | - | - | 1/1 | - |"
    assert rows["all"] == "| all | 0/1 | - | 1/2 | 1/1 | 1/1 |"


@pytest.mark.parametrize(
    ("alarms", "limit"),
    # the exact one-sided 95 % upper limits of a Poisson mean after 0, 1, 2 and 3 events
    # (Garwood 1936, as tabulated by Gehrels 1986, Table 1)
    [(0, 2.996), (1, 4.744), (2, 6.296), (3, 7.754)],
)
def test_the_false_alarm_rates_upper_bound_is_the_poisson_limit(alarms: int, limit: float) -> None:
    assert false_alarm_upper_bound(alarms, 10.0) == pytest.approx(limit / 10.0, rel=2e-3)


def test_no_healthy_hours_give_no_bound() -> None:
    assert math.isnan(false_alarm_upper_bound(0, 0.0))
