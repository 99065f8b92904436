"""Small 3-vector operations on tuples, for the compiled kernels (numba, inlined).

The contact laws, the steady Newton kernel and the dynamic step work on (t, n, b) 3-tuples;
these helpers keep numpy's order of floating-point operations (test/kernels checks the kernels
against the numpy references to rounding). Units are those of the arguments.
"""

from __future__ import annotations

import math

from numba import njit


@njit(inline="always")
def _cross(a, b):
    """a x b of two 3-tuples, term order of numpy.cross."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(inline="always")
def _dot(a, b):
    """a . b of two 3-tuples."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(inline="always")
def _add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@njit(inline="always")
def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@njit(inline="always")
def _scale(s, a):
    """s a, scalar times 3-tuple."""
    return (s * a[0], s * a[1], s * a[2])


@njit(inline="always")
def _unit(v):
    """(v / max(|v|, 1e-300), |v|): the zero vector maps to itself with norm 0."""
    norm = math.sqrt(_dot(v, v))
    safe = max(norm, 1e-300)
    return (v[0] / safe, v[1] / safe, v[2] / safe), norm


@njit(inline="always")
def _helical(rate, zhat, lead_rate, r):
    """Velocity of point r [m] in a helical motion of rate ``rate`` [rad/s] about z, lead
    2 pi ``lead_rate`` [m]: rate (z x r + p/(2 pi) z) [m/s] (module docstring of the reference).
    """
    return _scale(rate, _add(_cross(zhat, r), _scale(lead_rate, zhat)))
