"""Duty cycles of electro-mechanical actuators: what a ball screw on a real bench goes through.

A :class:`Trajectory` is the true screw speed [rad/s], temperature [K] and set preload [N] on a
regular time grid (1 ms by default). It is built from segments drawn at random
(:func:`draw_trajectory`), each one of the EMA patterns of issue 13:

- ``sine``: a sinusoidal position command x = A sin(2 pi f t) at f = 0.2-5 Hz: the screw
  speed is a cosine and reverses twice per cycle;
- ``trapezoid``: point-to-point moves, accelerate / cruise / decelerate, then dwell at
  standstill, alternating direction;
- ``steps``: speed steps between levels up to 3000 rpm (ramped over a drive's 20-100 ms),
  either sign, held 1-5 s;
- ``reversal``: constant speed with slow reversals through zero (ramps of 0.5-3 s).

Temperature: constant ambient with a slow drift, or a **cold start** from -20..5 C warming
exponentially towards 30..45 C. The set preload is constant per recording. Speeds are drawn
log-uniformly so that slow motion (tens of rpm) is as likely as fast.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..errors import ConfigError
from ..units import CELSIUS_ZERO, RPM

FloatArray = NDArray[np.float64]

#: Kinds of segment.
SEGMENT_KINDS = ("sine", "trapezoid", "steps", "reversal")
#: Range of the peak speed of a segment [rpm], drawn log-uniformly.
PEAK_SPEED_RPM = (20.0, 3000.0)
#: Range of the sine frequency [Hz], drawn log-uniformly.
SINE_FREQUENCY = (0.2, 5.0)
#: Length of a segment [s].
SEGMENT_LENGTH = (20.0, 90.0)


@dataclass(frozen=True)
class Trajectory:
    """True operating profile on a regular grid.

    Attributes:
        time: instants from 0 [s], regular.
        speed: screw speed [rad/s].
        temperature: lubricant / nut temperature [K].
        preload: preload set in the preload device [N].
        segments: (start [s], kind) of each segment.
    """

    time: FloatArray
    speed: FloatArray
    temperature: FloatArray
    preload: FloatArray
    segments: tuple[tuple[float, str], ...]

    @property
    def duration(self) -> float:
        """Length [s] (one step past the last instant)."""
        return float(self.time[-1] + (self.time[1] - self.time[0])) if len(self.time) > 1 else 0.0


def _ramped_levels(
    t: FloatArray, times: list[float], levels: list[float], ramp: float
) -> FloatArray:
    """Piecewise-constant ``levels`` changing at ``times`` [s], each change a linear ramp of
    ``ramp`` [s] (the drive's speed loop). Not a :class:`~ballscrew_twin.models.profile.Profile`:
    the ramps are linear and summed onto the first level in turn, the arithmetic the drawn
    duty cycles (and so the seeded bench recordings) were made with."""
    out = np.full_like(t, levels[0])
    for k in range(1, len(levels)):
        fraction = np.clip((t - times[k]) / ramp, 0.0, 1.0)
        out += (levels[k] - levels[k - 1]) * fraction
    return out


def _peak(rng: np.random.Generator, top_rpm: float) -> float:
    low, high = PEAK_SPEED_RPM
    high = min(high, top_rpm)
    return float(math.exp(rng.uniform(math.log(low), math.log(high))) * RPM)


def segment_speed(kind: str, t: FloatArray, rng: np.random.Generator, top_rpm: float) -> FloatArray:
    """Speed [rad/s] of one segment of ``kind`` at times ``t`` [s] from its start."""
    length = float(t[-1]) if len(t) else 0.0
    if kind == "sine":
        frequency = math.exp(rng.uniform(*np.log(SINE_FREQUENCY)))
        peak = _peak(rng, top_rpm)
        phase = rng.uniform(0.0, 2.0 * math.pi)
        return np.asarray(peak * np.cos(2.0 * math.pi * frequency * t + phase))
    if kind == "trapezoid":
        out = np.zeros_like(t)
        start, direction = 0.0, float(rng.choice([-1.0, 1.0]))
        while start < length:
            peak = _peak(rng, top_rpm)
            accel = rng.uniform(0.05, 0.5)
            cruise = rng.uniform(0.2, 3.0)
            dwell = rng.uniform(0.0, 2.0)
            rise = np.clip((t - start) / accel, 0.0, 1.0)
            fall = np.clip((t - start - accel - cruise) / accel, 0.0, 1.0)
            out += direction * peak * (rise - fall)
            start += 2.0 * accel + cruise + dwell
            direction = -direction
        return out
    if kind == "steps":
        times, levels, now = [0.0], [_peak(rng, top_rpm) * rng.choice([-1.0, 1.0])], 0.0
        while now < length:
            now += rng.uniform(1.0, 5.0)
            times.append(now)
            levels.append(_peak(rng, top_rpm) * float(rng.choice([-1.0, 1.0])))
        return _ramped_levels(t, times, levels, rng.uniform(0.02, 0.1))
    if kind == "reversal":
        peak = _peak(rng, top_rpm)
        times, levels, now, sign = [0.0], [peak], 0.0, 1.0
        while now < length:
            now += rng.uniform(3.0, 10.0)
            sign = -sign
            times.append(now)
            levels.append(sign * peak)
        return _ramped_levels(t, times, levels, rng.uniform(0.5, 3.0))
    raise ConfigError(f"duty cycle: segment kind {kind!r} is not one of {SEGMENT_KINDS}")


@dataclass(frozen=True)
class ColdStart:
    """How a cold start warms: first and final temperature ranges [C] and the range of the
    time constant [s] (each drawn uniformly).

    The default is the cold start of a day's duty cycle; a commissioning warm-up
    (:data:`COMMISSIONING_WARMUP`) starts colder and reaches its final temperature within the
    recording, so that the unit is learnt over the temperatures it will work at.
    """

    first: tuple[float, float] = (-20.0, 5.0)
    last: tuple[float, float] = (30.0, 45.0)
    time_constant: tuple[float, float] = (200.0, 900.0)


#: A commissioning warm-up: from -20..-10 C to 35..45 C with a time constant of 100-250 s.
COMMISSIONING_WARMUP = ColdStart(
    first=(-20.0, -10.0), last=(35.0, 45.0), time_constant=(100.0, 250.0)
)


def temperature_path(
    t: FloatArray, rng: np.random.Generator, cold_start: bool, warmup: ColdStart | None = None
) -> tuple[FloatArray, str]:
    """Temperature [K] at ``t`` [s] and a label: a cold start (``warmup``, default
    :class:`ColdStart`: -20..5 C warming towards 30..45 C with a time constant of 200-900 s)
    or an ambient 10..35 C with a drift of up to +-1 C per 10 min."""
    if cold_start:
        w = warmup or ColdStart()
        first = rng.uniform(*w.first)
        last = rng.uniform(*w.last)
        tau = rng.uniform(*w.time_constant)
        celsius = last + (first - last) * np.exp(-t / tau)
        label = f"cold start {first:.1f} -> {last:.1f} C (tau {tau:.0f} s)"
    else:
        ambient = rng.uniform(10.0, 35.0)
        drift = rng.uniform(-1.0, 1.0) / 600.0
        celsius = ambient + drift * t
        label = f"ambient {ambient:.1f} C"
    return np.asarray(celsius + CELSIUS_ZERO), label


def draw_trajectory(
    seed: int,
    duration: float,
    *,
    step: float = 1e-3,
    kinds: tuple[str, ...] = SEGMENT_KINDS,
    cold_start: bool | None = None,
    preload: float | None = None,
    top_rpm: float = PEAK_SPEED_RPM[1],
    warmup: ColdStart | None = None,
) -> Trajectory:
    """A random duty cycle of ``duration`` [s] on a grid of ``step`` [s].

    Args:
        seed: seed of this trajectory's own generator.
        kinds: segment kinds to draw from.
        cold_start: force a cold start (True), an ambient run (False); None: 1 in 4 cold.
        preload: set preload [N]; None: drawn from 600-2500 N.
        top_rpm: highest peak speed [rpm].
        warmup: how a cold start warms (default :class:`ColdStart`).
    """
    if not (math.isfinite(duration) and duration > 0.0 and 0.0 < step < duration):
        raise ConfigError(f"duty cycle: duration = {duration!r} s, step = {step!r} s invalid")
    unknown = sorted(set(kinds) - set(SEGMENT_KINDS))
    if unknown or not kinds:
        raise ConfigError(f"duty cycle: kinds {unknown or kinds} not among {SEGMENT_KINDS}")
    rng = np.random.default_rng([seed, 0xD17])
    time = np.arange(round(duration / step), dtype=np.float64) * step
    speed = np.zeros_like(time)
    segments: list[tuple[float, str]] = []
    start = 0.0
    while start < duration:
        length = rng.uniform(*SEGMENT_LENGTH)
        kind = str(rng.choice(list(kinds)))
        inside = (time >= start) & (time < start + length)
        local = time[inside] - start
        if len(local):
            # Each segment starts and ends at standstill (a stop between two tasks), faded in
            # and out over 0.2 s so that the drive's acceleration stays bounded at the joins.
            fade = np.clip(np.minimum(local, length - local) / 0.2, 0.0, 1.0)
            speed[inside] = segment_speed(kind, local, rng, top_rpm) * fade
            segments.append((start, kind))
        start += length
    cold = bool(rng.uniform() < 0.25) if cold_start is None else cold_start
    temperature, label = temperature_path(time, rng, cold, warmup)
    set_preload = float(rng.uniform(600.0, 2500.0)) if preload is None else preload
    segments.insert(0, (0.0, label))
    return Trajectory(
        time=time,
        speed=np.asarray(speed, dtype=np.float64),
        temperature=temperature,
        preload=np.full_like(time, set_preload),
        segments=tuple(segments),
    )
