"""The friction's transient terms of a block's uncertainty: what a unit whose friction trails
the screw rotation (presliding, a first-order lag over the angle) does that the quasi-static
twin does not. Pure functions on a block's samples, used by :class:`.monitor.HealthMonitor`;
docs/model.md, section 15 ("Residual and uncertainty"), gives their reasons and the runs.

A first-order lag over the rotation phi, dT/dphi = (T_ss - T) / phi_l, with phi_l the lag
angle [rad], has two consequences that a block's sigma must carry: while the speed sweeps the
quasi-static drag T_ss the friction trails it by phi_l |dT_ss/dphi| (:func:`following_error`),
and after a reversal, where T_ss jumps from -T to T, the friction closes the jump as
2 |T| exp(-phi / phi_l) (:func:`presliding_remainder`). The first can also be predicted: the
twin's drag passed through such a lag (:func:`lagged_drag`) trails it by the following error
of that lag's angle; :class:`PredictedLag` carries it from block to block.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from .residuals import FloatArray

#: Least rotation between two samples counted as turning [rad]: below it the screw stood.
LEAST_TURN = 1e-12


def _rotation_slope(angle: FloatArray, drag: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The rotation |d angle| [rad] between successive samples and the drag's slope over it,
    dT/dphi [N m/rad] (the rotation taken as at least LEAST_TURN)."""
    turned = np.abs(np.diff(np.asarray(angle, dtype=float)))
    return turned, np.diff(drag) / np.maximum(turned, LEAST_TURN)


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
    slope = np.abs(_rotation_slope(angle, drag)[1])
    span = float(stamps[-1] - stamps[0])
    mean_slope = float(np.sum(slope * np.diff(stamps)) / span) if span > 0.0 else 0.0
    return mean_slope * lag_angle


def lagged_drag(
    angle: FloatArray, drag: FloatArray, lag_angle: float, start: float | None = None
) -> FloatArray:
    """The quasi-static drag passed through a first-order lag over the screw rotation [N m]:
    dT/dphi = (T_ss - T) / phi_l with phi the rotation, solved exactly for a T_ss linear in
    phi between the samples (stable for any step: T(phi + d) = T_ss(phi + d) - s phi_l +
    (T(phi) - T_ss(phi) + s phi_l) exp(-d / phi_l), with s the slope over the step). Any
    fading memory over the rotation whose kernel has the mean phi_l trails a sweep by the
    same -phi_l dT_ss/dphi (:func:`following_error`); the first-order form is the simplest.

    Args:
        angle: screw angle at the samples [rad] (signed; the rotation is |d angle|).
        drag: quasi-static drag there [N m].
        lag_angle: phi_l [rad]; 0 returns ``drag``.
        start: the lagged drag at the first sample [N m]; None takes the state of a sweep
            that has run at the first step's slope for long (T_ss - s phi_l).
    """
    drag = np.asarray(drag, dtype=float)
    if lag_angle <= 0.0 or len(drag) == 0:
        return drag.copy()
    turned, slope = _rotation_slope(angle, drag)
    slope = np.where(turned > LEAST_TURN, slope, 0.0)
    out = np.empty_like(drag)
    if start is not None:
        out[0] = start
    else:
        out[0] = drag[0] - (slope[0] * lag_angle if len(slope) else 0.0)
    decay = np.exp(-turned / lag_angle)
    for i in range(1, len(drag)):
        trail = slope[i - 1] * lag_angle
        out[i] = drag[i] - trail + (out[i - 1] - drag[i - 1] + trail) * decay[i - 1]
    return out


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


class PredictedLag:
    """The friction's predicted lag behind the twin over a run of blocks: the quasi-static drag
    through :func:`lagged_drag`, going on from the last block's end where the next block
    follows it sample to sample, else from a sweep's steady lag (after a gated stretch)."""

    def __init__(self) -> None:
        #: (stamp [s], lagged minus quasi-static drag [N m]) at the last evaluated sample.
        self._end: tuple[float, float] | None = None

    def block(
        self,
        stamps: FloatArray,
        at: npt.NDArray[np.intp],
        angle: FloatArray,
        quasi: FloatArray,
        lag_angle: float,
    ) -> FloatArray:
        """The lag T - T_ss [N m] at every one of a block's ``stamps`` [s], from the
        quasi-static drag ``quasi`` [N m] and screw ``angle`` [rad] at its evaluated samples
        ``at``, for the lag angle ``lag_angle`` [rad] (0: zeros, nothing carried on)."""
        if lag_angle <= 0.0:
            return np.zeros(len(stamps))
        evaluated = stamps[at]
        step = float(np.median(np.diff(stamps))) if len(stamps) > 1 else 0.0
        start = None
        if self._end is not None and 0.0 < evaluated[0] - self._end[0] <= 1.5 * step:
            start = float(quasi[0]) + self._end[1]
        lagged = lagged_drag(angle, quasi, lag_angle, start)
        self._end = (float(evaluated[-1]), float(lagged[-1] - quasi[-1]))
        return np.interp(stamps, evaluated, lagged - quasi)
