"""Sequential change detectors with thresholds set from a target false-alarm rate.

All detectors read standardised inputs (standard normal while the system is healthy) and are
tuned from the false-alarm rate a user accepts, ``rate`` [1/h], and the rate at which they are
fed, ``f`` [Hz]:

* **Two-sided CUSUM** (Page 1954) on the normalised innovations e_k:
  ``g+ = max(0, g+ + e - k)``, ``g- = max(0, g- - e - k)``, alarm when either exceeds h.
  The reference value k = delta / 2 makes it optimal for a mean shift of delta sigma. The
  in-control average run length (ARL0, samples between false alarms) of one side follows
  Siegmund's approximation ``ARL0 = (exp(2 k b) - 2 k b - 1) / (2 k^2)``, b = h + 1.166 (Basseville
  & Nikiforov 1993, Eq. 5.2.44); two sides alarm twice as often, so each side needs
  ``ARL0 = 2 * 3600 f / rate`` and h solves that equation (:func:`cusum_threshold`).
* **Windowed chi-square** on the same innovations: ``sum of the last W e^2`` ~ chi^2(W) when
  healthy; a false-alarm probability per test ``p = rate / (3600 f)`` (Bonferroni over the
  overlapping tests: conservative) gives the threshold ``chi2.isf(p, W)``. It sees a growth of
  the scatter (intermittent contact, ripple) that leaves the mean alone.
* **Order-tracked spectral test** on the raw torque of a window: the complex amplitude at a
  multiple (an *order*) m of the screw angle phi, ``X = sum x_k exp(-i m phi_k)``, follows the
  order even while the speed changes. The 2 J neighbours sit at m +- j / R, j = 2 .. J + 1, R the
  revolutions in the window (whole multiples of the order resolution, clear of the main lobe).
  With white noise the powers |X|^2 at these orders are independent exponentials, so the ratio
  of the power at the order to the neighbours' mean is F(2, 4 J) distributed; its threshold
  is ``f.isf(p, 2, 4 J)``. Where the noise is not white but changes within the window (a
  speed step's inertia transient, a fast stretch's order-one encoder torque), each sample is
  weighted by the inverse of its local noise variance (:func:`local_noise_variance`): the
  weighted noise is white again, so the ratio keeps its distribution, and a transient no
  longer fills every order's neighbours. Each sample is also weighted by the angle it stands
  for (:func:`angle_swept`), so that the transform integrates over the angle: a stretch of
  slow rotation, many samples over a fraction of a turn, would otherwise hold much of the
  power with an order resolution of several orders, and spill the order's line onto its
  neighbours. The neighbours are spaced by the revolutions that hold the power
  (:func:`effective_revolutions`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq
from scipy.stats import chi2, f

from ..errors import ConfigError
from ..params import check_number, limits, not_negative, positive
from .residuals import FloatArray

#: Siegmund's correction of the CUSUM threshold for the overshoot of a normal increment [-].
SIEGMUND_OVERSHOOT = 1.166
SECONDS_PER_HOUR = 3600.0
#: Local residual variance, in multiples of its median over the window, above which the order
#: test weights a sample down [-] (see :func:`order_test_weights`).
LOUD_VARIANCE = 4.0


#: The range of the detectors' counts (:func:`~ballscrew_twin.params.check_number`).
_COUNT = limits("samples", 1, math.inf, integer=True)


def check_rate(false_alarm_rate: float, sample_rate: float) -> None:
    """Raise ConfigError unless 0 < false_alarm_rate [1/h] and 0 < sample_rate [Hz]."""
    check_number(false_alarm_rate, positive("1/h"), "false_alarm_rate", text=False)
    check_number(sample_rate, positive("Hz"), "detector sample rate", text=False)


def arl0_from_rate(false_alarm_rate: float, sample_rate: float) -> float:
    """In-control average run length [samples] of a test fed at ``sample_rate`` [Hz] that
    raises ``false_alarm_rate`` [1/h] false alarms: 3600 f / rate."""
    check_rate(false_alarm_rate, sample_rate)
    return SECONDS_PER_HOUR * sample_rate / false_alarm_rate


def siegmund_arl0(k: float, h: float) -> float:
    """One-sided CUSUM in-control ARL [samples] for N(0, 1) increments (Siegmund)."""
    b = h + SIEGMUND_OVERSHOOT
    a = 2.0 * k * b
    return (math.expm1(a) - a) / (2.0 * k * k)


def cusum_threshold(k: float, arl0: float) -> float:
    """Threshold h [-] of a one-sided CUSUM with reference ``k`` [-] and in-control ARL
    ``arl0`` [samples] (inverse of :func:`siegmund_arl0`)."""
    check_number(k, positive("-"), "CUSUM reference k", text=False)
    if not (math.isfinite(arl0) and arl0 > 1.0):
        raise ConfigError(f"CUSUM ARL0 = {arl0!r} samples must be > 1")
    high = 1.0
    while siegmund_arl0(k, high) < arl0:
        high *= 2.0
    return float(brentq(lambda h: siegmund_arl0(k, h) - arl0, 0.0, high, xtol=1e-9))


@dataclass(frozen=True)
class CusumStep:
    """State after one CUSUM update.

    Attributes:
        statistic: max(g+, g-) [-].
        alarm: whether the statistic exceeds the threshold.
        direction: +1 if g+ is the larger side, else -1.
        change_index: index of the last sample at which the larger side was zero (estimate of
            the change time: the alarm's change starts at the next sample).
    """

    statistic: float
    alarm: bool
    direction: int
    change_index: int


#: The weight of one CUSUM input: in (0, 1] [-].
_WEIGHT = limits("-", 0.0, 1.0, lo_open=True)

#: Largest share of the threshold one input may add to the CUSUM beyond k [-]: no single
#: block can raise an alarm from zero (a one-block transient the twin does not model, e.g.
#: a start from standstill, is not a fault); two in a row at the clip can.
CUSUM_CLIP_SHARE = 0.6


class Cusum:
    """Two-sided CUSUM on standard-normal inputs, each input clipped to +-(k + 0.6 h)
    (:data:`CUSUM_CLIP_SHARE`: a Huber-type CUSUM; under normal inputs the clip is reached
    with probability below 1e-4 per input, so the mean run length stays at its target).

    Args:
        shift: mean shift it is tuned for, in sigma [-] (k = shift / 2).
        false_alarm_rate: target false alarms per hour [1/h].
        sample_rate: rate of the inputs [Hz].
    """

    def __init__(self, shift: float, false_alarm_rate: float, sample_rate: float) -> None:
        check_number(shift, positive("sigma"), "CUSUM shift", text=False)
        self.k = 0.5 * shift
        self.threshold = cusum_threshold(
            self.k, 2.0 * arl0_from_rate(false_alarm_rate, sample_rate)
        )
        self.clip = self.k + CUSUM_CLIP_SHARE * self.threshold
        self.reset()

    def reset(self) -> None:
        """Back to zero."""
        self.upper = 0.0
        self.lower = 0.0
        self.count = 0
        self._upper_zero = 0
        self._lower_zero = 0

    def update(self, e: float, weight: float = 1.0) -> CusumStep:
        """Take one normalised input ``e`` [-] (clipped to +-:attr:`clip`) of relative
        information ``weight`` in (0, 1] [-]: the shift the CUSUM is tuned for, in this
        input's sigma, over its tuned size (an input whose sigma is inflated by terms a
        fault does not change sees the same fault as a smaller shift). Each side moves by
        the log-likelihood ratio of that smaller shift, w (e - k w), scaled by the tuned
        shift: at w = 1 the plain e - k; a vague input neither raises the statistic nor pulls
        it down by a whole k (a fast sine's strokes between reversals, whose sigma carries the
        inertia's error, otherwise undid what the steady strokes added up)."""
        check_number(weight, _WEIGHT, "CUSUM input weight", text=False)
        e = min(max(e, -self.clip), self.clip)
        drift = self.k * weight
        self.upper = max(0.0, self.upper + weight * (e - drift))
        self.lower = max(0.0, self.lower + weight * (-e - drift))
        if self.upper == 0.0:
            self._upper_zero = self.count
        if self.lower == 0.0:
            self._lower_zero = self.count
        self.count += 1
        if self.upper >= self.lower:
            stat, direction, zero = self.upper, 1, self._upper_zero
        else:
            stat, direction, zero = self.lower, -1, self._lower_zero
        return CusumStep(stat, stat > self.threshold, direction, zero)


class WindowChiSquare:
    """Sum of the last ``window`` squared normalised inputs against chi^2(window).

    Args:
        window: number of inputs summed.
        false_alarm_rate: target false alarms per hour [1/h].
        sample_rate: rate of the inputs [Hz].
    """

    def __init__(self, window: int, false_alarm_rate: float, sample_rate: float) -> None:
        check_number(window, _COUNT, "chi-square window", text=False)
        self.window = window
        p = 1.0 / arl0_from_rate(false_alarm_rate, sample_rate)
        self.threshold = float(chi2.isf(p, window))
        self._values: list[float] = []

    def reset(self) -> None:
        """Forget the window."""
        self._values.clear()

    def update(self, e: float) -> tuple[float, bool]:
        """Take one input; return the statistic [-] (0 until the window is full) and alarm."""
        self._values.append(e * e)
        if len(self._values) > self.window:
            self._values.pop(0)
        if len(self._values) < self.window:
            return 0.0, False
        stat = float(sum(self._values))
        return stat, stat > self.threshold


def centred_acceleration(times: FloatArray, speed: FloatArray, window: float) -> FloatArray:
    """dw/dt at each of ``times`` [s] [rad/s^2]: the least-squares slope of the ``speed``
    [rad/s] samples within ``window`` [s] centred on it (fewer where the record ends; at least
    the neighbours on each side).

    The slope of a line over a window T is a differentiator with a low pass: its gain falls
    from that of d/dt below 1/T and has nulls above, so the interpolation images of 100 Hz
    speed samples are not differentiated into the torque."""
    n = len(times)
    if n < 2:
        return np.zeros(n)
    step = float(np.median(np.diff(times)))
    half = max(round(0.5 * window / step), 1) if step > 0.0 else 1
    t = times - times[0]
    mean_t, mean_w, mean_tt, mean_tw = (
        window_means(values, half, 2 * half + 1) for values in (t, speed, t * t, t * speed)
    )
    spread = mean_tt - mean_t**2
    covariance = mean_tw - mean_t * mean_w
    with np.errstate(invalid="ignore", divide="ignore"):
        slope = np.where(spread > 0.0, covariance / spread, 0.0)
    return np.asarray(slope)


def order_amplitudes(x: FloatArray, angle: FloatArray, orders: FloatArray) -> FloatArray:
    """Complex amplitudes ``sum x_k exp(-i m angle_k)`` for each order m [-] (angle [rad])."""
    return np.exp(-1j * np.outer(orders, angle)) @ x


def local_noise_variance(x: FloatArray, width: int) -> FloatArray:
    """Local variance of ``x`` at each sample [unit of x squared]: the mean of x^2 over the
    ``width`` samples centred on it (fewer at the ends). ``x`` should have its mean and slow
    trend removed."""
    check_number(width, _COUNT, "local noise variance: width", text=False)
    return window_means(np.asarray(x, dtype=np.float64) ** 2, width // 2, width)


def window_means(values: FloatArray, before: int, width: int) -> FloatArray:
    """Mean of ``values`` over the ``width`` samples from ``before`` samples ahead of each
    sample on (fewer where the record ends), from one cumulative sum [unit of values]."""
    sums = np.concatenate([[0.0], np.cumsum(values)])
    n = len(values)
    index = np.arange(n)
    low = np.clip(index - before, 0, n)
    high = np.clip(index - before + width, 0, n)
    return np.asarray((sums[high] - sums[low]) / (high - low))


def neighbouring(time: FloatArray, step: float) -> FloatArray:
    """Whether each pair of consecutive samples at ``time`` [s] are neighbours: at most 1.5
    ``step`` [s] apart, not across a gap of the window (a gated stretch the angle ran on
    through)."""
    return np.asarray(np.diff(time) <= 1.5 * step)


def angle_swept(time: FloatArray, angle: FloatArray, step: float) -> FloatArray:
    """Screw angle each sample stands for [rad]: half the angle turned [rad] over each of
    its intervals to a neighbouring sample (:func:`neighbouring`; an interval across a gap
    stands for nothing)."""
    turned = np.where(neighbouring(time, step), np.abs(np.diff(angle)), 0.0)
    swept = np.zeros(len(angle))
    swept[:-1] += 0.5 * turned
    swept[1:] += 0.5 * turned
    return swept


def effective_revolutions(energy: FloatArray, angle: FloatArray, bins_per_turn: int = 16) -> float:
    """Revolutions a weighted order transform resolves [-]: (sum e)^2 / sum_b(E_b^2 / d phi)
    / 2 pi, with e [any unit] each sample's share of the transform's noise power, E_b its sum
    over a bin of the screw ``angle`` [rad] and d phi the bin's width (``bins_per_turn`` to a
    turn). It is the span of the angle when the power is spread evenly over it, and the span
    of the part that holds the power otherwise (a window that holds its power in 3 of its 20
    revolutions resolves orders 1/3 apart); strokes back and forth over the same turns add up
    in the same bins.
    """
    width = 2.0 * math.pi / bins_per_turn
    index = np.floor((angle - np.min(angle)) / width).astype(np.int64)
    per_bin = np.bincount(index, weights=energy)
    total = float(np.sum(per_bin))
    spread = float(np.sum(per_bin**2)) / width
    if not (total > 0.0 and spread > 0.0):
        return 0.0
    return total**2 / spread / (2.0 * math.pi)


def order_test_weights(
    time: FloatArray,
    residual: FloatArray,
    angle: FloatArray,
    drag: FloatArray,
    step: float,
    noise_samples: int,
) -> tuple[FloatArray, float]:
    """Weight of each sample in the order test [-] (scaled to a mean square of 1) and
    the revolutions the weighted transform resolves [-] (0 when nothing turns).

    A defect's ripple s |T| sign(w) c(phi) scales with the drag and takes its sign: weighted
    by the predicted ``drag`` [N m], the ripple of strokes in both directions adds up instead
    of cancelling. Divided by the local noise variance of the ``residual`` [N m] (over
    ``noise_samples``), a transient's samples count for what they are worth: the matched
    filter in noise whose variance changes along the window. Only a stretch louder than
    ``LOUD_VARIANCE`` times the window's median is weighted down: the ripple itself raises
    the local variance (a 2 % ripple by up to 1.8 times at 0.2 mN m of noise), and would
    otherwise take the weight off the samples that carry it. Times the angle each sample
    stands for, the transform integrates over the ``angle`` [rad] instead of over ``time``
    [s] (sampled every ``step`` [s]): a slow stretch, many samples over a fraction of a turn,
    would otherwise hold much of the power at a coarse order resolution and spill the order's
    line onto its neighbours.
    """
    local = local_noise_variance(residual, noise_samples)
    floor = LOUD_VARIANCE * float(np.median(local))
    if not floor > 0.0:  # a residual flat over half the window: nothing to weigh
        return np.zeros_like(local), 0.0
    variance = np.maximum(local, floor)
    gain = drag / variance * angle_swept(time, angle, step)
    scale = math.sqrt(float(np.mean(gain**2)))
    if not scale > 0.0:
        return np.zeros_like(gain), 0.0
    return gain / scale, effective_revolutions(gain**2 * variance, angle)


def floor_offsets(order: float, revolutions: float, neighbours: int, lowest: float) -> FloatArray:
    """Offsets from ``order`` [-] of the order test's probes [-]: 0 (the order itself), then
    the 2 J = 2 ``neighbours`` nearest of m +- j / R, j = 2, 3, ..., R = ``revolutions`` [-],
    whose order m +- j / R is at least ``lowest`` [-] (0: j = 2 .. J + 1 on both sides, a
    negative order standing for its mirror).

    A window of short strokes resolves few revolutions (R of 1-3), and the neighbours then
    reach down to orders 0.3-2 below a sphere spot's 4.94. There lie the harmonics of the
    stroke (orders k / R): the twin's own error along it, and a spot's mean torque, s |T| / 2
    with the drag's sign, which the test's weighting by the drag turns into the shape of
    |T|^2 along the stroke (and which steps where the sphere leaves the loaded turns). Dev
    units 33015 and 33017 (round 39 of issue 13: 2 % spots on strokes over 2.4 and 2.7
    turns, never found): the spot raised the power at orders 0.5-4 five to ten times, and the
    floor with it, so that the ratio stayed at 3-14 against a threshold of 24.8. A neighbour
    below ``lowest`` is replaced by the next one farther out on the other side; the
    neighbours stay whole multiples of the resolution, so white noise keeps the ratio's F
    distribution.
    """
    chosen: list[float] = []
    j = 2
    while len(chosen) < 2 * neighbours:
        for offset in (-j / revolutions, j / revolutions):
            if (lowest <= 0.0 or order + offset >= lowest) and len(chosen) < 2 * neighbours:
                chosen.append(offset)
        j += 1
    return np.array([0.0, *chosen])


@dataclass(frozen=True)
class OrderTestResult:
    """Spectral test of several orders in one window.

    Attributes:
        ratios: power at each order over the mean power of its neighbours [-].
        threshold: alarm threshold of each ratio [-].
        amplitudes: estimated ripple amplitude at each order [N m] (2 |X| / N).
    """

    ratios: FloatArray
    threshold: float
    amplitudes: FloatArray


class OrderSpectralTest:
    """Order-tracked ripple test (see the module docstring).

    Args:
        neighbours: J, neighbouring orders on each side used for the noise floor.
        false_alarm_rate: target false alarms per hour [1/h], over all orders tested.
        test_rate: how often a window is tested [Hz].
        orders_per_test: how many orders each test checks (Bonferroni).
        lowest_neighbour: the lowest order a neighbour may lie at [-] (:func:`floor_offsets`;
            0: every neighbour at m +- j / R).
    """

    def __init__(
        self,
        false_alarm_rate: float,
        test_rate: float,
        orders_per_test: int,
        neighbours: int = 8,
        lowest_neighbour: float = 0.0,
    ) -> None:
        if neighbours < 1 or orders_per_test < 1:
            raise ConfigError("order test: neighbours and orders_per_test must be >= 1")
        self.neighbours = neighbours
        self.lowest_neighbour = float(
            check_number(
                lowest_neighbour,
                not_negative("-"),
                "order test: lowest_neighbour",
                text=False,
            )
        )
        p = 1.0 / (arl0_from_rate(false_alarm_rate, test_rate) * orders_per_test)
        self.threshold = float(f.isf(p, 2, 4 * neighbours))

    def test(
        self,
        x: FloatArray,
        angle: FloatArray,
        orders: FloatArray,
        revolutions: float | None = None,
    ) -> OrderTestResult:
        """Test ``orders`` [-] in torque ``x`` [N m] sampled at screw angles ``angle`` [rad].

        ``x`` (N,) should have its mean (and slow trend) removed; an (N, K) array tests K
        records at the same angles at once (results then have a trailing K axis). The
        neighbours are spaced by the inverse of ``revolutions`` [-], the revolutions the
        window resolves (:func:`effective_revolutions`; by default the angle's span). The
        window must span enough revolutions for the neighbours not to overlap the order
        (checked by the caller).
        """
        if revolutions is None:
            revolutions = float(np.ptp(angle)) / (2.0 * math.pi)
        revolutions = max(revolutions, 1e-9)
        offsets = np.array(
            [
                floor_offsets(m, revolutions, self.neighbours, self.lowest_neighbour)
                for m in np.asarray(orders, dtype=np.float64)
            ]
        )
        probes = (np.asarray(orders)[:, None] + offsets).ravel()
        values = order_amplitudes(x, angle, probes)
        power = (np.abs(values) ** 2).reshape(len(orders), offsets.shape[1], *np.shape(x)[1:])
        floor = np.mean(power[:, 1:], axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratios = np.where(floor > 0.0, power[:, 0] / floor, math.inf)
        amplitudes = 2.0 * np.sqrt(power[:, 0]) / len(x)
        return OrderTestResult(ratios, self.threshold, amplitudes)
