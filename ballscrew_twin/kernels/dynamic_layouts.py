"""The flat arrays the dynamic step kernel works on, and what each index of them holds.

:mod:`ballscrew_twin.kernels.dynamic_step` and :mod:`ballscrew_twin.kernels.dynamic_run` read and
write these arrays; :mod:`ballscrew_twin.models.dynamic_compiled` and
:mod:`ballscrew_twin.models.simulation` fill and unpack them. numba freezes these indices into
the kernels' cached machine code, so this file is part of their dependency stamps. SI units.
"""

from __future__ import annotations

from .contact_layout import F_DISS_DAMPING, F_DISS_LUBRICANT

# Body state (8,): time [s], screw angle [rad], screw speed [rad/s], controller integral [rad],
# nut positions (2) [m], nut velocities (2) [m/s].
B_TIME, B_ANGLE, B_SPEED, B_INTEGRAL, B_NUT_POS, B_NUT_VEL = 0, 1, 2, 3, 4, 6
N_BODY = 8
# Constants (N_CONST,): step [s], sphere mass [kg] and inertia [kg m^2], gravity vector (3)
# [m/s^2] and magnitude [m/s^2], screw inertia [kg m^2], nut mass [kg], nut weight along -z
# [N] (0 for a horizontal screw), PI gains k_p [N m s/rad], k_i [N m/rad], ball radius [m],
# pitch radius [m], lead / (2 pi) [m], sin and cos of the helix angle, initial nut offsets (2)
# [m], 1 when the positions are implicit (contact actions with the sphere centres at
# x_n + dt v_{n+1} and the screw at phi_n + dt Omega_{n+1}) else 0 (at x_n, phi_n) [-].
(
    K_DT,
    K_MASS,
    K_INERTIA,
    K_GX,
    K_GY,
    K_GZ,
    K_G,
    K_SCREW_INERTIA,
    K_NUT_MASS,
    K_WEIGHT,
    K_KP,
    K_KI,
    K_BALL_RADIUS,
    K_PITCH_RADIUS,
    K_LEAD_RATE,
    K_SIN_HELIX,
    K_COS_HELIX,
    K_NUT_OFFSET0,
) = range(18)
K_IMPLICIT = 19
N_CONST = 20
# Jacobian bookkeeping (3,) int64: valid (0/1), age [steps], refresh interval [steps].
J_VALID, J_AGE, J_INTERVAL = 0, 1, 2
# Step statistics (S_COUNT,): motor torque at the end of the step [N m], moment of the spheres
# on the screw [N m], axial force on each nut (2) [N], total dissipation [W], final scaled
# residual [-], 1 when not converged, contact evaluations made [-], Jacobian evaluations made
# [-], Newton iterations made [-], dissipation per mechanism (7, models.base.DISSIPATION_KEYS
# order) [W], dissipation of each nut's spheres (2) [W].
(
    S_MOTOR,
    S_SCREW_TORQUE,
    S_NUT_FORCE,
    S_DISSIPATION,
    S_RESIDUAL,
    S_UNCONVERGED,
    S_EVALS,
    S_JACOBIANS,
    S_ITERATIONS,
    S_MECHANISMS,
    S_NUT_DISSIPATION,
) = (0, 1, 2, 4, 5, 6, 7, 8, 9, 10, 17)
N_MECHANISMS = F_DISS_DAMPING + 1 - F_DISS_LUBRICANT
S_COUNT = 19
# Rows of a sphere's stacked actions (8,): force (3) [N], moment (3) [N m], its moment on the
# screw about z [N m], its axial force on its nut [N].
N_STACK = 8
# Predictor bookkeeping (3,) float64: the time the next step starts at if it continues the last
# one [s] (NaN: none), the number of earlier starts kept [-], the order to use [-].
H_NEXT_TIME, H_COUNT, H_ORDER = 0, 1, 2
