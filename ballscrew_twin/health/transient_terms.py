"""The friction's transient terms of a block's uncertainty: what a unit whose friction trails
the screw rotation (presliding, a first-order lag over the angle) does that the quasi-static
twin does not. Pure functions on a block's samples, used by :class:`.monitor.HealthMonitor`;
docs/model.md, section 15 ("Residual and uncertainty"), gives their reasons and the runs.

A first-order lag over the rotation phi, dT/dphi = (T_ss - T) / phi_l, with phi_l the lag
angle [rad], has two consequences that a block's sigma must carry: while the speed sweeps the
quasi-static drag T_ss the friction trails it by phi_l |dT_ss/dphi| (:func:`following_error`),
and after a reversal, where T_ss jumps from -T to T, the friction closes the jump as
2 |T| exp(-phi / phi_l) (:func:`presliding_remainder`).
"""

from __future__ import annotations

import numpy as np

from .residuals import FloatArray


def following_error(
    angle: FloatArray, drag: FloatArray, stamps: FloatArray, lag_angle: float
) -> float:
    """How far a friction that trails the screw rotation trails the quasi-static twin over a
    block [N m]: the time mean of |dT/dphi| times the lag angle. Where the speed sweeps the
    drag (a step, a stop, a sine) the unit's friction follows it over its presliding angle:
    for a first-order lag over the rotation, T - T_ss = -phi_l dT_ss/dphi once the sweep has
    run for a few phi_l. At speed the drag changes little per radian (a sine at 200 rad/s:
    ~0.5 mN m/rad); into a stop it changes a lot (the drag falls steeply near standstill
    while little rotation is left), so a stop keeps its large error and a fast stroke does
    not.

    Args:
        angle: screw angle at the block's evaluated samples [rad].
        drag: quasi-static drag there [N m].
        stamps: their times [s].
        lag_angle: phi_l, the angle over which the friction follows the drag [rad].
    """
    if len(stamps) < 2:
        return 0.0
    turned = np.maximum(np.abs(np.diff(angle)), 1e-12)
    slope = np.abs(np.diff(drag)) / turned
    span = float(stamps[-1] - stamps[0])
    mean_slope = float(np.sum(slope * np.diff(stamps)) / span) if span > 0.0 else 0.0
    return mean_slope * lag_angle


def presliding_remainder(travel: FloatArray, drags: FloatArray, lag_angle: float) -> float:
    """What is left of a reversal's presliding jump over a block [N m]: the mean over its
    samples of 2 |T| exp(-phi / phi_l). At a reversal the quasi-static drag jumps from -T to
    T; a friction that trails the rotation closes the jump over a few lag angles, and the
    monitor's gate, which waits for the settling angle (three lag angles by default), lets
    2 exp(-3) = 10 % of the drag through still to come. After a stop the friction starts
    from where it stood, not from -T, and the term is an upper bound (a restart in the same
    direction leaves nothing to close).

    Args:
        travel: phi, the screw rotation since the last reversal or stop at each sample [rad]
            (:attr:`.residuals.ReversalGate.travel`; inf where none was seen).
        drags: the twin's drag at the same samples [N m] (as many as ``travel``).
        lag_angle: phi_l [rad]; 0 gives 0 (no lag).
    """
    if len(travel) == 0 or lag_angle <= 0.0:
        return 0.0
    return float(np.mean(2.0 * np.abs(drags) * np.exp(-np.asarray(travel) / lag_angle)))
