"""Detectors: thresholds from a false-alarm rate, checked against tables and by simulation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import binom

from ballscrew_twin.errors import ConfigError
from ballscrew_twin.health.detectors import (
    Cusum,
    OrderSpectralTest,
    WindowChiSquare,
    arl0_from_rate,
    cusum_threshold,
    effective_revolutions,
    floor_offsets,
    local_noise_variance,
    order_test_weights,
    siegmund_arl0,
)


def test_siegmund_matches_the_textbook_arl_of_k_half_h_four() -> None:
    # Montgomery, Introduction to Statistical Quality Control, Table 9.3: one-sided
    # ARL0 of k = 0.5, h = 4 is 336 (two-sided 168).
    assert siegmund_arl0(0.5, 4.0) == pytest.approx(336.0, rel=0.02)
    assert cusum_threshold(0.5, 336.0) == pytest.approx(4.0, abs=0.02)


def test_arl0_is_the_expected_samples_between_false_alarms() -> None:
    # 10 Hz, one false alarm per hour -> 36000 samples between false alarms.
    assert arl0_from_rate(1.0, 10.0) == pytest.approx(36000.0)


def _run_lengths(cusum: Cusum, chains: int, rng: np.random.Generator) -> np.ndarray:
    """Samples to the first alarm of ``chains`` independent in-control runs (vectorised)."""
    upper = np.zeros(chains)
    lower = np.zeros(chains)
    length = np.zeros(chains)
    alive = np.ones(chains, dtype=bool)
    step = 0
    while alive.any():
        step += 1
        e = rng.standard_normal(chains)
        upper = np.maximum(0.0, upper + e - cusum.k)
        lower = np.maximum(0.0, lower - e - cusum.k)
        fired = alive & ((upper > cusum.threshold) | (lower > cusum.threshold))
        length[fired] = step
        alive &= ~fired
    return length


def test_two_sided_cusum_false_alarm_rate_is_verified_by_simulation() -> None:
    # Target: 72 false alarms per hour at 10 Hz -> ARL0 = 500 samples (both sides together).
    cusum = Cusum(shift=1.0, false_alarm_rate=72.0, sample_rate=10.0)
    lengths = _run_lengths(cusum, 3000, np.random.default_rng(1))
    # Siegmund's approximation is accurate to a few per cent; the mean of 3000 geometric-like
    # run lengths has a relative standard error of ~2 %.
    assert np.mean(lengths) == pytest.approx(500.0, rel=0.1)


def test_cusum_class_matches_the_vectorised_recursion_and_finds_the_change() -> None:
    cusum = Cusum(shift=2.0, false_alarm_rate=1.0, sample_rate=10.0)
    rng = np.random.default_rng(2)
    data = np.concatenate([rng.standard_normal(300), rng.standard_normal(100) - 2.0])
    alarm_at = None
    for i, e in enumerate(data):
        step = cusum.update(float(e))
        if step.alarm:
            alarm_at, change = i, step.change_index
            assert step.direction == -1
            break
    assert alarm_at is not None and 300 <= alarm_at < 330
    # The change-point estimate of the CUSUM is within a few samples of the true change.
    assert abs(change + 1 - 300) <= 5


def test_chi_square_false_alarm_probability_by_simulation() -> None:
    # p per test = rate / (3600 f) = 0.02 at rate 72/h, f = 1 Hz.
    test = WindowChiSquare(window=10, false_alarm_rate=72.0, sample_rate=1.0)
    rng = np.random.default_rng(3)
    sums = np.sum(rng.standard_normal((20000, 10)) ** 2, axis=1)
    hits = int(np.sum(sums > test.threshold))
    low, high = binom.interval(0.999, 20000, 0.02)
    assert low <= hits <= high


def test_chi_square_window_fills_before_testing() -> None:
    test = WindowChiSquare(window=3, false_alarm_rate=1.0, sample_rate=1.0)
    assert test.update(100.0) == (0.0, False)
    assert test.update(0.0) == (0.0, False)
    stat, alarm = test.update(0.0)
    assert stat == pytest.approx(1e4) and alarm


def _angles(n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Sample times [s] at 200 Hz and screw angles of a speed ramp 10 -> 20 rad/s."""
    t = np.arange(n) / 200.0
    speed = 10.0 + 10.0 * t / t[-1]
    angle = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(t))])
    return t, angle + rng.uniform(0, 2 * math.pi)


def test_order_test_false_alarm_rate_on_white_noise_by_simulation() -> None:
    # p = 0.05 per order: 1 test per second of 3 orders -> rate = 0.05 * 3600 * 3 per hour.
    test = OrderSpectralTest(false_alarm_rate=0.05 * 3600 * 3, test_rate=1.0, orders_per_test=3)
    rng = np.random.default_rng(4)
    t, angle = _angles(800, rng)
    orders = np.array([4.94, 6.14, 8.14])
    trials = 1000
    ratios = test.test(rng.standard_normal((len(t), trials)), angle, orders).ratios
    hits = int(np.sum(ratios > test.threshold))
    low, high = binom.interval(0.999, trials * 3, 0.05)
    assert low <= hits <= high


def test_order_test_finds_a_ripple_that_follows_the_speed() -> None:
    test = OrderSpectralTest(false_alarm_rate=0.01, test_rate=1.0, orders_per_test=3)
    rng = np.random.default_rng(5)
    t, angle = _angles(800, rng)
    amplitude = 0.5  # sigma of the noise is 1: expected power ratio A^2 N / 2 = 100
    x = rng.standard_normal(len(t)) + amplitude * np.cos(6.14 * angle + 0.4)
    result = test.test(x, angle, np.array([4.94, 6.14, 8.14]))
    assert result.ratios[1] > test.threshold
    assert result.ratios[0] < test.threshold and result.ratios[2] < test.threshold
    # 2 |X| / N estimates the amplitude (noise contributes ~ 2 / sqrt(N) = 0.07).
    assert result.amplitudes[1] == pytest.approx(amplitude, abs=0.15)


def test_effective_revolutions_is_the_span_of_the_angle_that_holds_the_power() -> None:
    turn = 2.0 * math.pi
    angle = np.linspace(0.0, 10.0 * turn, 20001)
    even = np.ones_like(angle)
    assert effective_revolutions(even, angle) == pytest.approx(10.0, rel=0.01)
    # nine times the power per radian over the first turn: (9 + 9)^2 / (81 + 9) = 3.6
    first_turn_loud = np.where(angle < turn, 9.0, 1.0)
    assert effective_revolutions(first_turn_loud, angle) == pytest.approx(3.6, rel=0.02)
    # five strokes back and forth over the same two turns resolve two turns, not ten
    strokes = 2.0 * turn * np.abs(((np.linspace(0.0, 5.0, 20001) + 1.0) % 2.0) - 1.0)
    assert effective_revolutions(even, strokes) == pytest.approx(2.0, rel=0.02)


def test_local_noise_variance_follows_a_loud_stretch() -> None:
    rng = np.random.default_rng(8)
    x = rng.standard_normal(4000)
    x[2000:2400] *= 10.0
    variance = local_noise_variance(x, 50)
    assert np.median(variance[:1900]) == pytest.approx(1.0, rel=0.1)
    assert np.median(variance[2050:2350]) == pytest.approx(100.0, rel=0.15)
    with pytest.raises(ConfigError, match=r"width = 0 is outside the allowed range \[1, inf\]"):
        local_noise_variance(x, 0)


def _slow_then_fast() -> tuple[np.ndarray, np.ndarray]:
    """Times [s] at 1 kHz and screw angles [rad]: 2 s at 2 rad/s (0.6 turn), then 2 s at
    60 rad/s (19 turns)."""
    t = np.arange(4000) / 1000.0
    w = np.where(t < 2.0, 2.0, 60.0)
    return t, np.concatenate([[0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * np.diff(t))])


def _weighted(
    t: np.ndarray, x: np.ndarray, angle: np.ndarray, drag: np.ndarray | None = None
) -> tuple[np.ndarray, float]:
    x = x - x.mean()
    drag = np.ones_like(t) if drag is None else drag
    weights, revolutions = order_test_weights(t, x, angle, drag, 1e-3, 50)
    y = x * weights
    return y - y.mean(), revolutions


def test_a_flat_residual_gets_no_weight_instead_of_a_division_by_zero() -> None:
    t, angle = _slow_then_fast()
    weights, revolutions = order_test_weights(t, np.zeros_like(t), angle, np.ones_like(t), 1e-3, 50)
    assert revolutions == 0.0 and not np.any(weights)


def test_weighted_order_test_keeps_its_false_alarm_rate_through_a_transient() -> None:
    # noise 20 times louder for 50 ms at the speed step (an inertia transient), on a window
    # slow for half its samples: p = 0.05 per order still holds
    test = OrderSpectralTest(false_alarm_rate=0.05 * 3600 * 3, test_rate=1.0, orders_per_test=3)
    rng = np.random.default_rng(12)
    t, angle = _slow_then_fast()
    orders = np.array([4.94, 6.14, 8.14])
    trials, hits = 400, 0
    for _ in range(trials):
        x = rng.standard_normal(len(t))
        x[1990:2040] *= 20.0
        y, revolutions = _weighted(t, x, angle)
        hits += int(np.sum(test.test(y, angle, orders, revolutions).ratios > test.threshold))
    low, high = binom.interval(0.999, trials * 3, 0.05)
    assert low <= hits <= high


def test_weighted_order_test_finds_a_ripple_a_slow_stretch_hid() -> None:
    # a ripple of a quarter of the noise at order 6.14 over the whole window: weighted by the
    # angle each sample stands for, the fast half resolves it; unweighted, the slow half's
    # 2000 samples over 0.6 turn spill the line onto its neighbours (ratio about 5)
    test = OrderSpectralTest(false_alarm_rate=0.01, test_rate=1.0, orders_per_test=3)
    rng = np.random.default_rng(13)
    t, angle = _slow_then_fast()
    orders = np.array([4.94, 6.14, 8.14])
    x = rng.standard_normal(len(t)) + 0.25 * np.cos(6.14 * angle + 1.0)
    x[1990:2040] += 20.0 * rng.standard_normal(50)
    y, revolutions = _weighted(t, x, angle)
    assert revolutions == pytest.approx(19.1, rel=0.05)
    weighted = test.test(y, angle, orders, revolutions).ratios
    assert weighted[1] > test.threshold
    assert weighted[0] < test.threshold and weighted[2] < test.threshold
    assert test.test(x - x.mean(), angle, orders).ratios[1] < test.threshold


def test_floor_offsets_without_a_lowest_order_are_the_neighbours_on_both_sides() -> None:
    offsets = floor_offsets(4.94, 2.1, 8, 0.0)
    steps = np.arange(2, 10) / 2.1
    assert offsets[0] == 0.0
    assert sorted(offsets[1:]) == pytest.approx(sorted([*-steps, *steps]))


@pytest.mark.parametrize("revolutions", [1.1, 2.1, 30.0])
@pytest.mark.parametrize("order", [4.94, 6.14])
def test_floor_offsets_are_the_nearest_neighbours_above_the_lowest_order(
    order: float, revolutions: float
) -> None:
    lowest = 3.0
    offsets = floor_offsets(order, revolutions, 8, lowest)
    steps = np.rint(offsets[1:] * revolutions)  # whole multiples of the resolution 1 / R
    assert offsets[1:] * revolutions == pytest.approx(steps)
    assert len(set(steps)) == 16 and np.all(np.abs(steps) >= 2)
    assert np.all(order + offsets[1:] >= lowest - 1e-12)
    # none left out that lies nearer than the farthest taken and above the lowest order
    farthest = int(np.max(np.abs(steps)))
    eligible = {
        j
        for j in range(-farthest + 1, farthest)
        if abs(j) >= 2 and order + j / revolutions >= lowest
    }
    assert eligible <= set(steps.astype(int))
    if order - 9 / revolutions >= lowest:  # a long window: the neighbours of the old rule
        assert sorted(offsets) == pytest.approx(sorted(floor_offsets(order, revolutions, 8, 0.0)))


def _short_strokes() -> tuple[np.ndarray, np.ndarray]:
    """Times [s] at 1 kHz and screw angles [rad] of 4 s of a 1 Hz sine stroking over 2.4
    turns (the strokes of dev units 33015 and 33017 in round 39 of issue 13)."""
    t = np.arange(4000) / 1000.0
    return t, 1.2 * 2.0 * math.pi * (1.0 - np.cos(2.0 * math.pi * t))


@pytest.mark.parametrize("lowest", [0.0, 2.0])
def test_order_test_keeps_its_false_alarm_rate_on_short_strokes(lowest: float) -> None:
    test = OrderSpectralTest(
        false_alarm_rate=0.05 * 3600 * 3, test_rate=1.0, orders_per_test=3, lowest_neighbour=lowest
    )
    rng = np.random.default_rng(21)
    t, angle = _short_strokes()
    orders = np.array([4.94, 6.14, 8.14])
    trials, hits = 400, 0
    for _ in range(trials):
        y, revolutions = _weighted(t, rng.standard_normal(len(t)), angle)
        hits += int(np.sum(test.test(y, angle, orders, revolutions).ratios > test.threshold))
    low, high = binom.interval(0.999, trials * 3, 0.05)
    assert low <= hits <= high


def test_a_sphere_spot_on_short_strokes_is_found_above_its_mean_in_the_low_orders() -> None:
    # a spot's raised cosine 0.5 s |T| sign(w) (1 - cos(4.94 phi)) on strokes whose drag T
    # changes along them: weighted by the drag, the spot's mean torque follows the stroke's
    # own shape, whose harmonics (orders k / 2.4) fill the neighbours below the order
    t, angle = _short_strokes()
    speed = np.gradient(angle, t)
    drag = np.sign(speed) * (0.2 + np.abs(speed) / np.max(np.abs(speed)))
    orders = np.array([4.94, 6.14, 8.14])
    threshold = OrderSpectralTest(0.01, 1.0, 3).threshold
    found = {0.0: [], 3.0: []}
    healthy = {0.0: [], 3.0: []}
    for seed in range(20):
        noise = np.random.default_rng(100 + seed).standard_normal(len(t))
        for spot, kept in ((0.25, found), (0.0, healthy)):
            x = noise + spot * (1.0 - np.cos(4.94 * angle)) * drag
            y, revolutions = _weighted(t, x, angle, drag)
            for lowest in (0.0, 3.0):
                test = OrderSpectralTest(0.01, 1.0, 3, lowest_neighbour=lowest)
                kept[lowest].append(test.test(y, angle, orders, revolutions).ratios[0])
    assert np.sum(np.array(found[0.0]) > threshold) <= 2
    assert np.sum(np.array(found[3.0]) > threshold) >= 15
    # without the spot the floor above the lowest order is no lower than the whole one
    assert np.median(healthy[3.0]) == pytest.approx(np.median(healthy[0.0]), rel=0.2)


@pytest.mark.parametrize(
    ("factory", "message"),
    [
        (
            lambda: Cusum(shift=0.0, false_alarm_rate=1.0, sample_rate=1.0),
            "CUSUM shift = 0.0 is outside the allowed range (0, inf] sigma",
        ),
        (
            lambda: Cusum(shift=1.0, false_alarm_rate=-1.0, sample_rate=1.0),
            "false_alarm_rate = -1.0 is outside the allowed range (0, inf] 1/h",
        ),
        (
            lambda: Cusum(shift=1.0, false_alarm_rate=1.0, sample_rate=math.nan),
            "detector sample rate: nan is not a finite number",
        ),
        (
            lambda: WindowChiSquare(window=0, false_alarm_rate=1.0, sample_rate=1.0),
            "chi-square window = 0 is outside the allowed range [1, inf] samples",
        ),
        (
            lambda: WindowChiSquare(window=2.5, false_alarm_rate=1.0, sample_rate=1.0),  # type: ignore[arg-type]
            "chi-square window: expected a whole number, got 2.5",
        ),
        (
            lambda: OrderSpectralTest(1.0, 1.0, 3, lowest_neighbour=-2.0),
            "order test: lowest_neighbour = -2.0 is outside the allowed range [0, inf] -",
        ),
    ],
)
def test_bad_detector_settings_are_named(factory: object, message: str) -> None:
    """Through the package's one number check: the argument, its value, unit and range."""
    with pytest.raises(ConfigError) as err:
        factory()  # type: ignore[operator]
    assert str(err.value).startswith(message), str(err.value)


def test_one_outlying_block_cannot_raise_the_cusum_but_two_can() -> None:
    cusum = Cusum(5.0, 0.01, 10.0)
    assert cusum.clip == pytest.approx(cusum.k + 0.6 * cusum.threshold)
    step = cusum.update(1e6)  # a one-block transient
    assert not step.alarm
    assert step.statistic == pytest.approx(cusum.clip - cusum.k)
    cusum.reset()
    assert not cusum.update(-50.0).alarm
    assert cusum.update(-50.0).alarm  # a change that holds
