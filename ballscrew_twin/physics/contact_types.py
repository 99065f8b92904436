"""The data of one contact evaluation: what goes in (a scene) and what comes out.

Both implementations of the contact laws use these types: the readable numpy reference
(:mod:`ballscrew_twin.models.contact_forces`, which also builds a scene with ``make_scene``) and
its compiled twin (:mod:`ballscrew_twin.kernels.contacts`). They live here, below both, so that
the kernels do not import the models. SI units throughout.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..params import ScrewGeometry, TwinConfig
from .hertz import HertzContact

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class ContactScene:
    """Per-operating-point constants of the contact laws (computed once per solve)."""

    config: TwinConfig
    geometry: ScrewGeometry  # at the scene's temperature
    temperature: float  # K
    screw_speed: float  # rad/s
    e_star: float  # Pa, Hertz modulus
    e_reduced: float  # Pa, E' = 2 E*
    viscosity_atm: float  # Pa s, eta_0T at the temperature
    ball_mass: float  # kg
    ball_inertia: float  # kg m^2
    deformation_ball_share: float  # delta_ball / delta (Eq. 20-21)
    surface_radius: float  # m, R_c of MC


@dataclass(frozen=True)
class ContactEvaluation:
    """Everything the contacts do to the balls for one set of ball states.

    Array shapes: B balls, 4 half grooves; vectors have a last axis (t, n, b).
    """

    force: FloatArray  # (B, 3) N, total force on each ball incl. gravity and inertia
    moment: FloatArray  # (B, 3) N m, total moment on each ball about its centre incl. inertia
    groove_force: FloatArray  # (B, 4, 3) N, force of the ball on each half groove
    groove_moment_z: FloatArray  # (B, 4) N m, moment about the screw axis on each half groove
    active: NDArray[np.bool_]  # (B, 4)
    approach: FloatArray  # (B, 4) m
    contact_angle: FloatArray  # (B, 4) rad
    hertz: HertzContact  # fields (B, 4)
    film_total: FloatArray  # (B, 4) m
    tallian: FloatArray  # (B, 4)
    load_share: FloatArray  # (B, 4)
    slip: FloatArray  # (B, 4) m/s, |v_t| at the contact centre
    spin: FloatArray  # (B, 4) rad/s, relative spin about the normal
    roll: FloatArray  # (B, 4) rad/s, relative rolling speed
    entrainment: FloatArray  # (B, 4) m/s, u of Eq. 23 along t
    friction_lubricant: FloatArray  # (B, 4) N, lubricant part of F_t at the centre slip
    friction_dry: FloatArray  # (B, 4) N, dry part of F_t at the centre slip
    shear_stress: FloatArray  # (B, 4) Pa, at the characteristic sliding speed
    sliding_coefficient: FloatArray  # (B, 4) mu_s
    dissipation: dict[str, FloatArray]  # mechanism -> (B, 4) W
