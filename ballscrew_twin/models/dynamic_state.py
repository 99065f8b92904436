"""The data of the dynamic model: its state, its commanded inputs, its speed controller and
what one step reports.

:class:`~ballscrew_twin.models.dynamic.DynamicModel` advances a :class:`DynamicState` under
:class:`Commands` and returns a :class:`StepReport` per step, by its readable Python step or by
the compiled one (:mod:`.dynamic_compiled`); scenarios (:mod:`.scenario`) and the simulation
runner (:mod:`.simulation`) use these types too. SI units, inertial frame.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..physics.contact_types import ContactEvaluation
from .sphere_contact import SpherePairContact

FloatArray = NDArray[np.float64]


@dataclass
class DynamicState:
    """Positions and velocities of all bodies at time ``time`` (SI, inertial frame)."""

    time: float  # s
    screw_angle: float  # rad
    screw_speed: float  # rad/s
    controller_integral: float  # rad, integral of the speed error
    nut_position: FloatArray  # (2,) m, axial displacement of master and slave nut from start
    nut_velocity: FloatArray  # (2,) m/s
    ball_position: FloatArray  # (B, 3) m
    ball_velocity: FloatArray  # (B, 3) m/s
    ball_omega: FloatArray  # (B, 3) rad/s, absolute angular velocity
    helix_parameter: FloatArray  # (B,) rad, continuous azimuth of each sphere on the thread


@dataclass(frozen=True)
class Commands:
    """Commanded inputs at one instant."""

    screw_speed: float  # rad/s, reference of the speed controller
    preload: float  # N, force pushing the nuts apart


@dataclass(frozen=True)
class SpeedController:
    """PI speed controller of the screw (paper section 3): T = k_p e + k_i int e dt."""

    proportional: float = 0.05  # N m s/rad
    integral: float = 5.0  # N m/rad


@dataclass
class StepReport:
    """What one step computed besides the new state (for outputs and checks)."""

    motor_torque: float  # N m, at the end of the step
    contacts: ContactEvaluation  # at the start of the step
    nut_force: FloatArray  # (2,) N, axial force of the spheres on each nut
    screw_torque: float  # N m, moment of the spheres on the screw about z
    dissipation: float  # W, all contact mechanisms (sphere-to-sphere contacts included)
    sphere_pairs: SpherePairContact | None = None  # sphere-to-sphere contacts, when modelled
    sphere_dissipation: float = 0.0  # W, the part of ``dissipation`` between spheres
    # W, ball-groove contacts: per mechanism (7, models.base.DISSIPATION_KEYS order) and per nut
    mechanism_dissipation: FloatArray = field(default_factory=lambda: np.zeros(7))
    nut_dissipation: FloatArray = field(default_factory=lambda: np.zeros(2))
