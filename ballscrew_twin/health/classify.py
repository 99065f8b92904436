"""Which fault explains an alarm: responses of each class in the torque residual.

Mean-shift classes are told apart by *how the torque change depends on the operating point*
over the blocks since the estimated onset, each block j with residual r_j against the state
tracked before the onset, standard deviation sigma_j, and the class's response D_j(a) (the
torque change at severity a at that block's operating point, :class:`Response`):

* ``preload_loss``: effective preload (1 - a) F_pr, D = -a F_pr dT/dF (the twin's
  sensitivity, linear in a); torque falls at every speed, roughly in proportion to it.
* ``lubricant_degradation``: viscosity (1 - a) eta, D = T(twin with a thinner oil) - T: the
  film thins, so the lubricant shear and rolling resistance fall at high speed and the dry
  contact share rises at low speed (the torque *rises* there).
* ``jam_onset``: debris between the surfaces, towards seizure: mu_dry (Eq. 36) and both RMS
  roughnesses (Eq. 38) x (1 + a), D = T(twin so changed) - T: more asperity contact and more
  friction in it, a rise that is largest where the film is thin (low speed, hot). "Sudden
  rise" is not assumed: the twin says how the torque changes.

The last two are far from linear in a (near the speed where a viscosity loss changes the
torque's sign, a 30 % loss barely moves it where a 60 % loss raises it): the changed twin is
evaluated at a few severities and D is interpolated linearly in a between them.

The severity may grow during the window (a step, a ramp, an exponential approach): it is
fitted as a piecewise-linear a(t) on knots at 0, 0.5, 1, 2, 4 and 8 s after the estimated onset
(:func:`growth_basis`), every knot value in [0, limit], by bounded non-linear weighted least
squares of r_j = D_j(a(t_j)); the log-likelihood ratio against "no change" is
``LLR = (sum W r^2 - sum W (r - D)^2) / 2`` (W = 1/sigma^2). Every class gets the same free
time profile, so classes compete only on how the change depends on the operating point, at
the severity the data call for. The severity is fitted up to :data:`REPORTED_EXTENT` x the
class's physical limit (a <= 1 for a fraction lost: :data:`SEVERITY_LIMITS`) to report it; a
class that needs more than its limit is scored by its fit bounded at the limit. With equal
priors the posterior of class c is ``exp(LLR_c / phi) / sum exp(LLR / phi)``, its confidence,
where ``phi = max(1, RSS / (n - K))`` is the reduced chi-square of the best fit (RSS its
weighted residual sum of squares over n blocks, K fitted knots), times the blocks per
independent piece of evidence (``correlation``): when even the best class does not explain
the residuals to the noise level (model error, growth that is not piecewise linear), the
sigmas are scaled up by sqrt(phi) before the classes are compared, so small differences in
fit do not look decisive.
At one constant operating point all responses are constant, so any two classes that change
the torque in the same direction there give equal LLRs: with torque alone they are not
separable until the speed or the temperature moves; the confidence then says so (about 1/2).

Ripple classes come from the order-tracked spectral test at the sphere-pass orders
(:func:`defect_orders`): ``raceway_defect`` at the nut- or screw-raceway pass order,
``sphere_defect`` at twice the sphere spin order.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from scipy.optimize import lsq_linear

from ..params import TwinConfig
from .fault_profiles import defect_frequencies
from .residuals import FloatArray

FAULT_CLASSES: tuple[str, ...] = (
    "preload_loss",
    "lubricant_degradation",
    "raceway_defect",
    "sphere_defect",
    "jam_onset",
)
#: Classes decided from the mean torque change.
MEAN_SHIFT_CLASSES: tuple[str, ...] = ("preload_loss", "lubricant_degradation", "jam_onset")
#: Largest physical severity of each mean-shift class [-]: a fraction lost cannot pass 1; a
#: debris rise of mu_dry and roughness beyond x11 is a seizure, not a jam onset.
SEVERITY_LIMITS: dict[str, float] = {
    "preload_loss": 1.0,
    "lubricant_degradation": 1.0,
    "jam_onset": 10.0,
}
#: A class is named only when its fit leaves a reduced chi-square at most this [-]; above it
#: no class explains the residual and the alarm is ``unclassified``.
MAX_REDUCED_CHI_SQUARE = 4.0
#: A severity is fitted up to this multiple of its class's limit to report how far beyond
#: its range the residual would take it [-].
REPORTED_EXTENT = 10.0
#: Most Gauss-Newton steps of a severity fit (about 7 on dev unit 8016's 234 fits).
FIT_ITERATIONS = 40
#: Spectral orders tested, and the class each one indicates.
ORDER_CLASSES: dict[str, str] = {
    "nut_raceway": "raceway_defect",
    "screw_raceway": "raceway_defect",
    "sphere_spin": "sphere_defect",
}


def defect_orders(config: TwinConfig) -> dict[str, float]:
    """Sphere-pass frequencies of the orders tested, as multiples of the screw rotation
    frequency [-]: :func:`.fault_profiles.defect_frequencies` (rolling kinematics, nut fixed)
    at one revolution per second. With g = r_b cos(alpha_0) / r_m, Z spheres on n_t loaded
    turns: nut raceway Z / n_t (1 - g) / 2, screw raceway Z / n_t (1 + g) / 2, sphere spot
    r_m / r_b (1 - g^2)."""
    per_second = defect_frequencies(config, 2.0 * math.pi)
    return {name: per_second[name] for name in ORDER_CLASSES}


@dataclass(frozen=True)
class Classification:
    """Likely fault class of an alarm.

    Attributes:
        fault_class: one of :data:`FAULT_CLASSES`, or "" if none fits.
        confidence: posterior probability of that class [0..1].
        scores: log-likelihood ratio of each class considered [-].
        severities: fitted severity of each mean-shift class at the last block, allowed up to
            :data:`REPORTED_EXTENT` x its limit (fraction of preload or viscosity lost,
            relative rise of mu_dry and roughness for a jam) [-].
        reason: why no class is named ("" when one is).
        reduced_chi_square: weighted residual sum of squares of the best fit per degree of
            freedom [-] (nan for ripple classes).
    """

    fault_class: str
    confidence: float
    scores: dict[str, float]
    severities: dict[str, float]
    reason: str = ""
    reduced_chi_square: float = math.nan


def _posterior(scores: dict[str, float], phi: float) -> dict[str, float]:
    top = max(scores.values())
    weights = {c: math.exp((v - top) / phi) for c, v in scores.items()}
    total = sum(weights.values())
    return {c: w / total for c, w in weights.items()}


#: Knots of the severity's time profile after the onset [s] (hat functions; the last ones
#: beyond the data are dropped).
GROWTH_KNOTS = (0.0, 0.5, 1.0, 2.0, 4.0, 8.0)


def growth_basis(elapsed: FloatArray) -> FloatArray:
    """(n, K) piecewise-linear (hat) basis in time since the onset [s] at the
    :data:`GROWTH_KNOTS` that the data reach, held flat after the last one."""
    t = np.maximum(np.asarray(elapsed, dtype=np.float64), 0.0)
    knots = [k for k in GROWTH_KNOTS if k <= float(np.max(t))] if len(t) else [0.0]
    if len(knots) < 2:
        return np.ones((len(t), 1))
    columns = []
    for i, knot in enumerate(knots):
        column = np.zeros_like(t)
        if i > 0:
            left = knots[i - 1]
            rising = (t >= left) & (t <= knot)
            column[rising] = (t[rising] - left) / (knot - left)
        if i + 1 < len(knots):
            right = knots[i + 1]
            falling = (t >= knot) & (t <= right)
            column[falling] = (right - t[falling]) / (right - knot)
        else:
            column[t >= knot] = 1.0
        columns.append(column)
    return np.column_stack(columns)


@dataclass(frozen=True)
class Response:
    """Torque change a fault class makes at each block, at a few severities.

    Between them, and between 0 (no change) and the first, the change is interpolated
    linearly in the severity; beyond the last it follows the last segment. A class whose
    change is linear in its severity has one severity, 1 (:meth:`linear`).

    Attributes:
        severities: (K,) increasing severities > 0 at which the change is known [-].
        changes: (K, n) torque change at each of them and each block [N m].
    """

    severities: FloatArray
    changes: FloatArray

    @classmethod
    def linear(cls, signature: FloatArray) -> Response:
        """A change ``severity * signature`` [N m] (``signature`` per unit severity)."""
        return cls(np.array([1.0]), np.asarray(signature, dtype=np.float64)[None, :])

    @functools.cached_property
    def _table(self) -> tuple[FloatArray, FloatArray]:
        knots = np.concatenate(([0.0], self.severities))
        values = np.vstack((np.zeros(self.changes.shape[1]), self.changes))
        return knots, values

    def at(self, severity: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Change [N m] and its slope d(change)/d(severity) [N m] at each block's severity."""
        knots, values = self._table
        # the segment [knots[i], knots[i + 1]] holding each severity (the first below 0, the
        # last beyond the last knot)
        segment = np.searchsorted(knots[1:-1], severity, side="right")
        blocks = np.arange(values.shape[1])
        low = values[segment, blocks]
        slope = (values[segment + 1, blocks] - low) / (knots[segment + 1] - knots[segment])
        return low + slope * (severity - knots[segment]), slope


@dataclass(frozen=True)
class _Fit:
    llr: float  # log-likelihood ratio against "no change" [-]
    severity: float  # fitted severity at the last block [-]


def _bounded_least_squares(design: FloatArray, target: FloatArray, upper: float) -> FloatArray:
    """argmin |design b - target| over 0 <= b <= ``upper``."""
    solution = np.asarray(np.linalg.lstsq(design, target, rcond=None)[0], dtype=np.float64)
    if np.all((solution >= 0.0) & (solution <= upper)):
        return solution
    return np.asarray(
        lsq_linear(design, target, bounds=(0.0, upper), method="bvls").x, dtype=np.float64
    )


def _severity_fit(
    residuals: FloatArray, weight: FloatArray, response: Response, basis: FloatArray, upper: float
) -> _Fit:
    """Weighted least squares of r_j = change(a(t_j))_j over a(t) = basis @ b with every knot
    value b_k in [0, ``upper``] (a severity is never negative: no class undoes itself).

    Gauss-Newton on the piecewise-linear response: each step is the bounded linear least
    squares of the response linearised on the segments the blocks' severities lie in (exact
    while they stay there), halved until the sum of squares falls."""
    root = np.sqrt(weight)

    def misfit(b: FloatArray) -> float:
        return float(np.sum(weight * (response.at(basis @ b)[0] - residuals) ** 2))

    # start from the constant severity, among the evaluated ones, that fits best
    starts = [np.full(basis.shape[1], min(float(p), upper)) for p in response.severities]
    costs = [misfit(b) for b in starts]
    b, cost = starts[int(np.argmin(costs))], min(costs)
    for _ in range(FIT_ITERATIONS):
        a = basis @ b
        change, slope = response.at(a)
        design = (root * slope)[:, None] * basis
        step = _bounded_least_squares(design, root * (residuals - change + slope * a), upper) - b
        fraction = 1.0
        trial = misfit(b + step)
        while trial > cost and fraction > 1e-3:
            fraction *= 0.5
            trial = misfit(b + fraction * step)
        if trial > cost:
            break
        converged = cost - trial <= 1e-12 * cost
        b, cost = b + fraction * step, trial
        if converged:
            break
    # no change at all (b = 0) is always allowed: never score below it
    llr = max(0.5 * (float(np.sum(weight * residuals**2)) - cost), 0.0)
    return _Fit(llr, float((basis @ b)[-1]))


def classify_mean_shift(
    residuals: FloatArray,
    sigmas: FloatArray,
    responses: Mapping[str, FloatArray | Response],
    elapsed: FloatArray | None = None,
    correlation: float = 1.0,
) -> Classification:
    """Fit every class's response to the residuals (see the module docstring).

    Args:
        residuals: r_j, block residual against the pre-onset tracked state [N m].
        sigmas: sigma_j, their standard deviations [N m].
        responses: class -> its :class:`Response`, or s_j, the torque change per unit
            severity [N m] of a class linear in its severity.
        elapsed: time of each block since the estimated onset [s]; given, the severity may
            grow in time (piecewise linear on :data:`GROWTH_KNOTS`), which a constant-severity
            fit would misread as a change of shape.
        correlation: blocks per independent one [-] (>= 1): the twin's error is systematic
            over a regime, so neighbouring blocks do not bring independent evidence; the
            log-likelihood ratios are divided by it before the posterior is formed.
    """
    r = np.asarray(residuals, dtype=float)
    weight = 1.0 / np.asarray(sigmas) ** 2
    basis = np.ones((len(r), 1)) if elapsed is None else growth_basis(elapsed)
    scores: dict[str, float] = {}
    severities: dict[str, float] = {}
    for name, given in responses.items():
        response = given if isinstance(given, Response) else Response.linear(given)
        if not np.any(response.changes):
            continue
        limit = SEVERITY_LIMITS.get(name, math.inf)
        free = _severity_fit(r, weight, response, basis, REPORTED_EXTENT * limit)
        severities[name] = free.severity
        # beyond its range the class explains only what its largest severity does
        if free.severity > limit:
            free = _severity_fit(r, weight, response, basis, limit)
        scores[name] = free.llr
    if not scores or max(scores.values()) <= 0.0:
        return Classification(
            "", 0.0, scores, severities, reason="no class changes the torque the way measured"
        )
    rss = float(np.sum(weight * r**2)) - 2.0 * max(scores.values())
    reduced = rss / max(len(r) - basis.shape[1], 1)
    phi = max(1.0, reduced) * max(correlation, 1.0)
    posterior = _posterior(scores, phi)
    best = max(posterior, key=posterior.__getitem__)
    limit = SEVERITY_LIMITS.get(best, math.inf)
    severity = severities.get(best, math.nan)
    if not 0.0 < severity <= limit:
        reason = f"fitted {best} severity {severity:.3g} is outside its range (0, {limit:g}]"
        return Classification("", 0.0, scores, severities, reason, reduced)
    if reduced > MAX_REDUCED_CHI_SQUARE:
        reason = (
            f"no class explains the residual: the best fit ({best}) leaves a reduced "
            f"chi-square of {reduced:.3g} > {MAX_REDUCED_CHI_SQUARE:g}"
        )
        return Classification("", 0.0, scores, severities, reason, reduced)
    return Classification(best, posterior[best], scores, severities, "", reduced)


def classify_ripple(ratios: dict[str, float], threshold: float) -> Classification:
    """Class of the order with the largest power ratio above ``threshold`` [-].

    Confidence: that ratio's share of the excess over the threshold of all orders that fired.
    """
    excess = {name: r - threshold for name, r in ratios.items() if r > threshold}
    if not excess:
        return Classification("", 0.0, dict(ratios), {}, reason="no order above its threshold")
    by_class: dict[str, float] = {}
    for name, value in excess.items():
        cls = ORDER_CLASSES[name]
        by_class[cls] = by_class.get(cls, 0.0) + value
    best = max(by_class, key=by_class.__getitem__)
    return Classification(best, by_class[best] / sum(by_class.values()), dict(ratios), {})
