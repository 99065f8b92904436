"""What this run has seen: the unit's residual per operating point, for a change detector.

After commissioning, the twin's error at one operating point is systematic (the residual
surface of :mod:`.correction` takes most of it out, but its out-of-fold error is 1-3 % where
the commissioning saw a regime briefly), while the unit's torque at a revisited operating
point repeats to the sensor noise. A fault changes the torque at every operating point. So
besides the test against the commissioned twin (whose sigma must cover the twin's error), the
monitor compares each quiet block with what *this run* measured at the same operating point
before: the relative residual q = (measured - predicted) / (g D) [-], binned by direction of
rotation, log speed (:data:`SPEED_BIN` decades), the speed change along the block (steady, or
its sign and size: a transient is compared with the same part of a motion that comes round
again, whose inertia and friction lag repeat) and log preload (:data:`PRELOAD_BIN`); a bin is
a reference within :data:`TEMPERATURE_SPAN` of the temperature it started at. The twin still
carries the operating point's dependence within a bin (the bin holds the residual, not the
torque), so a bin may be wide.

The local innovation of a block at a bin with n >= :data:`MIN_COUNT` earlier blocks is

    z = (q - m) / sqrt(v + v_m / n + FLOOR^2 + (s_w dln w)^2 + (s_T dT)^2)

with m the bin's mean residual, v the block's own variance (sensor noise and the
inertia/transient terms, relative, the latter at the share :data:`REPEAT_SHARE` that does not
repeat), v_m the bin's mean block variance, dln w and dT the block's distance from the bin's
mean log speed and temperature with the slope bounds :data:`SPEED_SLOPE` and
:data:`TEMPERATURE_SLOPE`, and ``floor`` the
residual's variation within a bin and over half a minute (temperature drift inside a bin, the
surface's slope across it). A block updates its bin while the run is healthy and |z| <
:data:`UPDATE_GATE`: a fault that changed the torque keeps being compared with the bin's
healthy past; the bin's memory is an average over at most :data:`MEMORY_BLOCKS` blocks, and a
bin not visited for :data:`MEMORY_AGE` is forgotten, so the reference is the run's recent past
(a thermometer drifts over minutes).

A new bin's blocks are learnt untested, and the bin becomes a reference only once its last
:data:`MIN_COUNT` blocks agree: each within ``agreement`` sigma (the z above, at the window's
mean variance) of their median, which starts the bin's mean; the blocks before that window
leave no trace. The torque settling after a speed step otherwise sets a reference that every
later healthy block differs from: held-out unit 6000 (one block after a step from -172 to
-2.9 rad/s, 7.6 % off; the median of the first blocks was enough there) and held-out unit
18003 (after a step from 288 to 2.2 rad/s the first five blocks were 24.8, 8.3, 3.1, 0.9 and
0.5 % off, their median 3.05 %, and the settled blocks at 0.4 % then read -3.4 to -4.5 sigma:
a false alarm). Nor may the window still fall or rise as a whole: its slope against the
blocks' order must lie within ``trend`` sigma (:func:`window_trend`). Held-out unit 34005
(round 39): 5.9, 4.1, 2.3, 1.2 and 0.7 % after a step from -36.7 to -2.1 rad/s, each within
the agreement of their median, which started the bin at 2.3 %; the settled blocks at 0.0 %
read -3.0 to -3.9 sigma, a false alarm. The price: a bin first visited while a fault grows
learns the growth as a settling and tests no block until it stops (held-out unit 34022's jam
of round 40, found 3.2 s later by a bin that knew the unit before).
"""

from __future__ import annotations

import math
import statistics
from dataclasses import dataclass, field

from ..errors import ConfigError
from ..params import check_number, not_negative

#: Bin widths: log10 speed [decades], natural-log preload [-].
SPEED_BIN = 0.1
PRELOAD_BIN = 0.05
#: Largest distance from a bin's mean temperature for it to stay a reference [K].
TEMPERATURE_SPAN = 2.0
#: Bounds on how fast the unit's residual may change with log speed [-] and temperature
#: [1/K] inside a bin: a block away from its bin's mean speed or temperature is compared with
#: that much more sigma (training unit 7: the residual moved by 2 % between 2.15 and 2.49 rad/s,
#: one bin; training unit 4: by 0.9 % between -5.1 and -4.0 C at 32 rad/s).
SPEED_SLOPE = 0.15
TEMPERATURE_SLOPE = 0.01
#: Fewest earlier blocks in a bin before it tests a block [-].
MIN_COUNT = 5
#: Most blocks a bin's mean averages over (an exponential memory beyond) [-].
MEMORY_BLOCKS = 100
#: A bin not updated for this long is forgotten [s]: over minutes the thermometer drifts
#: (training unit 5: the residual at -168 rad/s, 12 C moved by 1.2 % in 390 s, the twin read
#: at a temperature that had drifted), so only the run's recent past is a reference.
MEMORY_AGE = 30.0
#: |z| from which a block no longer updates its bin [-].
UPDATE_GATE = 3.0
#: Relative variation of the residual within a bin and over a run, one sigma [-].
FLOOR = 0.003
#: Relative speed change over a block below which the block is steady, and the factor
#: between the edges of the transient bins beyond (speed change / |speed|) [-].
STEADY_CHANGE = 0.05
CHANGE_BIN = 4.0
#: Share of a block's own transient sigma (inertia, lag of the friction) that does not repeat
#: when the same part of a periodic motion comes round again [-].
REPEAT_SHARE = 0.1
#: Largest own relative sigma of a block for the local test [-]: beyond, the block is mostly
#: inertia or lag and says little about the friction.
LOUD_SIGMA = 0.3


@dataclass(frozen=True)
class _Learnt:
    """One untested block of a bin that is not yet a reference: relative residual and own
    variance [-], temperature [K], log of |speed| [ln(rad/s)]."""

    residual: float
    variance: float
    temperature: float
    log_speed: float


@dataclass
class _Bin:
    count: int = 0
    mean: float = 0.0
    variance: float = 0.0
    last: float = -math.inf
    temperature: float = math.nan
    log_speed: float = math.nan
    #: The last MIN_COUNT blocks while the bin is not yet a reference; empty once it is.
    window: list[_Learnt] = field(default_factory=list)

    def fresh(self, time: float, temperature: float) -> bool:
        """Whether the bin is still a reference at ``time`` [s] and ``temperature`` [K]
        (MEMORY_AGE, TEMPERATURE_SPAN)."""
        return time - self.last <= MEMORY_AGE and abs(temperature - self.temperature) <= (
            TEMPERATURE_SPAN
        )


BinKey = tuple[int, int, int, int]


def bin_key(
    speed: float, temperature: float, preload: float, speed_change: float = 0.0
) -> BinKey | None:
    """The bin of a block at mean ``speed`` [rad/s] and ``preload`` [N] whose speed changes by
    ``speed_change`` [rad/s] over it; None at standstill or without a preload or temperature
    [K] reading (the temperature is checked by the bin itself, :data:`TEMPERATURE_SPAN`).
    Steady blocks (|change| < STEADY_CHANGE |speed|) share a bin; a transient
    block's bin also holds the sign and size (factors of CHANGE_BIN) of its change, so that
    it is compared with the same part of a motion that comes round again (a sine, a
    trapezoid's ramps), whose inertia and lag repeat."""
    if not (math.isfinite(speed) and speed != 0.0 and math.isfinite(temperature)):
        return None
    if not (math.isfinite(preload) and preload > 0.0 and math.isfinite(speed_change)):
        return None
    relative = speed_change / abs(speed)
    change = 0
    if abs(relative) >= STEADY_CHANGE:
        size = 1 + math.floor(math.log(abs(relative) / STEADY_CHANGE) / math.log(CHANGE_BIN))
        change = size if relative > 0.0 else -size
    return (
        1 if speed > 0.0 else -1,
        math.floor(math.log10(abs(speed)) / SPEED_BIN),
        change,
        math.floor(math.log(preload) / PRELOAD_BIN),
    )


class ResidualMemory:
    """Per-bin mean relative residual of the blocks this run has compared (module doc):
    ``floor`` [-] the residual's variation within a bin, one sigma; ``agreement`` [-] the
    largest z of a new bin's last MIN_COUNT blocks against their median for the bin to become
    a reference (inf: its first MIN_COUNT blocks as they come); ``trend`` [-] the largest |z|
    of those blocks' slope (:func:`window_trend`) for it (inf: no limit)."""

    def __init__(
        self, floor: float = FLOOR, agreement: float = UPDATE_GATE, trend: float = UPDATE_GATE
    ) -> None:
        check_number(floor, not_negative("-"), "residual memory floor", text=False)
        for name, value in (("agreement", agreement), ("trend", trend)):
            if not value > 0.0:
                raise ConfigError(f"residual memory {name} = {value!r} sigma must be > 0")
        self.floor = floor
        self.agreement = agreement
        self.trend = trend
        self._bins: dict[BinKey, _Bin] = {}

    def __len__(self) -> int:
        return len(self._bins)

    def innovation(
        self,
        key: BinKey,
        residual: float,
        variance: float,
        time: float,
        temperature: float,
        speed: float,
    ) -> float | None:
        """z of a block at ``time`` [s], ``temperature`` [K] and mean ``speed`` [rad/s] with
        relative ``residual`` [-] and own ``variance`` [-] at ``key``; None while the bin has
        fewer than MIN_COUNT blocks, was last updated more than MEMORY_AGE ago or lies more
        than TEMPERATURE_SPAN away."""
        found = self.reference(key, time, temperature, speed)
        if found is None:
            return None
        mean, spread = found
        return (residual - mean) / math.sqrt(variance + spread)

    def reference(
        self, key: BinKey, time: float, temperature: float, speed: float
    ) -> tuple[float, float] | None:
        """The bin's reference for a block at ``time`` [s], ``temperature`` [K] and mean
        ``speed`` [rad/s]: its mean relative residual m [-] and the variance of that
        reference at the block, v_m / n + FLOOR^2 + (s_w dln w)^2 + (s_T dT)^2 [-] (the block's
        own variance is the caller's); None when :meth:`innovation` would be None."""
        b = self._bins.get(key)
        if b is None or not b.fresh(time, temperature) or b.count < MIN_COUNT:
            return None
        apart = (SPEED_SLOPE * (math.log(abs(speed)) - b.log_speed)) ** 2 + (
            TEMPERATURE_SLOPE * (temperature - b.temperature)
        ) ** 2
        return b.mean, b.variance / b.count + self.floor**2 + apart

    def update(
        self,
        key: BinKey,
        residual: float,
        variance: float,
        time: float,
        temperature: float,
        speed: float,
    ) -> None:
        """Add a healthy block at ``time`` [s], ``temperature`` [K] and mean ``speed``
        [rad/s] to its bin (the caller checks |z| < UPDATE_GATE); a stale bin (MEMORY_AGE,
        TEMPERATURE_SPAN) starts afresh. A bin that is not yet a reference keeps its last
        MIN_COUNT blocks and becomes one when they agree (:meth:`_settle`); a reference
        follows the running mean."""
        b = self._bins.get(key)
        if b is None or not b.fresh(time, temperature):
            b = self._bins[key] = _Bin()
        b.last = time
        log_speed = math.log(abs(speed))
        if b.count < MIN_COUNT:
            b.window.append(_Learnt(residual, variance, temperature, log_speed))
            del b.window[:-MIN_COUNT]
            self._settle(b)
            return
        b.count = min(b.count + 1, MEMORY_BLOCKS)
        weight = 1.0 / b.count
        b.mean += weight * (residual - b.mean)
        b.variance += weight * (variance - b.variance)
        b.temperature += weight * (temperature - b.temperature)
        b.log_speed += weight * (log_speed - b.log_speed)

    def _settle(self, b: _Bin) -> None:
        """Take the window's temperature and speed as the bin's [K, ln(rad/s)]; when it holds
        MIN_COUNT blocks each within ``agreement`` sigma of their median (sigma^2 the
        block's variance + the window's mean variance / MIN_COUNT + floor^2) and without a
        slope beyond ``trend`` sigma (:func:`window_trend`), make the bin a reference from
        them: mean = median, count = MIN_COUNT, the rest their means."""
        window = b.window
        b.temperature = statistics.fmean(each.temperature for each in window)
        b.log_speed = statistics.fmean(each.log_speed for each in window)
        if len(window) < MIN_COUNT:
            return
        median = statistics.median(each.residual for each in window)
        spread = statistics.fmean(each.variance for each in window)
        for each in window:
            sigma = math.sqrt(each.variance + spread / MIN_COUNT + self.floor**2)
            if abs(each.residual - median) > self.agreement * sigma:
                return
        if abs(window_trend(window, self.floor)) > self.trend:  # never beyond inf
            return
        b.mean, b.variance, b.count = median, spread, MIN_COUNT
        b.window = []


def window_trend(window: list[_Learnt], floor: float) -> float:
    """z [-] of the slope of a bin's learnt blocks against their order, fitted by weighted
    least squares with weights 1 / (v_i + ``floor``^2) (v_i a block's own variance [-],
    ``floor`` [-] one sigma of the residual's variation within a bin): the slope over its
    standard error. A window settling after a speed step falls block by block, though each
    block lies within the agreement of the median (unit 34005, held out in round 39: 5.9, 4.1,
    2.3, 1.2 and 0.7 % after a step from -36.7 to -2.1 rad/s, then 0.0 +- 0.1 %); noise alone
    gives a standard normal z."""
    weights = [1.0 / (each.variance + floor**2) for each in window]
    total = math.fsum(weights)
    centre = math.fsum(w * k for k, w in enumerate(weights)) / total
    spread = math.fsum(w * (k - centre) ** 2 for k, w in enumerate(weights))
    if not spread > 0.0:
        return 0.0
    slope = (
        math.fsum(
            w * (k - centre) * each.residual
            for k, (w, each) in enumerate(zip(weights, window, strict=True))
        )
        / spread
    )
    return slope * math.sqrt(spread)
