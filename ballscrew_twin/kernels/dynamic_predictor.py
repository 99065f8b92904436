"""Newton's first guess of the dynamic step (numba): the velocities extrapolated from the starts
of the last steps.

:func:`predict` extrapolates u_n, u_{n-1}, ... to the step's end at the order, 0 to
PREDICTOR_ORDER, that predicted the last step best; :func:`remember` keeps the starts (in
caller-owned arrays, layout H_* of :mod:`.dynamic_layouts`) and picks that order. The compiled
twin of ``DynamicModel._predict`` and ``_remember``, called by
:func:`ballscrew_twin.kernels.dynamic_step.step_kernel`. Velocities in m/s and rad/s.
"""

from __future__ import annotations

import math

from numba import njit

from .dynamic_layouts import H_COUNT, H_NEXT_TIME, H_ORDER, K_BALL_RADIUS, K_DT, K_PITCH_RADIUS

#: Extrapolation u_n, u_{n-1}, ... -> u_{n+1} of each order, padded to four coefficients
#: (models/dynamic.py has the readable copy).
PREDICTOR_COEFFICIENTS = ((1.0, 0.0, 0.0, 0.0), (2.0, -1.0, 0.0, 0.0), (3.0, -3.0, 1.0, 0.0),
                          (4.0, -6.0, 4.0, -1.0))  # fmt: skip


@njit(cache=True)
def extrapolate(order, row, column, now, history):
    """Velocity component extrapolated at ``order`` from ``now`` (u_n) and history[0..order-1]
    (u_{n-1}, ...) at (row, column)."""
    coefficients = PREDICTOR_COEFFICIENTS[order]
    value = coefficients[0] * now
    for j in range(order):
        value += coefficients[j + 1] * history[j, row, column]
    return value


@njit(cache=True)
def predict(u0, shared0, time, jammed, history, meta, u, shared):
    """Newton's first guess (DynamicModel.predict): u_n extrapolated at the order meta[H_ORDER]
    from the starts of the last steps when the step continues the last one (``time`` [s] is
    meta[H_NEXT_TIME]); else ``u``, ``shared`` are left as given (u_n). A jammed sphere's
    rotation stays zero. Returns True when it extrapolated.

    history (PREDICTOR_ORDER, B + 1, 6): u_{n-1}, u_{n-2}, ... (sphere rows; row B holds the
    screw speed and nut velocities in columns 0-2); meta (3,): layout H_*.
    """
    count = u0.shape[0]
    order = int(meta[H_ORDER])
    if meta[H_NEXT_TIME] != time or order == 0:
        return False
    for i in range(count):
        for k in range(6):
            u[i, k] = extrapolate(order, i, k, u0[i, k], history)
            if jammed[i] and k >= 3:
                u[i, k] = 0.0
    for k in range(3):
        shared[k] = extrapolate(order, count, k, shared0[k], history)
    return True


@njit(cache=True)
def remember(u0, shared0, u, shared, time, c, history, meta):
    """After a step from ``time`` [s]: the order for the next step is the one whose prediction
    came closest to the converged velocities ``u``, ``shared`` (largest difference over all
    components, angular velocities times the ball radius, screw speed times the pitch radius,
    in m/s; ties to the lower order); u0, shared0 join the history (DynamicModel.remember)."""
    count = u0.shape[0]
    depth = history.shape[0]
    kept = int(meta[H_COUNT]) if meta[H_NEXT_TIME] == time else 0
    best = 0
    best_error = math.inf
    for order in range(min(kept, depth) + 1):
        error = 0.0
        for i in range(count):
            for k in range(6):
                weight = 1.0 if k < 3 else c[K_BALL_RADIUS]
                guess = extrapolate(order, i, k, u0[i, k], history)
                error = max(error, weight * abs(guess - u[i, k]))
        for k in range(3):
            weight = c[K_PITCH_RADIUS] if k == 0 else 1.0
            guess = extrapolate(order, count, k, shared0[k], history)
            error = max(error, weight * abs(guess - shared[k]))
        if error < best_error:
            best = order
            best_error = error
    for j in range(depth - 1, 0, -1):
        history[j, :, :] = history[j - 1]
    for i in range(count):
        for k in range(6):
            history[0, i, k] = u0[i, k]
    for k in range(3):
        history[0, count, k] = shared0[k]
    meta[H_NEXT_TIME] = time + c[K_DT]
    meta[H_COUNT] = min(kept + 1, depth)
    meta[H_ORDER] = best
