"""The unit's Eyring stress and boundary friction, fitted at commissioning for the classes.

The monitor compares the measured torque with the real-time map corrected to the unit (its
shape and residual surface, :mod:`.correction`): that corrects the *level* of the twin's drag.
A fault's class, though, is judged by how the torque *changes* with each fault (a thinner oil,
debris: :data:`.residuals.FAULT_CHANGES`), and that change depends on the unit's own friction
laws. A unit whose Eyring stress tau_e (Eq. 35) is 0.77 x nominal and whose mu_dry (Eq. 36)
is 1.20 x responds to a 40 % viscosity loss as the nominal twin does to debris: dev unit 16013
of issue 13's round 17, named ``jam_onset`` at confidence 1.00; with the twin's responses at
the unit's own tau_e and mu_dry the same alarm is named ``lubricant_degradation`` at 1.00,
with 0.45 fitted against the true 0.40.

So the commissioning also fits the scales (s_tau, s_mu) of tau_e and mu_dry, with dT_f, a
change of the main fit's temperature shift dT (tau_e and mu_dry shape the speed dependence
partly as the viscosity does, which the main fit, with the nominal laws, took as dT). dT_f
only frees the fit: the responses are read at the main fit's shift, as the monitor's twin
is. Dev unit 16023 (tau_e 0.79, mu_dry 0.72, viscosity 1.17 x nominal; main fit dT = -2.4 K)
was fitted at 0.78, 0.70 and dT_f = +2.0 K; with its responses read 2.0 K warmer its 40 %
viscosity loss was named ``jam_onset`` at 0.68, at the main fit's shift
``lubricant_degradation`` at 1.00 with 0.42 fitted (the warmer reading undoes part of the
shift that stands for the unit's thicker oil). On up to
:data:`FIT_POINTS` quiet blocks of the recording (compared blocks whose inertia torque is below
:data:`QUIET_SHARE` of the torque, evenly picked), with z_j - b their bias-free means and
(w_j, T_j, F_j) the unit's operating point of the main fit (the load cell's preload x k_F, the
temperature + dT), the misfit of the steady model (Eqs. 1-45) with tau_e and mu_dry scaled is

    r_j = (z_j - b - g T_ss(w_j, T_j + dT_f, F_j; s_tau, s_mu)) / |z_j| / 1 %,

g the gain that fits the blocks best for each (s_tau, s_mu, dT_f) (weighted least squares: it
takes the sensor's gain and the common friction level that the map's correction holds). The
misfit is evaluated on a grid (:data:`SCALE_NODES` squared, the production spreads of issue
13, +-30 %, times :data:`SHIFT_NODES`), and from the grid's best node scipy's trust-region
least squares with a soft-L1 loss (as the main fit) polishes it inside the grid's range. The
cost has a long valley (tau_e down with mu_dry up, or a warmer shift), which a grid alone
misses: steady drags of a unit with 0.8 and 1.2 and 2 K, 16 blocks without noise, put the
grid's best node at 0.7, 1.0 and 3 K; the polish finds 0.8, 1.2 and 2 K. With noise and the
unit's other departures (Stribeck, presliding) the fitted point lies somewhere along the
valley rather than on the unit's true values; what the classes need is a twin whose responses
are those of a unit that explains the recording.

What it changed on dev units (``bench detection``'s seeds, each run's class named with the
nominal responses and with the fitted ones): see docs/model.md section 16.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from ..errors import BallscrewTwinError, ConfigError
from ..models.base import OperatingPoint
from ..params import TwinConfig
from .residuals import FloatArray, make_twin_model

#: Scales of tau_e and mu_dry at which the cost is evaluated [-] (the spreads of issue 13).
SCALE_NODES = (0.7, 0.85, 1.0, 1.15, 1.3)
#: Changes of the main fit's temperature shift dT at which the cost is evaluated [K] (+-6 K,
#: the shift's production spread of 5 K: tau_e and mu_dry shape the speed dependence partly
#: as the viscosity does, which the main fit took as dT with the nominal friction laws).
SHIFT_NODES = (-6.0, -3.0, 0.0, 3.0, 6.0)
#: Relative misfit of a block taken as one sigma, and the misfit (in those sigmas) beyond
#: which a block counts linearly (soft-L1 loss), as in the main fit [-].
FIT_SIGMA = 0.01
ROBUST_SCALE = 3.0
#: Most evaluations of the misfit while polishing [-].
MAX_EVALUATIONS = 60
#: Most blocks the fit uses [-].
FIT_POINTS = 48
#: Largest share of a block's torque that its inertia torque may be for the fit [-].
QUIET_SHARE = 0.05


def scaled_friction(
    config: TwinConfig, eyring_scale: float, dry_friction_scale: float
) -> TwinConfig:
    """``config`` with tau_e (Eq. 35) times ``eyring_scale`` and mu_dry (Eq. 36) times
    ``dry_friction_scale`` [-] (``config`` itself when both are 1)."""
    if eyring_scale == 1.0 and dry_friction_scale == 1.0:
        return config
    for name, value in (("eyring_scale", eyring_scale), ("dry_friction_scale", dry_friction_scale)):
        if not (math.isfinite(value) and value > 0.0):
            raise ConfigError(f"friction scales: {name} = {value!r} must be > 0")
    lubricant = config.lubricant
    contact = config.contact
    return replace(
        config,
        lubricant=replace(lubricant, eyring_stress=lubricant.eyring_stress * eyring_scale),
        contact=replace(
            contact,
            dry_friction_coefficient=contact.dry_friction_coefficient * dry_friction_scale,
        ),
    )


def friction_misfit(measured: FloatArray, drag: FloatArray) -> FloatArray:
    """Relative misfit of ``measured`` bias-free block means [N m] by ``drag`` [N m] times the
    gain that fits them best (weighted least squares), each over its |measured| [-]."""
    scale = np.abs(measured) + 1e-3 * float(np.max(np.abs(measured)))
    z, d = measured / scale, drag / scale
    gain = float(z @ d) / float(d @ d)
    return np.asarray(z - gain * d)


def fit_friction_scales(
    measured: FloatArray,
    points: Sequence[OperatingPoint],
    config: TwinConfig,
    model_factory: Callable[[TwinConfig], Any] = make_twin_model,
) -> tuple[float, float]:
    """(s_tau, s_mu) [-] with which the steady model explains ``measured``, the bias-free
    quiet block means [N m] at the unit's operating ``points`` of the main fit, together with
    a change dT_f of its temperature shift that is fitted and dropped (see the module
    docstring); (1, 1) when fewer than 6 points or a solve fails (then the nominal responses
    stand)."""
    if len(points) < 6 or len(measured) != len(points):
        return 1.0, 1.0

    def drag(eyring: float, dry: float, shifts: Sequence[float]) -> list[FloatArray]:
        model = model_factory(scaled_friction(config, eyring, dry))
        return [
            np.array(
                [
                    model.evaluate(replace(op, temperature=op.temperature + shift)).drag_torque
                    for op in points
                ]
            )
            for shift in shifts
        ]

    def misfit(x: FloatArray) -> FloatArray:
        (values,) = drag(float(x[0]), float(x[1]), (float(x[2]),))
        return friction_misfit(measured, values) / FIT_SIGMA

    try:
        costs = np.array(
            [
                [
                    [
                        float(np.sum(friction_misfit(measured, d) ** 2))
                        for d in drag(e, m, SHIFT_NODES)
                    ]
                    for m in SCALE_NODES
                ]
                for e in SCALE_NODES
            ]
        )
        if not np.all(np.isfinite(costs)):
            return 1.0, 1.0
        i, j, k = np.unravel_index(int(np.argmin(costs)), costs.shape)
        start = np.array([SCALE_NODES[i], SCALE_NODES[j], SHIFT_NODES[k]])
        fit = least_squares(
            misfit,
            start,
            bounds=(
                [SCALE_NODES[0], SCALE_NODES[0], SHIFT_NODES[0]],
                [SCALE_NODES[-1], SCALE_NODES[-1], SHIFT_NODES[-1]],
            ),
            x_scale=np.array([0.1, 0.1, 1.0]),
            diff_step=1e-4,
            loss="soft_l1",
            f_scale=ROBUST_SCALE,
            max_nfev=MAX_EVALUATIONS,
        )
    except (BallscrewTwinError, ValueError):  # a failed solve, or a non-finite torque
        return 1.0, 1.0
    return float(fit.x[0]), float(fit.x[1])
