"""What a run of the dynamic model records: :class:`SimulationResult` (SI units).

Filled by :func:`ballscrew_twin.models.simulation.simulate`, summarised by
:mod:`.simulation_summary`, written by :mod:`ballscrew_twin.results`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .base import DISSIPATION_KEYS
from .scenario import Scenario

FloatArray = NDArray[np.float64]

#: Dissipation mechanisms of the contact laws, in the order of the result's columns.
MECHANISMS = DISSIPATION_KEYS

#: Speeds below this are treated as standstill when dividing a power by the speed [rad/s].
STANDSTILL_SPEED = 1e-9


@dataclass
class SimulationResult:
    """Recorded time series, contact states and summary of one run (SI units).

    Time series (length N, every output interval): ``time`` [s], ``speed_command`` [rad/s],
    ``preload_command`` [N], ``screw_speed`` [rad/s], ``motor_torque`` [N m], ``screw_torque``
    (spheres on the screw about z) [N m], ``nut_force`` (N, 2) [N], ``nut_position`` (N, 2) [m],
    ``dissipation`` [W], ``mechanism_dissipation`` (N, 7) [W] in :data:`MECHANISMS` order,
    ``nut_dissipation`` (N, 2) [W], ``kinetic_energy``, ``elastic_energy``,
    ``gravitational_energy`` [J], ``gravitational_power`` (dE_grav/dt) [W], ``input_energy``
    (cumulative int P_in dt) [J], ``dissipated_energy`` [J], ``power_balance_error`` [J].

    Contact states (M samples, B spheres, 4 half grooves S1, S2, N1, N2): ``contact_time`` [s],
    ``normal_force`` (elastic part K delta^1.5) [N], ``friction_force`` [N], ``contact_angle``
    [rad], ``tallian`` [-], ``film_thickness`` [m], ``slip`` [m/s], ``max_pressure`` [Pa],
    ``semi_axis_x``, ``semi_axis_y`` [m], ``lubricant_share``, ``dry_share`` [-] of the
    friction, ``in_contact`` (bool); ``ball_nut`` (B,) 0 master / 1 slave and ``ball_index`` (B,)
    index within its nut.
    """

    scenario: Scenario
    time: FloatArray
    speed_command: FloatArray
    preload_command: FloatArray
    screw_speed: FloatArray
    motor_torque: FloatArray
    screw_torque: FloatArray
    nut_force: FloatArray
    nut_position: FloatArray
    dissipation: FloatArray
    mechanism_dissipation: FloatArray
    nut_dissipation: FloatArray
    kinetic_energy: FloatArray
    elastic_energy: FloatArray
    gravitational_energy: FloatArray
    gravitational_power: FloatArray
    input_energy: FloatArray
    dissipated_energy: FloatArray
    power_balance_error: FloatArray
    contact_time: FloatArray
    normal_force: FloatArray
    friction_force: FloatArray
    contact_angle: FloatArray
    tallian: FloatArray
    film_thickness: FloatArray
    slip: FloatArray
    max_pressure: FloatArray
    semi_axis_x: FloatArray
    semi_axis_y: FloatArray
    lubricant_share: FloatArray
    dry_share: FloatArray
    in_contact: NDArray[np.bool_]
    ball_nut: NDArray[np.int64]
    ball_index: NDArray[np.int64]
    summary: dict[str, Any] = field(default_factory=dict)
    screw_inertia: float = 0.0  # I_s [kg m^2] of the run's parameter set

    @property
    def gravity_torque(self) -> FloatArray:
        """Gravitational power / screw speed at each sample, 0 at standstill [N m]."""
        return _per_speed(self.gravitational_power, self.screw_speed)

    @property
    def inertia_torque(self) -> FloatArray:
        """I_s dOmega/dt at each sample (central differences of the recorded speed) [N m]."""
        if len(self.time) < 2:
            return np.zeros_like(self.time)
        return self.screw_inertia * np.gradient(self.screw_speed, self.time)

    @property
    def drag_torque(self) -> FloatArray:
        """Motor torque minus gravity torque minus I_s dOmega/dt at each sample [N m]."""
        return self.motor_torque - self.gravity_torque - self.inertia_torque

    def nut_torque(self) -> FloatArray:
        """(N, 2) dissipation of each nut's spheres / screw speed, 0 at standstill [N m]."""
        return _per_speed(self.nut_dissipation, self.screw_speed[:, None])

    def breakdown_torque(self) -> FloatArray:
        """(N, 7) dissipation per mechanism / screw speed at each sample, 0 at standstill [N m]."""
        return _per_speed(self.mechanism_dissipation, self.screw_speed[:, None])


def _per_speed(power: FloatArray, speed: FloatArray) -> FloatArray:
    """power / speed where |speed| > STANDSTILL_SPEED, else 0."""
    moving = np.abs(speed) > STANDSTILL_SPEED
    return np.asarray(np.where(moving, power / np.where(moving, speed, 1.0), 0.0))
