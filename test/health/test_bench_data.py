"""Bench-data generator: statistics against the steady model, faults, samples, scenes, CLI."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from ballscrew_twin.bags.bench import read_bench_bag
from ballscrew_twin.bags.recording import truth_path
from ballscrew_twin.cli import main as cli_main
from ballscrew_twin.commands.bench_data import generate_bag
from ballscrew_twin.errors import ConfigError
from ballscrew_twin.health.bench_data import (
    SAMPLE_DIR,
    SAMPLE_NAMES,
    SCENE_DIR,
    generate,
)
from ballscrew_twin.health.bench_scene import bench_scene_from_mapping, load_bench_scene
from ballscrew_twin.health.fault_profiles import FAULT_CLASSES, defect_frequencies
from ballscrew_twin.models.base import OperatingPoint
from ballscrew_twin.models.steady import SteadyStateModel
from ballscrew_twin.params import TwinConfig, load_config

CONFIG = load_config()
SPEED, TEMPERATURE, PRELOAD = 10.0, 300.0, 1200.0  # rad/s, K, N
SENSORS = {
    "torque": {"rate": 500.0, "noise": 2e-4, "bias": 3e-4, "resolution": 1e-6},
    "speed": {"rate": 100.0, "noise": 0.01, "ripple": 0.0},
    "temperature": {"rate": 20.0, "noise": 0.05, "drift": 2e-3, "resolution": 0.001},
    "preload": {"rate": 50.0, "noise": 5.0, "bias": 10.0, "resolution": 0.1},
}


def _scene(faults: list[dict[str, Any]] | None = None, duration: float = 4.0, **extra: Any) -> Any:
    data = {
        "name": "constant",
        "duration": duration,
        "model_step": 0.5,
        "profile": [{"time": 0.0, "speed": SPEED, "temperature": TEMPERATURE, "preload": PRELOAD}],
        "sensors": SENSORS,
        "faults": faults or [],
        **extra,
    }
    return bench_scene_from_mapping(data, "constant.yaml")


def _steady(config: TwinConfig, preload: float = PRELOAD) -> float:
    """Drag torque of the steady model at the test's operating point [N m] (the oracle)."""
    op = OperatingPoint(screw_speed=SPEED, temperature=TEMPERATURE, preload=preload)
    return SteadyStateModel(config).evaluate(op).drag_torque


def _mean_within(values: np.ndarray, expected: float, sigma: float) -> None:
    """Mean of white-noise samples equals ``expected`` within 5 standard errors."""
    assert abs(values.mean() - expected) < 5.0 * sigma / math.sqrt(len(values)) + 1e-12


def test_healthy_channels_have_the_models_values_plus_the_sensor_errors() -> None:
    data = generate(_scene(), seed=11)
    expected = _steady(CONFIG) + SENSORS["torque"]["bias"]
    _mean_within(data.torque, expected, SENSORS["torque"]["noise"])
    assert data.torque.std() == pytest.approx(SENSORS["torque"]["noise"], rel=0.1)
    assert len(data.torque) == 2000 and np.allclose(np.diff(data.torque_time), 1 / 500.0)
    _mean_within(data.speed, SPEED, 0.01)
    np.testing.assert_allclose(data.angle, SPEED * data.speed_time, atol=2 * math.pi / 4096)
    drift = TEMPERATURE + 2e-3 * data.temperature_time
    _mean_within(data.temperature - drift, 0.0, 0.05)
    _mean_within(data.preload, PRELOAD + 10.0, 5.0)


def test_same_seed_same_bag_other_seed_other_noise() -> None:
    a, b, c = (generate(_scene(duration=1.0), seed=s) for s in (5, 5, 6))
    np.testing.assert_array_equal(a.torque, b.torque)
    np.testing.assert_array_equal(a.temperature, b.temperature)
    assert not np.array_equal(a.torque, c.torque)
    assert a.truth["seed"] == 5 and c.truth["seed"] == 6


def _lubricant(config: TwinConfig, factor: float) -> TwinConfig:
    lub = config.lubricant
    return replace(
        config,
        lubricant=replace(
            lub,
            viscosity_reference=factor * lub.viscosity_reference,
            viscosity_second=factor * lub.viscosity_second,
        ),
    )


def _debris(config: TwinConfig, factor: float) -> TwinConfig:
    """Boundary friction and both roughnesses x factor (the jam_onset change)."""
    contact = replace(
        config.contact,
        dry_friction_coefficient=factor * config.contact.dry_friction_coefficient,
    )
    screw = replace(
        config.screw,
        ball_roughness=factor * config.screw.ball_roughness,
        groove_roughness=factor * config.screw.groove_roughness,
    )
    return replace(config, contact=contact, screw=screw)


@pytest.mark.parametrize(
    ("fault", "oracle"),
    [
        ("preload_loss", lambda: _steady(CONFIG, preload=0.75 * PRELOAD)),
        ("lubricant_degradation", lambda: _steady(_lubricant(CONFIG, 0.75))),
        ("jam_onset", lambda: _steady(_debris(CONFIG, 1.25))),
    ],
)
def test_step_fault_changes_the_torque_to_the_faulted_models(fault: str, oracle: Any) -> None:
    spec = {"class": fault, "onset": 2.0, "severity": 0.25, "growth": "step"}
    data = generate(_scene([spec]), seed=2)
    bias, noise = SENSORS["torque"]["bias"], SENSORS["torque"]["noise"]
    before = data.torque[data.torque_time < 2.0]
    after = data.torque[data.torque_time >= 2.0]
    _mean_within(before, _steady(CONFIG) + bias, noise)
    _mean_within(after, oracle() + bias, noise)
    # the load cell reads the set preload whatever the contacts carry
    _mean_within(data.preload, PRELOAD + 10.0, 5.0)
    assert data.truth["faults"] == [
        {"class": fault, "onset_s": 2.0, "severity": 0.25, "growth": "step", "growth_time_s": 0.0}
        | ({"starvation": 0.0, "roughness_increase": 0.0} if fault.startswith("lub") else {})
    ]


def test_raceway_defect_puts_a_line_at_the_nut_raceway_frequency() -> None:
    spec = {"class": "raceway_defect", "onset": 0.0, "severity": 0.2, "growth": "step"}
    data = generate(_scene([spec]), seed=4)
    x = data.torque - data.torque.mean()
    spectrum = np.abs(np.fft.rfft(x)) * 2.0 / len(x)
    freqs = np.fft.rfftfreq(len(x), 1.0 / 500.0)
    s = CONFIG.screw
    g = s.ball_radius * math.cos(s.nominal_contact_angle) / s.pitch_radius
    expected = s.balls_per_nut / s.loaded_turns * SPEED / 2.0 * (1.0 - g) / (2.0 * math.pi)
    k = int(np.argmax(spectrum))
    assert abs(freqs[k] - expected) <= 1.0 / 4.0
    # raised cosine of peak 0.2 |T|: fundamental 0.1 |T| (leakage: the peak bin holds most)
    assert spectrum[k] == pytest.approx(0.1 * abs(_steady(CONFIG)), rel=0.3)


def test_defect_faster_than_half_the_torque_rate_is_refused() -> None:
    spec = {"class": "sphere_defect", "onset": 0.0, "severity": 0.1, "growth": "step"}
    scene = _scene([spec])
    fast = replace(scene, profile=(replace(scene.profile[0], speed=400.0),))
    assert defect_frequencies(CONFIG, 400.0)["sphere_spin"] > 250.0
    with pytest.raises(ConfigError, match=r"sphere_defect ripple .* raise sensors.torque.rate"):
        generate(fast)


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"colour": 1}, r"unknown key\(s\) \['colour'\]"),
        ({"duration": -1.0}, r"duration = -1.0 is outside"),
        ({"duration": 0.0}, r"duration = 0.0 is outside the allowed range \(0, 36000\] s"),
        (
            {"profile": [{"time": 0.0, "speed": 1.0, "temperature": 20.0, "preload": 1.0}]},
            r"profile\[0\].temperature = 20.0 is outside .* K",
        ),
        (
            {
                "profile": [
                    {"time": 0.0, "speed": 1.0, "temperature": 300.0, "preload": 1.0},
                    {"time": 0.0, "speed": 1.0, "temperature": 300.0, "preload": 1.0},
                ]
            },
            r"profile\[1\].time = 0.0 s is not after",
        ),
        (
            {"faults": [{"class": "jam_onset", "onset": 9.0, "severity": 1.0, "growth": "step"}]},
            r"faults\[0\].onset = 9.0 s is not before the end",
        ),
        ({"profile": []}, r"profile needs at least one point"),
        ({"seed": -3}, r"seed must be a whole number"),
    ],
)
def test_scene_errors_name_the_file_and_the_field(change: dict[str, Any], match: str) -> None:
    data = {
        "name": "x",
        "duration": 4.0,
        "profile": [{"time": 0.0, "speed": 1.0, "temperature": 300.0, "preload": 1.0}],
    }
    with pytest.raises(ConfigError, match=match) as err:
        bench_scene_from_mapping(data | change, "bad.yaml")
    assert "bad.yaml" in str(err.value)


def test_profile_is_piecewise_linear_and_held_after_the_last_point() -> None:
    scene = bench_scene_from_mapping(
        {
            "name": "p",
            "duration": 10.0,
            "profile": [
                {"time": 0.0, "speed": 0.0, "temperature": 300.0, "preload": 100.0},
                {"time": 2.0, "speed": 20.0, "temperature": 310.0, "preload": 300.0},
            ],
        },
        "p.yaml",
    )
    times = [1.0, 2.0, 9.0]
    speed, temperature, preload = scene.profile_at(times)
    np.testing.assert_allclose(speed, [10.0, 20.0, 20.0])
    np.testing.assert_allclose(temperature, [305.0, 310.0, 310.0])
    np.testing.assert_allclose(preload, [200.0, 300.0, 300.0])
    # the very arithmetic of numpy's interpolation, which the seeded recordings were made with
    np.testing.assert_array_equal(temperature, np.interp(times, [0.0, 2.0], [300.0, 310.0]))


# ---------------------------------------------------------------------------------------------
# Committed samples


def test_every_sample_bag_is_small_readable_and_labelled() -> None:
    for name in SAMPLE_NAMES:
        bag = SAMPLE_DIR / name
        size = sum(f.stat().st_size for f in bag.iterdir())
        assert size < 1_000_000, f"{bag}: {size} bytes"
        rec = read_bench_bag(bag, required=("torque", "speed", "temperature", "preload"))
        assert rec.issues == ()
        assert rec.duration == pytest.approx(20.0, abs=0.01)
        classes = [f["class"] for f in rec.truth["faults"]] if rec.truth else None
        assert classes == ([] if name == "healthy" else [name])
        assert name == "healthy" or name in FAULT_CLASSES
        scene = load_bench_scene(SCENE_DIR / f"{name}.yaml")
        assert rec.truth is not None and rec.truth["seed"] == scene.seed


def test_a_regenerated_sample_equals_the_committed_one(tmp_path: Path) -> None:
    name = "preload_loss"
    generate_bag(SCENE_DIR / f"{name}.yaml", tmp_path / name)
    new = read_bench_bag(tmp_path / name)
    old = read_bench_bag(SAMPLE_DIR / name)
    assert new.truth == old.truth
    assert json.loads(truth_path(tmp_path / name).read_text()) == json.loads(
        truth_path(SAMPLE_DIR / name).read_text()
    )
    steps = {"torque": 1e-5, "speed": 1e-12, "angle": 2 * math.pi / 4096,
             "temperature": 0.01, "preload": 0.5}  # fmt: skip
    for channel, step in steps.items():
        a, b = new.series(channel), old.series(channel)
        np.testing.assert_array_equal(a.time, b.time)
        # equal up to one quantisation step (round-off of the solver across machines)
        np.testing.assert_allclose(a.value, b.value, rtol=0.0, atol=step * 1.0001)


# ---------------------------------------------------------------------------------------------
# Command line


def test_cli_generate_info_and_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scene = tmp_path / "s.yaml"
    scene.write_text(
        "name: s\nduration: 1.0\nprofile:\n"
        "  - {time: 0.0, speed: 10.0, temperature: 300.0, preload: 1000.0}\n"
        "faults:\n  - {class: preload_loss, onset: 0.5, severity: 0.1, growth: step}\n"
    )
    out = tmp_path / "bag"
    plot = tmp_path / "bag.png"
    args = ["bench-data", "generate", "--scene", str(scene), "--out", str(out), "--seed", "9"]
    assert cli_main([*args, "--plot", str(plot)]) == 0
    assert plot.stat().st_size > 0
    assert json.loads(truth_path(out).read_text())["seed"] == 9
    assert cli_main(["bench-data", "info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "torque" in text and "preload_loss" in text
    assert cli_main(args) == 2  # the bag exists already
    assert "exists already" in capsys.readouterr().err
    scene.write_text("name: s\nduration: 1.0\nprofile: []\n")
    assert cli_main([*args[:-4], "--out", str(tmp_path / "other")]) == 2
    assert "profile needs at least one point" in capsys.readouterr().err
