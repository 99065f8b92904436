"""Compiled Dahl presliding lag of the bench-unit generator (numba).

The compiled twin of :func:`ballscrew_twin.health.bench_units.presliding_reference` (read it first):
the same recurrence, T_k = T_ss,k + (T_k-1 - T_ss,k) exp(-|phi_k - phi_k-1| / phi_c), as one
loop. Why: a generated hour at 200 Hz is 720 000 steps, ~1 s in Python, ~5 ms here;
test/kernels/test_presliding_kernel.py holds the two equal.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


@njit(cache=True)
def presliding_lag(
    steady: FloatArray, angle: FloatArray, presliding_angle: float, start: float
) -> FloatArray:
    """T [N m] lagging ``steady`` [N m] over the screw ``angle`` [rad] with Dahl angle
    ``presliding_angle`` [rad] (> 0), from ``start`` [N m] at the first instant."""
    out = np.empty_like(steady)
    previous = start
    for k in range(steady.shape[0]):
        travel = abs(angle[k] - angle[k - 1]) if k > 0 else 0.0
        decay = math.exp(-travel / presliding_angle)
        previous = steady[k] + (previous - steady[k]) * decay
        out[k] = previous
    return out
