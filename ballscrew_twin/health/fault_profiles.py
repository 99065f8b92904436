"""Faults injected in the twin: each class a physical change of the model, with onset and growth.

A :class:`FaultSpec` names the class, its onset time [s], its severity [-] (the value reached
at full growth) and a growth profile g(t) (:func:`growth_fraction`): ``step`` (g = 1 from the
onset), ``ramp`` (linear over ``growth_time``) or ``exponential`` (1 - exp(-(t - onset) /
growth_time), a first-order approach). The classes and what they change:

- ``preload_loss`` (raceway wear): the preload carried by the contacts becomes
  (1 - s g) F_pr. The load cell in the preload device still reads the set force.
- ``lubricant_degradation`` (viscosity loss, starvation, contamination): both viscosity points
  of the lubricant (eta_0, eta_1) x (1 - s g), so the film is thinner at every temperature
  (Eqs. 24-33) and the asperities carry more (Eqs. 37-38); optionally ``starvation``: the
  residual thickener layer h_R of Eq. 33 x (1 - starvation g) (the model has no inlet
  starvation factor, so the lost grease layer stands for it), and ``roughness_increase``:
  both RMS roughnesses x (1 + roughness_increase g) (contamination wearing the surfaces,
  Eq. 38).
- ``jam_onset`` (debris in the raceways, the usual start of a jam): the boundary friction
  coefficient mu_dry of Eq. 36 and both RMS roughnesses (Eq. 38: particles between the
  surfaces) x (1 + s g): a sudden friction rise at every speed (mu_dry alone barely shows
  once the film separates the surfaces, e.g. +1 % at 200 rpm for x5); default growth
  exponential.
- ``raceway_defect`` (spall on a nut raceway) and ``sphere_defect`` (spot on a sphere): torque
  ripple. PARAMETRIC RIPPLE MODEL, not derived from the contact mechanics: a raised-cosine
  ripple s g |T| (1 - cos 2 pi phi) / 2 added to the drag torque T, phi the signed position
  of the sphere train in defect periods (a sphere that rolls back over a spall meets it again
  at the same place, so the ripple is a function of the screw angle, through reversals too),
  at the rolling-kinematics frequencies of :func:`defect_frequencies`
  (``nut_raceway`` for a raceway spall; ``sphere_spin`` for a sphere spot, and only while that
  sphere is in the loaded zone, a fraction Z/Z_tot of its ``circulation`` period). The
  amplitude s is the peak ripple as a fraction of the drag torque.

The physical changes are applied with ``dataclasses.replace`` on the frozen
:class:`~ballscrew_twin.params.TwinConfig` (:func:`apply_to_config`) and evaluated by the
steady-state model (:class:`FaultedTwin`, cached).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ConfigError
from ..models.base import OperatingPoint
from ..params import TwinConfig, from_mapping, quantity, validate_fields

FloatArray = NDArray[np.float64]

FAULT_CLASSES = (
    "preload_loss",
    "lubricant_degradation",
    "raceway_defect",
    "sphere_defect",
    "jam_onset",
)
GROWTH_PROFILES = ("step", "ramp", "exponential")
#: Largest severity of each class [-] (a preload or viscosity cannot fall below zero).
MAX_SEVERITY = {
    "preload_loss": 0.95,
    "lubricant_degradation": 0.95,
    "raceway_defect": 2.0,
    "sphere_defect": 2.0,
    "jam_onset": 10.0,
}
#: Growth profile of a class when the scene does not give one.
DEFAULT_GROWTH = {
    "preload_loss": "ramp",
    "lubricant_degradation": "ramp",
    "raceway_defect": "step",
    "sphere_defect": "step",
    "jam_onset": "exponential",
}


@dataclass(frozen=True, kw_only=True)
class FaultSpec:
    """One injected fault (see the module docstring for what each class changes)."""

    fault_class: str
    onset: float = quantity("s", 0.0, 1e6, "onset time since the start")
    severity: float = quantity("-", 0.0, 10.0, "value reached at full growth")
    growth: str = "step"
    growth_time: float = quantity(
        "s", 0.0, 1e6, "ramp duration or exponential time constant (0 with step)", default=0.0
    )
    starvation: float = quantity(
        "-", 0.0, 1.0, "lubricant_degradation: fraction of the residual layer lost", default=0.0
    )
    roughness_increase: float = quantity(
        "-", 0.0, 10.0, "lubricant_degradation: relative increase of the roughness", default=0.0
    )

    def __post_init__(self) -> None:
        where = f"fault {self.fault_class}"
        if self.fault_class not in FAULT_CLASSES:
            raise ConfigError(f"fault class {self.fault_class!r} is not one of {FAULT_CLASSES}")
        validate_fields(self, where)
        if self.growth not in GROWTH_PROFILES:
            raise ConfigError(f"{where}.growth = {self.growth!r} is not one of {GROWTH_PROFILES}")
        if self.growth != "step" and self.growth_time <= 0.0:
            raise ConfigError(f"{where}.growth_time must be > 0 s with growth {self.growth}")
        top = MAX_SEVERITY[self.fault_class]
        if not 0.0 < self.severity <= top:
            raise ConfigError(f"{where}.severity = {self.severity} must be in (0, {top:g}]")
        extras = self.starvation > 0.0 or self.roughness_increase > 0.0
        if extras and self.fault_class != "lubricant_degradation":
            raise ConfigError(
                f"{where}: starvation and roughness_increase belong to lubricant_degradation"
            )

    def to_truth(self) -> dict[str, Any]:
        """Ground-truth record: class, onset_s, severity, growth, growth_time_s (and extras)."""
        out: dict[str, Any] = {
            "class": self.fault_class,
            "onset_s": self.onset,
            "severity": self.severity,
            "growth": self.growth,
            "growth_time_s": self.growth_time,
        }
        if self.fault_class == "lubricant_degradation":
            out["starvation"] = self.starvation
            out["roughness_increase"] = self.roughness_increase
        return out


def faults_from_list(data: Any, where: str) -> tuple[FaultSpec, ...]:
    """Validate a YAML list of faults ``[{class, onset, severity, growth, growth_time, ...}]``."""
    if data is None:
        return ()
    if not isinstance(data, list):
        raise ConfigError(f"{where}: expected a list of faults, got {type(data).__name__}")
    out = []
    for k, item in enumerate(data):
        path = f"{where}[{k}]"
        if not isinstance(item, dict):
            raise ConfigError(f"{path}: expected a mapping, got {type(item).__name__}")
        item = dict(item)
        cls = item.pop("class", None)
        if cls not in FAULT_CLASSES:
            raise ConfigError(f"{path}.class = {cls!r} is not one of {list(FAULT_CLASSES)}")
        severity = item.get("severity")
        try:
            value = float(severity)  # type: ignore[arg-type]
        except (TypeError, ValueError):
            value = math.nan  # not a number: from_mapping names it below
        if math.isfinite(value) and not 0.0 < value <= MAX_SEVERITY[cls]:
            hint = (
                " (a viscosity or preload *increase* is not a fault of this class)"
                if value < 0.0 and cls in ("lubricant_degradation", "preload_loss")
                else ""
            )
            raise ConfigError(
                f"{path}.severity = {severity!r} is outside the range of {cls}, "
                f"(0, {MAX_SEVERITY[cls]:g}]{hint}"
            )
        item.setdefault("growth", DEFAULT_GROWTH[cls])
        out.append(from_mapping(FaultSpec, item, path, fault_class=cls))
    return tuple(out)


def growth_fraction(spec: FaultSpec, time: ArrayLike) -> FloatArray:
    """g(t) of ``spec`` at ``time`` [s]: 0 before the onset, rising to 1 (see module doc)."""
    t = np.asarray(time, dtype=np.float64)
    since = t - spec.onset
    started = since >= 0.0
    if spec.growth == "step":
        g = np.ones_like(t)
    elif spec.growth == "ramp":
        g = np.clip(since / spec.growth_time, 0.0, 1.0)
    else:
        g = -np.expm1(-np.maximum(since, 0.0) / spec.growth_time)
    return np.where(started, g, 0.0)


@dataclass(frozen=True, kw_only=True)
class FaultState:
    """What the active faults change at one instant (1 / 0: unchanged) [-]."""

    preload_factor: float = 1.0
    viscosity_factor: float = 1.0
    residual_layer_factor: float = 1.0
    roughness_factor: float = 1.0
    dry_friction_factor: float = 1.0
    raceway_ripple: float = 0.0
    sphere_ripple: float = 0.0

    def rounded(self, digits: int = 9) -> FaultState:
        """The state with every factor rounded (a cache key that ignores round-off)."""
        return FaultState(**{f.name: round(getattr(self, f.name), digits) for f in fields(self)})

    @property
    def model_key(self) -> tuple[float, float, float, float]:
        """The factors that change the parameter set (one steady model per key)."""
        return (
            self.viscosity_factor,
            self.residual_layer_factor,
            self.roughness_factor,
            self.dry_friction_factor,
        )


def fault_state(faults: Sequence[FaultSpec], time: float) -> FaultState:
    """Combined :class:`FaultState` of ``faults`` at ``time`` [s] (factors multiply, ripple
    amplitudes add)."""
    values = {f.name: getattr(FaultState(), f.name) for f in fields(FaultState)}
    for spec in faults:
        g = float(growth_fraction(spec, time))
        s = spec.severity * g
        if spec.fault_class == "preload_loss":
            values["preload_factor"] *= 1.0 - s
        elif spec.fault_class == "lubricant_degradation":
            values["viscosity_factor"] *= 1.0 - s
            values["residual_layer_factor"] *= 1.0 - spec.starvation * g
            values["roughness_factor"] *= 1.0 + spec.roughness_increase * g
        elif spec.fault_class == "jam_onset":
            values["dry_friction_factor"] *= 1.0 + s
            values["roughness_factor"] *= 1.0 + s
        elif spec.fault_class == "raceway_defect":
            values["raceway_ripple"] += s
        else:
            values["sphere_ripple"] += s
    return FaultState(**values)


def apply_to_config(config: TwinConfig, state: FaultState) -> TwinConfig:
    """The parameter set with the model changes of ``state`` (dataclasses.replace)."""
    lub = config.lubricant
    screw = config.screw
    return replace(
        config,
        name=f"{config.name} (faulted)",
        lubricant=replace(
            lub,
            viscosity_reference=lub.viscosity_reference * state.viscosity_factor,
            viscosity_second=lub.viscosity_second * state.viscosity_factor,
            residual_layer=lub.residual_layer * state.residual_layer_factor,
        ),
        screw=replace(
            screw,
            ball_roughness=screw.ball_roughness * state.roughness_factor,
            groove_roughness=screw.groove_roughness * state.roughness_factor,
        ),
        contact=replace(
            config.contact,
            dry_friction_coefficient=config.contact.dry_friction_coefficient
            * state.dry_friction_factor,
        ),
    )


# ---------------------------------------------------------------------------------------------
# Rolling kinematics of the defect frequencies


def orbital_speed(
    screw_speed: ArrayLike, pitch_radius: float, ball_radius: float, contact_angle: float
) -> FloatArray:
    """w_c = w / 2 (1 - g), g = r_b cos(alpha) / r_m: orbital speed of the spheres about the
    screw axis for rolling without slip, nut not turning [rad/s] (the cage speed of a bearing
    whose inner ring turns)."""
    g = ball_radius * math.cos(contact_angle) / pitch_radius
    return 0.5 * np.asarray(screw_speed, dtype=np.float64) * (1.0 - g)


def sphere_spin_speed(
    screw_speed: ArrayLike, pitch_radius: float, ball_radius: float, contact_angle: float
) -> FloatArray:
    """w_b = r_m / (2 r_b) w (1 - g^2): spin speed of a sphere rolling without slip [rad/s]."""
    g = ball_radius * math.cos(contact_angle) / pitch_radius
    return (
        pitch_radius
        / (2.0 * ball_radius)
        * np.asarray(screw_speed, dtype=np.float64)
        * (1.0 - g * g)
    )


def defect_frequencies(config: TwinConfig, screw_speed: float) -> dict[str, float]:
    """Defect frequencies [Hz] at ``screw_speed`` [rad/s] (magnitudes).

    Keys: ``orbit`` (w_c / 2 pi), ``nut_raceway`` (spheres passing a point of a nut raceway,
    Z / n_t w_c / 2 pi), ``screw_raceway`` (passing a point of the screw raceway,
    Z / n_t (w - w_c) / 2 pi), ``sphere_spin`` (a spot on a sphere meeting the raceways, twice
    per spin turn, 2 w_b / 2 pi) and ``circulation`` (one sphere's trips round its circuit,
    w_c / (2 pi n_t) Z / Z_tot). Z = balls_per_nut, Z_tot = balls_total_per_nut, n_t =
    loaded_turns, alpha = nominal_contact_angle; rolling without slip, nut not turning.
    """
    s = config.screw
    w = abs(screw_speed)
    w_c = float(orbital_speed(w, s.pitch_radius, s.ball_radius, s.nominal_contact_angle))
    w_b = float(sphere_spin_speed(w, s.pitch_radius, s.ball_radius, s.nominal_contact_angle))
    per_turn = s.balls_per_nut / s.loaded_turns
    two_pi = 2.0 * math.pi
    return {
        "orbit": w_c / two_pi,
        "nut_raceway": per_turn * w_c / two_pi,
        "screw_raceway": per_turn * (w - w_c) / two_pi,
        "sphere_spin": 2.0 * w_b / two_pi,
        "circulation": w_c / (two_pi * s.loaded_turns) * s.balls_per_nut / s.balls_total_per_nut,
    }


def ripple_torque(
    config: TwinConfig,
    time: ArrayLike,
    screw_speed: ArrayLike,
    drag_torque: ArrayLike,
    raceway_amplitude: ArrayLike,
    sphere_amplitude: ArrayLike,
) -> FloatArray:
    """Torque ripple of the defects [N m] at the instants ``time`` [s] (parametric model).

    Args:
        config: parameter set (geometry of the kinematics).
        time: increasing instants [s], fine enough to resolve the ripple.
        screw_speed: screw speed at those instants [rad/s].
        drag_torque: drag torque the ripple rides on [N m] (its magnitude scales the ripple,
            the speed gives its sign).
        raceway_amplitude: relative peak ripple of a nut-raceway spall [-] (s g(t)).
        sphere_amplitude: relative peak ripple of a sphere spot [-] (s g(t)).

    The phase of each ripple is the integral of its signed frequency over time: continuous
    when the speed changes, and running back when the screw reverses (the spheres roll back
    over the same defect), so the ripple is periodic in the screw angle.
    """
    t = np.asarray(time, dtype=np.float64)
    w = np.asarray(screw_speed, dtype=np.float64)
    base = np.abs(np.asarray(drag_torque, dtype=np.float64))
    per_rad_s = defect_frequencies(config, 1.0)  # frequencies are linear in |w|

    def phase(key: str) -> FloatArray:
        rate = per_rad_s[key] * w
        return np.concatenate(([0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(t))))

    raised = 0.5 * (1.0 - np.cos(2.0 * math.pi * phase("nut_raceway")))
    out = np.asarray(raceway_amplitude, dtype=np.float64) * raised
    loaded_fraction = config.screw.balls_per_nut / config.screw.balls_total_per_nut
    in_load = np.mod(phase("circulation"), 1.0) < loaded_fraction
    spin = 0.5 * (1.0 - np.cos(2.0 * math.pi * phase("sphere_spin")))
    out = out + np.asarray(sphere_amplitude, dtype=np.float64) * spin * in_load
    return out * base * np.sign(w)


# ---------------------------------------------------------------------------------------------
# The twin with faults


class FaultedTwin:
    """Drag torque of the steady-state model under a :class:`FaultState`, cached.

    One :class:`~ballscrew_twin.models.steady.SteadyStateModel` per distinct parameter change
    (so warm starts stay valid) and a cache of torques keyed on the operating point and the
    fault state, both rounded to ``digits`` significant decimals (round-off does not defeat the
    cache; the rounding is far below any sensor's resolution).

    Args:
        config: the healthy parameter set.
        digits: decimals kept in the cache key of speed [rad/s], temperature [K], preload [N]
            and factors [-].
    """

    def __init__(self, config: TwinConfig, digits: int = 6) -> None:
        self.config = config
        self.digits = digits
        self._models: dict[tuple[float, ...], Any] = {}
        self._torque: dict[tuple[Any, ...], float] = {}
        self.evaluations = 0

    def _model(self, state: FaultState) -> Any:
        from ..models.steady import SteadyStateModel

        key = state.model_key
        if key not in self._models:
            self._models[key] = SteadyStateModel(apply_to_config(self.config, state))
        return self._models[key]

    def drag_torque(self, op: OperatingPoint, state: FaultState) -> float:
        """Drag torque [N m] at ``op`` with the contact preload x ``state.preload_factor`` and
        the parameter changes of ``state`` (ripple not included: see :func:`ripple_torque`)."""
        state = state.rounded(self.digits)
        key = (
            round(op.screw_speed, self.digits),
            round(op.temperature, self.digits),
            round(op.preload, self.digits),
            round(op.axial_load, self.digits),
            state.preload_factor,
            state.model_key,
        )
        if key not in self._torque:
            faulted = OperatingPoint(
                screw_speed=key[0],
                temperature=key[1],
                preload=key[2] * state.preload_factor,
                axial_load=key[3],
            )
            self._torque[key] = float(self._model(state).evaluate(faulted).drag_torque)
            self.evaluations += 1
        return self._torque[key]
