"""Around a fold of the start-up path: pseudo-arclength continuation of the steady state.

Where the start-up path (:func:`~ballscrew_twin.models.steady_continuation.startup_continuation`)
can take no step up in speed that stays on its state, the state usually ends at a fold (a
saddle-node: the state and an unstable one meet and vanish). A screw whose speed is raised
slowly past it leaves along the curve's direction there; where the curve of steady states is
an S (hysteresis), it reaches the S's other stable arm. :func:`follow_fold` traces the curve
of steady states through the fold in (state, ln |speed|), whatever its shape, until it moves
up in speed past the fold again, and returns the state there (docs/model.md section 7a, "Past
a fold"). Before this, the path jumped by Newton solves from starts beyond the fold and took
the first that converged: which state it landed on was decided by Newton's basins, and the
state reached flickered between two at neighbouring preloads (32 mm screw, 407.5 rpm, 0.16 C:
17, 18.5 and 20 N rolling, 18, 19 and 21 N travelling with the nut).

The unknowns of the curve are the sphere and nut offsets over :data:`LENGTH_SCALE` and the
rates over the speed, with ln |speed|; the residuals are the steady solver's scaled ones: with
the compiled backend the compiled solver's, whose exact sphere Jacobian blocks give the
curve's Jacobian but for one forward difference along ln |speed|; with the readable backends
the readable reference's (:class:`~ballscrew_twin.models.steady_reference.ReadableNewton`),
differentiated by forward differences. The curve's dense bordered system (a null vector by
SVD) serves the two-sphere problems (one sphere per nut: the symmetric one and the averaged one
of a full cold solve), not the full one (:data:`SPHERES`). Units: SI (m, rad/s, N).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from .base import OperatingPoint
from .steady_compiled import kernel_inputs
from .steady_types import BallSet, SteadyState

if TYPE_CHECKING:
    from .steady import SteadyStateModel

FloatArray = NDArray[np.float64]

#: Length that scales the offsets in the curve's metric [m] (a contact approach's order).
LENGTH_SCALE = 1e-6
#: Relative forward-difference step of the curve's Jacobian [-].
DIFFERENCE_STEP = 1e-7
#: First, longest and shortest step along the curve (scaled arclength) [-].
FIRST_STEP = 1e-3
MAX_STEP = 0.3
MIN_STEP = 1e-8
#: A step is kept when its corrector (chord iterations on the last point's Jacobian) converges
#: to CORRECTOR_TOLERANCE (worst scaled residual) within CORRECTOR_ITERATIONS, moves at most
#: DRIFT times the step (plus DRIFT_FLOOR, the corrector's own correction of a point converged
#: near a fold) off its predictor and turns the tangent by less than acos(MIN_COSINE);
#: otherwise it is halved. After a kept step it grows by GROWTH.
CORRECTOR_TOLERANCE = 1e-9
CORRECTOR_ITERATIONS = 12
DRIFT = 0.3
DRIFT_FLOOR = 1e-4
MIN_COSINE = 0.95
GROWTH = 1.5
#: The curve is followed until it moves up in speed past the fold speed times PAST [-]; it is
#: given up after MAX_STEPS steps or once its speed leaves [fold / WINDOW, fold x WINDOW].
PAST = 1.004
MAX_STEPS = 600
WINDOW = 2.0
#: The curve is given up where a sphere's rate leaves +-RATE_LIMIT times the screw speed [-]
#: (rolling: orbital rate about 0.5, spin about 6): the traction is nearly flat in the slip
#: (section 6), so along some curves a spin about the contact chord grows without bound.
RATE_LIMIT = 20.0
#: Sphere count of the problems followed so: one per nut (the symmetric and the averaged
#: problems of a cold solve; :meth:`_Curve.jacobian`'s differences rely on it) [-].
SPHERES = 2


def _pack(state: SteadyState) -> FloatArray:
    """The curve's coordinates of ``state``: offsets / LENGTH_SCALE, rates / speed, ln |speed|."""
    rates = state.kinematics / state.screw_speed
    return np.concatenate(
        [
            state.ball_nb.ravel() / LENGTH_SCALE,
            rates.ravel(),
            state.nut_offset / LENGTH_SCALE,
            [math.log(abs(state.screw_speed))],
        ]
    )


def _speed(y: FloatArray, sign: float) -> float:
    """The screw speed [rad/s] of the curve's coordinates ``y`` (of ``sign``; ln |speed| capped
    at 50 so that an absurd corrector iterate does not overflow)."""
    return sign * math.exp(min(float(y[-1]), 50.0))


def _unpack(y: FloatArray, count: int, sign: float) -> SteadyState:
    """The state at the curve's coordinates ``y`` (``count`` spheres, speed of ``sign``)."""
    speed = _speed(y, sign)
    return SteadyState(
        y[: 2 * count].reshape(count, 2) * LENGTH_SCALE,
        y[2 * count : 6 * count].reshape(count, 4) * speed,
        y[6 * count : 6 * count + 2] * LENGTH_SCALE,
        speed,
    )


class _Curve:
    """The scaled residual of ``op``'s temperature and loads as a function of the curve's
    coordinates, and its Jacobian (rows: residuals; columns: coordinates, speed last).

    With the compiled backend both come from the compiled solver's sphere evaluation
    (:func:`~ballscrew_twin.kernels.steady_solver.evaluate_compiled`: the exact sphere blocks,
    scaled to the curve's coordinates, and one forward difference along ln |speed|); with the
    readable backends from the readable reference, differentiated by forward differences."""

    def __init__(
        self, model: SteadyStateModel, op: OperatingPoint, balls: BallSet, loads: FloatArray
    ) -> None:
        self.model, self.op, self.balls, self.loads = model, op, balls, loads
        self.count = len(balls.nut)
        self.sign = math.copysign(1.0, op.screw_speed)
        self.compiled = model.backend == "compiled"
        if self.compiled:
            # The scene's parameters differ from speed to speed in the screw speed alone
            # (SteadyStateModel.scene replaces it in the temperature's scene); the residual
            # scales do not depend on the speed.
            scene = model.scene(op.temperature, op.screw_speed)
            inputs = kernel_inputs(model, scene, loads)
            self._scales, self._parameters = inputs.scales, inputs.parameters.copy()

    def _evaluate(self, y: FloatArray, partials: bool) -> tuple[FloatArray, FloatArray | None]:
        """(Scaled residuals at ``y``, the compiled sphere blocks when ``partials``);
        non-finite residuals where a corrector iterate is absurd (its overflow is not news:
        :meth:`correct` rejects it)."""
        count = self.count
        with np.errstate(over="ignore", invalid="ignore"):
            speed = _speed(y, self.sign)
            rates = y[2 * count : 6 * count].reshape(count, 4) * speed
            if not (np.isfinite(rates).all() and math.isfinite(speed)):
                return np.full(6 * count + 2, np.nan), None
            if not self.compiled:
                state = _unpack(y, count, self.sign)
                scene = self.model.scene(self.op.temperature, speed)
                spheres, _, nuts, _ = self.model._reference.residual(
                    scene, self.balls, state, self.loads
                )
                return np.concatenate([spheres.ravel(), nuts]), None
            self._parameters[self.model._solver.I_SCREW_SPEED] = speed
            spheres, nuts, blocks = self.model._solver.evaluate_compiled(
                np.concatenate([y[: 2 * count].reshape(count, 2) * LENGTH_SCALE, rates], axis=1),
                y[6 * count : 6 * count + 2] * LENGTH_SCALE,
                self.balls.nut,
                self.balls.weight,
                self.balls.gravity,
                self.loads,
                self._scales,
                self.model.inertial_terms,
                self._parameters,
                partials,
            )
        return np.concatenate([spheres.ravel(), nuts]), blocks

    def residual(self, y: FloatArray) -> FloatArray:
        """Scaled residuals at ``y`` (non-finite where the iterate is absurd)."""
        return self._evaluate(y, partials=False)[0]

    def jacobian(self, y: FloatArray) -> FloatArray:
        """The Jacobian at ``y``: the sphere and nut columns from the compiled sphere blocks
        (:meth:`_scaled_blocks`) or by forward differences (:meth:`_differenced`), the speed's
        column by a forward difference."""
        base, blocks = self._evaluate(y, partials=self.compiled)
        if blocks is None:
            jacobian = self._differenced(y, base)
        else:
            jacobian = self._scaled_blocks(blocks, _speed(y, self.sign))
        step = DIFFERENCE_STEP * max(1.0, abs(float(y[-1])))
        moved = y.copy()
        moved[-1] += step
        jacobian[:, -1] = (self.residual(moved) - base) / step
        return jacobian

    def _scaled_blocks(self, blocks: FloatArray, speed: float) -> FloatArray:
        """The Jacobian's columns but the speed's from the compiled blocks (B, 7, 7): sphere
        i's rows and its push on nut k (row 6) by its (n, b, w_B, omega) and e_k, times
        LENGTH_SCALE for the offsets and ``speed`` [rad/s] for the rates (chain rule of
        :func:`_unpack`)."""
        count = self.count
        jacobian = np.zeros((6 * count + 2, 6 * count + 3))
        column_scale = np.array([LENGTH_SCALE] * 2 + [speed] * 4 + [LENGTH_SCALE])
        for i, k in enumerate(self.balls.nut.tolist()):
            scaled = blocks[i] * column_scale
            columns = np.r_[2 * i : 2 * i + 2, 2 * count + 4 * i : 2 * count + 4 * i + 4]
            columns = np.append(columns, 6 * count + k)
            jacobian[6 * i : 6 * i + 6, columns] = scaled[:6]
            jacobian[6 * count + k, columns] += scaled[6]
        return jacobian

    def _differenced(self, y: FloatArray, base: FloatArray) -> FloatArray:
        """The Jacobian's columns but the speed's by forward differences, one unknown of every
        sphere at a time: with one sphere per nut each sphere's rows and its nut's row depend
        on that sphere's unknowns and that nut's offset alone, so 8 columns of differences
        give the 6 x count + 2 of them."""
        count = self.count
        jacobian = np.zeros((len(base), len(y)))
        rows = [np.r_[6 * i : 6 * i + 6, 6 * count + i] for i in range(count)]
        groups = [[2 * i + j for i in range(count)] for j in range(2)]  # offsets n, b
        groups += [[2 * count + 4 * i + j for i in range(count)] for j in range(4)]  # rates
        groups += [[6 * count + i for i in range(count)]]  # each sphere's nut offset
        for columns in groups:
            steps = DIFFERENCE_STEP * np.maximum(1.0, np.abs(y[columns]))
            moved = y.copy()
            moved[columns] += steps
            change = self.residual(moved) - base
            for i, column in enumerate(columns):
                jacobian[rows[i], column] = change[rows[i]] / steps[i]
        return jacobian

    @staticmethod
    def tangent(jacobian: FloatArray, along: FloatArray) -> FloatArray:
        """Unit null vector of ``jacobian``, oriented like ``along``."""
        null = np.linalg.svd(jacobian)[2][-1]
        return null if float(null @ along) >= 0.0 else -null

    def correct(
        self, predicted: FloatArray, tangent: FloatArray, jacobian: FloatArray
    ) -> FloatArray | None:
        """Chord Newton (``jacobian``, the last point's) on the residual and the plane through
        ``predicted`` normal to ``tangent``; None when it does not converge."""
        y = predicted.copy()
        bordered = np.vstack([jacobian, tangent])
        for _ in range(CORRECTOR_ITERATIONS):
            residual = self.residual(y)
            if not np.isfinite(residual).all():
                return None
            if float(np.max(np.abs(residual))) < CORRECTOR_TOLERANCE:
                return y
            right = np.append(residual, tangent @ (y - predicted))
            try:
                y = y - np.linalg.solve(bordered, right)
            except np.linalg.LinAlgError:
                return None
        return None


def follow_fold(
    model: SteadyStateModel,
    op: OperatingPoint,
    balls: BallSet,
    loads: FloatArray,
    state: SteadyState,
) -> SteadyState | None:
    """The steady state where the curve through ``state`` (the start-up path's last state, at
    ``op``'s temperature and ``loads`` [N]; moving up in speed there) first moves up in speed
    past PAST times ``state``'s speed, followed by pseudo-arclength continuation (module
    docstring); None when the curve leaves the speed window or the rate range, takes no step
    or MAX_STEPS pass, or the problem has not one sphere per nut (:data:`SPHERES`)."""
    if len(balls.nut) != SPHERES or state.screw_speed == 0.0:
        return None
    curve = _Curve(model, op, balls, loads)
    y = _pack(state)
    fold = float(y[-1])
    upward = np.zeros_like(y)
    upward[-1] = 1.0
    jacobian = curve.jacobian(y)
    tangent = curve.tangent(jacobian, upward)  # the path was moving up in speed at its end
    step = FIRST_STEP
    for _ in range(MAX_STEPS):
        while True:
            if step < MIN_STEP:
                return None
            predicted = y + step * tangent
            corrected = curve.correct(predicted, tangent, jacobian)
            if (
                corrected is not None
                and float(np.linalg.norm(corrected - predicted)) <= DRIFT * step + DRIFT_FLOOR
            ):
                there = curve.jacobian(corrected)
                turned = curve.tangent(there, tangent)
                if float(turned @ tangent) > MIN_COSINE:
                    break
            step *= 0.5
        y, tangent, jacobian = corrected, turned, there
        step = min(step * GROWTH, MAX_STEP)
        if y[-1] > fold + math.log(PAST) and tangent[-1] > 0.0:
            return _unpack(y, curve.count, curve.sign)
        rates = y[2 * curve.count : 6 * curve.count]
        if abs(float(y[-1]) - fold) > math.log(WINDOW) or np.max(np.abs(rates)) > RATE_LIMIT:
            return None
    return None
