"""Which fault explains an alarm: signatures of each class in the torque residual.

Mean-shift classes are told apart by *how the torque change depends on the operating point*
over the blocks since the estimated onset, each block j with residual r_j against the state
tracked before the onset, standard deviation sigma_j, and the class's signature s_j (torque
change per unit severity at that block's operating point):

* ``preload_loss``: effective preload (1 - a) F_pr, s = -F_pr dT/dF (the twin's sensitivity);
  torque falls at every speed, roughly in proportion to the torque.
* ``lubricant_degradation``: viscosity (1 - a) eta, s = dT/d(loss) of the twin with a thinner
  oil: the film thins, so the lubricant shear and rolling resistance fall at high speed and
  the dry contact share rises at low speed (the torque *rises* there).
* ``jam_onset``: debris between the surfaces, towards seizure: mu_dry (Eq. 36) and both RMS
  roughnesses (Eq. 38) x (1 + a), s = dT/d(rise) of the twin so changed: more asperity
  contact and more friction in it, a rise that is largest where the film is thin (low speed,
  hot). "Sudden rise" is not assumed: the twin says how the torque changes.

The severity may grow during the window (a step, a ramp, an exponential approach): it is
fitted as a piecewise-linear a(t) on knots at 0, 0.5, 1, 2, 4 and 8 s after the estimated onset
(:func:`growth_basis`) by weighted least squares, r_j = a(t_j) s_j, whose log-likelihood ratio
against "no change" is ``LLR = beta' X' W r / 2`` (X = [s phi_k(t)], W = 1/sigma^2): every
class gets the same free time profile, so classes compete only on how the change depends on
the operating point. A class whose
fitted severity is not positive on average, or passes its physical limit by the end
(a <= 1 for a fraction lost: :data:`SEVERITY_LIMITS`), is fitted with a constant severity
restricted to [0, limit] instead: ``LLR = a sum(s r W) - a^2 sum(s^2 W) / 2`` (0 for the wrong
sign). With equal priors the posterior of class c is ``exp(LLR_c / phi) / sum exp(LLR / phi)``,
its confidence, where ``phi = max(1, RSS / (n - K))`` is the reduced chi-square of the best
fit (RSS its weighted residual sum of squares over n blocks, K fitted values), times the
blocks per independent piece of evidence (``correlation``): when even the best class does
not explain the residuals to the noise level (model error, a non-linear response, growth that
is not linear), the sigmas are scaled up by sqrt(phi) before the classes are compared, so
small differences in fit do not look decisive.
At one constant operating point all signatures are constant, so any two classes that change
the torque in the same direction there give equal LLRs: with torque alone they are not
separable until the speed or the temperature moves; the confidence then says so (about 1/2).

Ripple classes come from the order-tracked spectral test at the sphere-pass orders
(:func:`defect_orders`): ``raceway_defect`` at the nut- or screw-raceway pass order,
``sphere_defect`` at twice the sphere spin order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

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
        severities: unconstrained least-squares severity of each mean-shift class (fraction of
            preload or viscosity lost, relative rise of mu_dry for a jam) [-].
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


def _growing_fit(
    residuals: FloatArray, weight: FloatArray, s: FloatArray, basis: FloatArray
) -> tuple[float, float, float] | None:
    """Weighted least squares of r = a(t) s with a(t) piecewise linear on ``basis``:
    (LLR, mean severity, end severity), None when the profile is not identifiable."""
    design = basis * s[:, None]
    normal = design.T @ (weight[:, None] * design)
    rhs = design.T @ (weight * residuals)
    if np.linalg.cond(normal) > 1e10:
        return None
    beta = np.linalg.solve(normal, rhs)
    severity = basis @ beta
    return 0.5 * float(beta @ rhs), float(np.mean(severity)), float(severity[-1])


def classify_mean_shift(
    residuals: FloatArray,
    sigmas: FloatArray,
    signatures: dict[str, FloatArray],
    elapsed: FloatArray | None = None,
    correlation: float = 1.0,
) -> Classification:
    """Fit every class's signature to the residuals (see the module docstring).

    Args:
        residuals: r_j, block residual against the pre-onset tracked state [N m].
        sigmas: sigma_j, their standard deviations [N m].
        signatures: class -> s_j, torque change per unit severity [N m].
        elapsed: time of each block since the estimated onset [s]; given, the severity may
            grow linearly in time, a(t) = a0 + a1 t (a ramp, or the start of any growth),
            which a constant-severity fit would misread as a change of shape.
        correlation: blocks per independent one [-] (>= 1): the twin's error is systematic
            over a regime, so neighbouring blocks do not bring independent evidence; the
            log-likelihood ratios are divided by it before the posterior is formed.
    """
    r = np.asarray(residuals, dtype=float)
    weight = 1.0 / np.asarray(sigmas) ** 2
    basis = None if elapsed is None else growth_basis(elapsed)
    scores: dict[str, float] = {}
    severities: dict[str, float] = {}
    for name, s in signatures.items():
        ss = float(np.sum(weight * s * s))
        sr = float(np.sum(weight * s * r))
        if ss <= 0.0:
            continue
        limit = SEVERITY_LIMITS.get(name, math.inf)
        severities[name] = sr / ss
        growing = None if basis is None else _growing_fit(r, weight, s, basis)
        if growing is not None and growing[1] > 0.0 and growing[2] <= limit:
            scores[name] = growing[0]
            continue
        severity = min(max(sr / ss, 0.0), limit)
        scores[name] = severity * sr - 0.5 * severity * severity * ss
    if not scores or max(scores.values()) <= 0.0:
        return Classification(
            "", 0.0, scores, severities, reason="no class changes the torque the way measured"
        )
    rss = float(np.sum(weight * r**2)) - 2.0 * max(scores.values())
    fitted = 1 if basis is None else basis.shape[1]
    reduced = rss / max(len(r) - fitted, 1)
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
