"""Layout of the contact kernels' output and of the dynamic model's per-contact statics.

:func:`~ballscrew_twin.kernels.contacts.contacts_kernel` returns one stacked (N_ROWS, B, 4)
float64 buffer: row ``CONTACT_FIELDS.index(name)`` per contact quantity (``F_APPROACH`` ...
name the rows), then the groove forces and the balls' forces and moments. The half grooves are
S1, S2, N1, N2 (physics/geometry.py), on the sides ``SIDE_N``, ``SIDE_B``.
"""

from __future__ import annotations

CONTACT_FIELDS = (
    "approach",  # m, raw rigid-body approach (negative when apart)
    "contact_angle",  # rad
    "normal_force",  # N, K_H delta^1.5 (0 when inactive)
    "semi_axis_x",  # m
    "semi_axis_y",  # m
    "hertz_approach",  # m, HertzContact.approach (delta recomputed from b)
    "max_pressure",  # Pa
    "mean_pressure",  # Pa
    "area",  # m^2
    "stiffness",  # N m^-1.5
    "film_total",  # m
    "tallian",  # -
    "load_share",  # -
    "slip",  # m/s
    "spin",  # rad/s
    "roll",  # rad/s
    "entrainment",  # m/s
    "friction_lubricant",  # N
    "friction_dry",  # N
    "shear_stress",  # Pa
    "sliding_coefficient",  # -
    "groove_moment_z",  # N m
    "lubricant_shear",  # W, dissipation rows in models.base.DISSIPATION_KEYS order from here
    "dry_contact",  # W
    "rolling_resistance",  # W
    "hysteresis",  # W
    "curvature",  # W
    "spin_dissipation",  # W (key "spin" of ContactEvaluation.dissipation)
    "normal_damping",  # W, hysteresis damping of Eqs. 18-19 (zero in a steady state)
)
N_FIELDS = len(CONTACT_FIELDS)
(
    F_APPROACH,
    F_ANGLE,
    F_NORMAL_FORCE,
    F_SEMI_X,
    F_SEMI_Y,
    F_HERTZ_APPROACH,
    F_MAX_PRESSURE,
    F_MEAN_PRESSURE,
    F_AREA,
    F_STIFFNESS,
    F_FILM,
    F_TALLIAN,
    F_LOAD_SHARE,
    F_SLIP,
    F_SPIN,
    F_ROLL,
    F_ENTRAINMENT,
    F_FRICTION_LUB,
    F_FRICTION_DRY,
    F_SHEAR_STRESS,
    F_MU_S,
    F_GROOVE_MZ,
    F_DISS_LUBRICANT,
    F_DISS_DRY,
    F_DISS_ROLLING,
    F_DISS_HYSTERESIS,
    F_DISS_CURVATURE,
    F_DISS_SPIN,
    F_DISS_DAMPING,
) = range(N_FIELDS)
# Rows after the per-contact fields: groove force (t, n, b) per contact, then the sphere's force
# and moment (t, n, b) stored in column 0 of the contact axis (the other columns stay 0).
R_GROOVE_FORCE = N_FIELDS
R_FORCE = N_FIELDS + 3
R_MOMENT = N_FIELDS + 6
N_ROWS = N_FIELDS + 9

# Half grooves S1, S2, N1, N2 (physics/geometry.py).
SIDE_N = (1.0, 1.0, -1.0, -1.0)
SIDE_B = (-1.0, 1.0, -1.0, 1.0)
IS_NUT = (False, False, True, True)

# The dynamic model evaluates the contacts of one time step several times at the same positions
# (Newton iterations, Jacobian columns): contacts_statics_kernel keeps what does not depend on
# the velocities, per contact, in one float64 row of N_STATICS values: contact_geometry's
# (d_n, d_b, approach, angle, active as 0/1), then contact_statics' in its order (the three
# vectors d, arm and contact point as three values each); contacts_kinetics_kernel finishes the
# evaluation from it. Together they are contacts_kernel's dynamic path, bit for bit.
N_STATICS = 30
