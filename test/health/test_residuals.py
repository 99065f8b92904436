"""Residual pipeline: alignment without look-ahead, cached predictions, noise estimate."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from ballscrew_twin.errors import ConfigError, SampleError, StampOrderError
from ballscrew_twin.health.residuals import (
    Block,
    BlockAligner,
    ResidualSettings,
    SlowSignal,
    TwinPredictor,
    within_block_variance,
)
from ballscrew_twin.models.base import OperatingPoint, TorqueBreakdown, TwinOutput
from ballscrew_twin.params import load_config


def test_slow_signal_interpolates_and_holds_but_never_extrapolates() -> None:
    signal = SlowSignal("speed", "rad/s")
    signal.add(0.0, 10.0)
    signal.add(1.0, 20.0)
    values = signal.at(np.array([-1.0, 0.25, 1.0, 5.0]))
    np.testing.assert_allclose(values, [10.0, 12.5, 20.0, 20.0])


def test_smoothing_is_a_causal_mean_of_the_recent_samples() -> None:
    signal = SlowSignal("preload", "N", smoothing=0.35)
    for t, v in [(0.0, 0.0), (0.1, 100.0), (0.2, 200.0), (0.3, 300.0), (0.4, 400.0)]:
        signal.add(t, v)
    # samples strictly inside (0.05, 0.4): 100, 200, 300, plus the value at 0.4 itself
    assert signal.at(np.array([0.4]))[0] == pytest.approx((100 + 200 + 300 + 400) / 4)


def test_bad_samples_are_named() -> None:
    aligner = BlockAligner(ResidualSettings())
    aligner.add_speed(1.0, 10.0)
    with pytest.raises(StampOrderError, match=r"speed: stamp 0\.5"):
        aligner.add_speed(0.5, 10.0)
    with pytest.raises(SampleError, match="temperature"):
        aligner.add_temperature(1.0, math.nan)
    aligner.add_torque(2.0, 0.01)
    with pytest.raises(StampOrderError, match="torque"):
        aligner.add_torque(1.9, 0.01)


def _feed_slow(aligner: BlockAligner, t: float) -> list[Block]:
    out = aligner.add_speed(t, 10.0 + t)
    out += aligner.add_temperature(t, 300.0)
    out += aligner.add_preload(t, 1500.0)
    return out


def test_a_block_waits_for_slow_signals_past_its_end_then_interpolates() -> None:
    settings = ResidualSettings(block_duration=0.1, max_wait=10.0, slow_smoothing=0.0)
    aligner = BlockAligner(settings)
    _feed_slow(aligner, 0.0)
    blocks: list[Block] = []
    for k in range(25):  # torque at 100 Hz over 0 .. 0.24 s
        blocks += aligner.add_torque(0.01 * k, 0.02)
    assert blocks == []  # slow signals only known at t = 0: nothing interpolable yet
    blocks = _feed_slow(aligner, 0.5)
    assert [b.index for b in blocks] == [0, 1]  # block 2 is still open
    first = blocks[0]
    np.testing.assert_allclose(first.speed, 10.0 + first.stamps)  # linear in time
    assert first.held == ()


def test_a_late_slow_signal_is_held_after_max_wait() -> None:
    settings = ResidualSettings(block_duration=0.1, max_wait=0.2, slow_smoothing=0.0)
    aligner = BlockAligner(settings)
    _feed_slow(aligner, 0.0)
    blocks: list[Block] = []
    for k in range(40):
        blocks += aligner.add_torque(0.01 * k, 0.02)
    # block 0 ends at 0.1 s; torque reached 0.3 s = end + max_wait: processed, values held
    assert blocks and blocks[0].index == 0
    assert set(blocks[0].held) == {"speed", "temperature", "preload"}
    np.testing.assert_allclose(blocks[0].speed, 10.0)


class LinearModel:
    """A fake twin whose torque is linear in each input (oracle of the first-order cache)."""

    name = "linear"

    def __init__(self) -> None:
        self.calls = 0

    def evaluate(self, op: OperatingPoint) -> TwinOutput:
        self.calls += 1
        torque = 1e-4 * op.screw_speed + 2e-5 * op.temperature + 1e-5 * op.preload
        return TwinOutput(
            drag_torque=torque,
            nut_torque=(torque / 2, torque / 2),
            breakdown=TorqueBreakdown(),
            fidelity=self.name,
            operating_point=op,
        )


def test_cached_prediction_is_exact_for_a_linear_twin_and_evaluates_once_per_cell() -> None:
    models: list[LinearModel] = []

    def factory(config: object) -> LinearModel:
        models.append(LinearModel())
        return models[-1]

    predictor = TwinPredictor(load_config(None), ResidualSettings(), factory)
    op = OperatingPoint(screw_speed=10.3, temperature=300.2, preload=1503.0)
    prediction = predictor.predict(op)
    exact = 1e-4 * 10.3 + 2e-5 * 300.2 + 1e-5 * 1503.0
    assert prediction.at(op) == pytest.approx(exact, rel=1e-9)
    assert prediction.preload_sensitivity == pytest.approx(1e-5)
    assert prediction.speed_sensitivity == pytest.approx(1e-4)
    assert prediction.temperature_sensitivity == pytest.approx(2e-5)
    calls = models[0].calls
    nearby = replace(op, preload=1502.0)  # same grid cell
    assert predictor.predict(nearby).at(nearby) == pytest.approx(exact - 1e-5, rel=1e-9)
    assert models[0].calls == calls


def test_within_block_variance_estimates_the_noise_around_a_trend() -> None:
    rng = np.random.default_rng(12)
    t = np.arange(400) / 200.0
    torque = 0.02 + 0.001 * t + rng.normal(0, 2e-4, t.size)
    block = Block(0, t, torque, np.full(t.size, 10.0), 300.0, 1500.0, ())
    variance = within_block_variance(block)
    assert variance is not None
    # sample variance of 400 normal values: relative standard error sqrt(2 / 398) = 7 %
    assert math.sqrt(variance) == pytest.approx(2e-4, rel=0.15)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("block_duration", 0.0),
        ("sensor_noise", -1.0),
        ("model_error_relative", math.inf),
        ("gate_angle", -1.0),
    ],
)
def test_bad_residual_settings_name_the_field(field: str, value: float) -> None:
    with pytest.raises(ConfigError, match=field):
        ResidualSettings(**{field: value})
