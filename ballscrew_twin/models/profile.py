"""Command profiles: one type for a commanded quantity over time (SI units).

A :class:`Profile` is piecewise-linear breakpoints with smooth (cubic) steps added on top
(:func:`smooth_step`). It is evaluated at one time, ``profile(t)``, or at many,
``profile.at(times)``, with the same arithmetic at each time (:func:`smooth_steps` is
:func:`smooth_step` elementwise), so a vectorised caller gets the values a scalar one does.

Its users: the commands of a scene file (``ballscrew_twin.scene``), the speed and preload ramps of
a scenario of the dynamic model (:class:`~.scenario.Scenario`, one smooth step each; the
compiled loop of ``simulate`` evaluates them over a stretch of steps at once) and the
piecewise-linear profile of a bench scene (``health/bench_scene.py``).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import reduce
from operator import add

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]

#: Points inside a smooth step where the extremes of a profile are sought [-] (Profile.knots).
STEP_SAMPLES = 64


def smooth_step(t: float, t0: float, t1: float) -> float:
    """Cubic smooth step: 0 for t <= t0, 1 for t >= t1, 3 s^2 - 2 s^3 with s = (t-t0)/(t1-t0).

    Continuous with a continuous first derivative (zero at both ends). ``t1 == t0`` is a hard
    step at t0 (value 1 from t0 on). Times in any consistent unit (s here).
    """
    if t >= t1:
        return 1.0
    if t <= t0:
        return 0.0
    s = (t - t0) / (t1 - t0)
    return s * s * (3.0 - 2.0 * s)


def smooth_steps(t: FloatArray, t0: float, t1: float) -> FloatArray:
    """:func:`smooth_step` at every time of ``t`` (same arithmetic, so the same values)."""
    if t1 <= t0:
        return np.where(t >= t1, 1.0, 0.0)
    s = np.clip((t - t0) / (t1 - t0), 0.0, 1.0)
    return np.where(t >= t1, 1.0, np.where(t <= t0, 0.0, s * s * (3.0 - 2.0 * s)))


@dataclass(frozen=True)
class SmoothStep:
    """A smooth (cubic) step of ``change`` from ``start`` to ``end`` [s] (``end == start``: a
    hard step at ``start``)."""

    start: float  # s
    end: float  # s
    change: float  # unit of the profile


@dataclass(frozen=True)
class Profile:
    """A commanded quantity over time: piecewise-linear breakpoints plus smooth steps.

    The value is the breakpoints' linear interpolation (held before the first and after the
    last) plus the sum of the steps; without breakpoints, the sum of the steps alone (0 with
    neither).

    Attributes:
        times: breakpoint times [s], strictly increasing.
        values: values at the breakpoints (unit of the quantity).
        steps: smooth steps added on top.
    """

    times: tuple[float, ...] = ()
    values: tuple[float, ...] = ()
    steps: tuple[SmoothStep, ...] = ()

    def __call__(self, t: float) -> float:
        """Value at time ``t`` [s]."""
        rises = [s.change * smooth_step(t, s.start, s.end) for s in self.steps]
        if self.times:
            return float(np.interp(t, self.times, self.values)) + sum(rises)
        return reduce(add, rises) if rises else 0.0

    def at(self, times: ArrayLike) -> FloatArray:
        """Values at every time of ``times`` [s] (as :meth:`__call__` at each)."""
        t = np.asarray(times, dtype=np.float64)
        rises = [s.change * smooth_steps(t, s.start, s.end) for s in self.steps]
        if self.times:
            return np.asarray(np.interp(t, self.times, self.values) + sum(rises))
        return np.asarray(reduce(add, rises)) if rises else np.zeros_like(t)

    def knots(self) -> list[float]:
        """Times at which the extremes of the profile are sought [s]: its breakpoints and the
        ends of its steps (exact for linear pieces and non-overlapping monotone steps), plus
        STEP_SAMPLES points inside each step (overlapping steps of opposite signs can have an
        extreme between their ends)."""
        out = list(self.times)
        for s in self.steps:
            out += list(np.linspace(s.start, s.end, STEP_SAMPLES + 1))
        return out

    def is_constant(self) -> bool:
        """No breakpoint change and no step: the same value at every time."""
        return len(set(self.values)) <= 1 and all(s.change == 0.0 for s in self.steps)
