"""Catalogue drag-torque formulas: Eq. 51 (manufacturers) and Eq. 52 (Zhou et al. 2016).

Both are linear in preload and know neither speed nor temperature; they are the cheapest
fidelity level and the reference lines of the paper's Fig. 9.
"""

from __future__ import annotations

import math
from typing import Literal

from ..errors import ConfigError
from ..params import TwinConfig
from .base import OperatingPoint, TorqueBreakdown, TwinOutput


def drag_torque_literature(
    preload: float, lead: float, helix_angle: float, friction_coefficient: float
) -> float:
    """No-load drag torque of the catalogues, Eq. 51 [N m].

    T = K_p p F_pr / (2 pi), K_p = 1/eta_1 - eta_2,
    eta_1 = tan(a_e) / tan(a_e + atan mu), eta_2 = tan(a_e - atan mu) / tan(a_e).

    Args:
        preload: F_pr [N].
        lead: p [m].
        helix_angle: a_e [rad].
        friction_coefficient: mu_lit [-].
    """
    phi = math.atan(friction_coefficient)
    eta_direct = math.tan(helix_angle) / math.tan(helix_angle + phi)
    eta_inverse = math.tan(helix_angle - phi) / math.tan(helix_angle)
    k_p = 1.0 / eta_direct - eta_inverse
    return k_p * lead * preload / (2.0 * math.pi)


def drag_torque_zhou(
    preload: float,
    friction_coefficient: float,
    contact_angle: float,
    pitch_radius: float,
    ball_radius: float,
    helix_angle: float,
) -> float:
    """No-load drag torque of Zhou et al. (2016), Eq. 52 [N m].

    T = mu F_pr sin(a_0) [r_m + r_b cos(a_0)] cos^2(a_e).

    Args:
        preload: F_pr [N].
        friction_coefficient: mu_lit [-].
        contact_angle: nominal contact angle a_0 [rad].
        pitch_radius: r_m [m].
        ball_radius: r_b [m].
        helix_angle: a_e [rad].
    """
    return (
        friction_coefficient
        * preload
        * math.sin(contact_angle)
        * (pitch_radius + ball_radius * math.cos(contact_angle))
        * math.cos(helix_angle) ** 2
    )


class CatalogModel:
    """Drag torque from a catalogue formula; no contact states, no speed or temperature effect.

    Args:
        config: the screw's parameter set.
        mu_lit: equivalent friction coefficient of the formula [-] (paper: 0.002).
        formula: ``"zhou"`` (Eq. 52, default) or ``"literature"`` (Eq. 51).
    """

    def __init__(
        self,
        config: TwinConfig,
        mu_lit: float = 0.002,
        formula: Literal["zhou", "literature"] = "zhou",
    ) -> None:
        if not (math.isfinite(mu_lit) and 0.0 <= mu_lit < 1.0):
            raise ConfigError(f"mu_lit = {mu_lit!r} must be in [0, 1)")
        if formula not in ("zhou", "literature"):
            raise ConfigError(f"formula = {formula!r} must be 'zhou' or 'literature'")
        self.config = config
        self.mu_lit = mu_lit
        self.formula = formula
        self.name = f"catalog-{formula}"

    def torque_at_preload(self, preload: float) -> float:
        """Drag torque magnitude at ``preload`` [N] for any non-zero speed [N m]."""
        screw = self.config.screw
        if self.formula == "zhou":
            return drag_torque_zhou(
                preload,
                self.mu_lit,
                screw.nominal_contact_angle,
                screw.pitch_radius,
                screw.ball_radius,
                screw.helix_angle,
            )
        return drag_torque_literature(preload, screw.lead, screw.helix_angle, self.mu_lit)

    def evaluate(self, op: OperatingPoint) -> TwinOutput:
        """Drag torque at ``op``: the formula's magnitude with the sign of the speed [N m]."""
        op.validate()
        notes: list[str] = ["catalogue formula: no speed, temperature or mechanism breakdown"]
        magnitude = self.torque_at_preload(op.preload)
        if op.screw_speed == 0.0:
            notes.append("zero speed: no sliding, drag torque 0 (breakaway torque not modelled)")
        torque = math.copysign(magnitude, op.screw_speed) if op.screw_speed != 0.0 else 0.0
        return TwinOutput(
            drag_torque=torque,
            nut_torque=(0.5 * torque, 0.5 * torque),
            breakdown=TorqueBreakdown(),
            fidelity=self.name,
            operating_point=op,
            notes=tuple(notes),
        )
