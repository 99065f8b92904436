"""Bench units that are not the twin: a real screw drawn from production spreads.

The health monitor predicts with the nominal twin (or the twin commissioned to a unit,
:mod:`.baseline`). A real unit differs from the nominal parameter set by tens of percent, and
it behaves near standstill in ways the quasi-static twin does not: scoring the monitor on data
made by its own equations says nothing about a real bench. The generator therefore draws a
:class:`BenchUnit` from documented spreads (:class:`UnitSpread`) and makes its drag torque
from three things the monitor does not have:

1. **Its own parameters**, solved by the steady-state model (symmetric mode) on a table of its
   own (:class:`UnitTorqueTable`): preload scale (the nut pair's preload tolerance: the load
   cell reads the set force, the contacts carry ``preload_scale`` times it), viscosity scale
   (lubricant batch and ageing, both viscosity points), dry friction coefficient mu_dry
   (Eq. 36) and Eyring stress tau_0 (Eq. 35) scales (run-in of the grooves, additive
   package).
2. **Presliding through reversals** (Dahl 1968, exponent 1): the friction torque does not
   flip with the speed; it approaches the steady torque of the current speed over a
   characteristic rotation angle phi_c, dT/d|phi| = (T_ss(w) - T) / phi_c, so a reversal
   takes ~3 phi_c of screw rotation to settle.
3. **A Stribeck rise at low speed**: T_ss + sign(w) T_st exp(-(w / w_st)^2), a breakaway
   torque T_st (a fraction of the unit's torque at 10 rad/s and 20 C, at the instant's
   contact preload) that vanishes above a few w_st.

The torque sensor adds a gain error and a bias on top (``torque_gain``, ``torque_bias``), and
the unit's rotating inertia seen by the sensor differs from the nominal screw inertia by
``inertia_scale``. The unit's table assumes the torque odd in the speed (measured: the
symmetric steady model's T(-w) + T(w) is below 1.4e-4 T(w) from 0.02 to 300 rad/s at
20 C, 1500 N; docs/model.md section 16).

All quantities SI: rad/s, K, N, N m, rad.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import RegularGridInterpolator

from ..errors import ConfigError
from ..models.base import OperatingPoint
from ..params import TwinConfig, finite, not_negative, positive, validate_fields
from .fault_profiles import FaultState, apply_to_config

FloatArray = NDArray[np.float64]

#: Lowest tabulated |speed| of a unit table [rad/s]; the torque goes linearly to 0 below it.
TABLE_SPEED_MIN = 0.005
#: Highest tabulated |speed| [rad/s] (3820 rpm).
TABLE_SPEED_MAX = 400.0
#: Speed nodes of a unit table, uniform in log |speed| [-].
TABLE_SPEED_NODES = 49
#: Spacing of a unit table's temperature nodes, on a lattice fixed in K [K].
TABLE_TEMPERATURE_STEP = 2.5
#: Ratio of neighbouring contact-preload nodes of a unit table, on a lattice fixed in
#: log preload [-].
TABLE_PRELOAD_RATIO = 1.25
#: Reference speed of the Stribeck torque's size [rad/s].
STRIBECK_REFERENCE_SPEED = 10.0
#: Reference temperature of the Stribeck torque's size [K] (20 C).
STRIBECK_REFERENCE_TEMPERATURE = 293.15


@dataclass(frozen=True, kw_only=True)
class UnitSpread:
    """Production spreads a unit is drawn from (uniform within +- the half-width, except where
    said).

    Attributes:
        preload: relative half-width of the preload the contacts carry for a set force [-].
        viscosity: relative half-width of both viscosity points [-].
        dry_friction: relative half-width of mu_dry (Eq. 36) [-].
        eyring_stress: relative half-width of tau_0 (Eq. 35) [-].
        torque_gain: relative half-width of the torque sensor's gain [-].
        torque_bias: standard deviation of the torque sensor's bias (normal) [N m].
        inertia: relative half-width of the rotating inertia the sensor sees [-].
        presliding_angle: range (low, high) of the Dahl angle phi_c [rad].
        stribeck_fraction: range of T_st as a fraction of the torque at 10 rad/s, 20 C [-].
        stribeck_speed: range of the Stribeck speed w_st [rad/s].
    """

    preload: float = 0.15
    viscosity: float = 0.20
    dry_friction: float = 0.30
    eyring_stress: float = 0.30
    torque_gain: float = 0.02
    torque_bias: float = 3.0e-4
    inertia: float = 0.10
    presliding_angle: tuple[float, float] = (0.02, 0.2)
    stribeck_fraction: tuple[float, float] = (0.0, 0.3)
    stribeck_speed: tuple[float, float] = (0.2, 1.0)

    def __post_init__(self) -> None:
        for name in ("preload", "viscosity", "dry_friction", "eyring_stress", "inertia"):
            value = getattr(self, name)
            if not 0.0 <= value < 1.0:
                raise ConfigError(f"unit spread: {name} = {value!r} must be in [0, 1)")
        if not (0.0 <= self.torque_gain < 0.5 and 0.0 <= self.torque_bias < 0.1):
            raise ConfigError("unit spread: torque_gain in [0, 0.5), torque_bias in [0, 0.1) N m")
        for name, low_bound in (
            ("presliding_angle", 1e-6),
            ("stribeck_fraction", 0.0),
            ("stribeck_speed", 1e-6),
        ):
            low, high = getattr(self, name)
            if not (math.isfinite(high) and low_bound <= low <= high):
                raise ConfigError(f"unit spread: {name} = {(low, high)!r} must be ordered, >= 0")


@dataclass(frozen=True, kw_only=True)
class BenchUnit:
    """One drawn unit (see the module docstring); the nominal twin is all scales 1, all
    extras 0.

    Attributes:
        seed: seed it was drawn with (-1: given by hand).
        preload_scale: contact preload over the set preload [-].
        viscosity_scale: both viscosity points over nominal [-].
        dry_friction_scale: mu_dry over nominal [-].
        eyring_scale: tau_0 over nominal [-].
        torque_gain: torque sensor gain [-].
        torque_bias: torque sensor bias [N m].
        inertia_scale: rotating inertia seen by the sensor over the screw's [-].
        presliding_angle: Dahl angle phi_c [rad] (0: no presliding).
        stribeck_fraction: T_st over |T_ss(10 rad/s, 20 C)| at the contact preload [-].
        stribeck_speed: w_st [rad/s].
    """

    seed: int = -1
    preload_scale: float = field(default=1.0, metadata=positive("-"))
    viscosity_scale: float = field(default=1.0, metadata=positive("-"))
    dry_friction_scale: float = field(default=1.0, metadata=positive("-"))
    eyring_scale: float = field(default=1.0, metadata=positive("-"))
    torque_gain: float = field(default=1.0, metadata=positive("-"))
    torque_bias: float = field(default=0.0, metadata=finite("N m"))
    inertia_scale: float = field(default=1.0, metadata=positive("-"))
    presliding_angle: float = field(default=0.0, metadata=not_negative("rad"))
    stribeck_fraction: float = field(default=0.0, metadata=not_negative("-"))
    stribeck_speed: float = field(default=1.0, metadata=positive("rad/s"))

    def __post_init__(self) -> None:
        validate_fields(self, "bench unit")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready record (ground truth)."""
        return asdict(self)


def draw_unit(seed: int, spread: UnitSpread | None = None) -> BenchUnit:
    """A unit drawn from ``spread`` with ``seed`` (one generator of its own, fixed order)."""
    s = spread or UnitSpread()
    rng = np.random.default_rng([seed, 0x0B5C])

    def around(half_width: float) -> float:
        return float(1.0 + rng.uniform(-half_width, half_width))

    def within(bounds: tuple[float, float]) -> float:
        return float(rng.uniform(*bounds))

    return BenchUnit(
        seed=seed,
        preload_scale=around(s.preload),
        viscosity_scale=around(s.viscosity),
        dry_friction_scale=around(s.dry_friction),
        eyring_scale=around(s.eyring_stress),
        torque_gain=around(s.torque_gain),
        torque_bias=float(rng.normal(0.0, s.torque_bias)),
        inertia_scale=around(s.inertia),
        presliding_angle=within(s.presliding_angle),
        stribeck_fraction=within(s.stribeck_fraction),
        stribeck_speed=within(s.stribeck_speed),
    )


def unit_config(config: TwinConfig, unit: BenchUnit) -> TwinConfig:
    """The parameter set of ``unit``: viscosity points, mu_dry and tau_0 scaled (the preload
    scale acts on the operating point, the sensor and inertia terms on the signal)."""
    lub = config.lubricant
    return replace(
        config,
        name=f"{config.name} (unit {unit.seed})",
        lubricant=replace(
            lub,
            viscosity_reference=lub.viscosity_reference * unit.viscosity_scale,
            viscosity_second=lub.viscosity_second * unit.viscosity_scale,
            eyring_stress=lub.eyring_stress * unit.eyring_scale,
        ),
        contact=replace(
            config.contact,
            dry_friction_coefficient=config.contact.dry_friction_coefficient
            * unit.dry_friction_scale,
        ),
    )


def lattice_nodes(low: float, high: float, step: float) -> FloatArray:
    """Nodes of the lattice k * ``step`` (k integer) that enclose [``low``, ``high``] (in the
    unit of ``step``): at least two, the same nodes for every range that falls between them,
    so one unit's table is the same function of its inputs whatever recording it was built
    for."""
    first = math.floor(low / step)
    last = max(math.ceil(high / step), first + 1)
    return np.arange(first, last + 1, dtype=np.float64) * step


class UnitTorqueTable:
    """Steady drag torque of one unit (and its model-changing faults) on a grid, interpolated.

    The nodes: |speed| uniform in log from :data:`TABLE_SPEED_MIN` to :data:`TABLE_SPEED_MAX`,
    temperature and log contact preload on fixed lattices (:func:`lattice_nodes`,
    :data:`TABLE_TEMPERATURE_STEP`, :data:`TABLE_PRELOAD_RATIO`) enclosing the ranges asked
    for, and the model-changing fault states given (viscosity, roughness, mu_dry factors: one
    table each). Every node is a symmetric steady solve of the unit's parameter set,
    warm-started along the speed axis. Between the nodes the logarithm of the torque is
    linear in log speed, temperature and log preload (the viscosity is close to exponential
    in temperature, the torque close to a power of speed and preload), so the table is one
    smooth-enough function of the unit, not of the recording it was built for.

    Args:
        config: the nominal parameter set.
        unit: the unit.
        temperature_range: (low, high) temperature to cover [K].
        preload_range: (low, high) contact preload to cover [N] (after ``preload_scale`` and
            any preload loss).
        fault_states: fault states whose model changes need tables of their own (the healthy
            state is always included).
    """

    def __init__(
        self,
        config: TwinConfig,
        unit: BenchUnit,
        temperature_range: tuple[float, float],
        preload_range: tuple[float, float],
        fault_states: tuple[FaultState, ...] = (),
    ) -> None:
        from ..models.steady import SteadyStateModel

        if min(*temperature_range, *preload_range) <= 0.0:
            raise ConfigError(
                f"unit table: temperature range {temperature_range} K and preload range "
                f"{preload_range} N must be > 0"
            )
        self.unit = unit
        self.speeds = np.exp(
            np.linspace(math.log(TABLE_SPEED_MIN), math.log(TABLE_SPEED_MAX), TABLE_SPEED_NODES)
        )
        self.temperatures = lattice_nodes(*temperature_range, TABLE_TEMPERATURE_STEP)
        low, high = (math.log(p) for p in preload_range)
        self.preloads = np.exp(lattice_nodes(low, high, math.log(TABLE_PRELOAD_RATIO)))
        base = unit_config(config, unit)
        keys = {FaultState().model_key: FaultState()}
        for state in fault_states:
            keys.setdefault(state.rounded().model_key, state.rounded())
        self._tables: dict[tuple[float, ...], RegularGridInterpolator] = {}
        self.solves = 0
        for key, state in keys.items():
            model = SteadyStateModel(apply_to_config(base, state), mode="symmetric")
            values = np.empty((len(self.speeds), len(self.temperatures), len(self.preloads)))
            for j, temperature in enumerate(self.temperatures):
                for k, preload in enumerate(self.preloads):
                    model.forget_warm_start()
                    for i, speed in enumerate(self.speeds):
                        values[i, j, k] = self._solve(model, speed, temperature, preload)
            self._tables[key] = RegularGridInterpolator(
                (np.log(self.speeds), self.temperatures, np.log(self.preloads)),
                np.log(values),
                bounds_error=False,
                fill_value=None,
            )
        # the Stribeck torque's size: the healthy unit at the reference speed and temperature,
        # at each preload node (a fixed function of the contact preload, like the table)
        model = SteadyStateModel(base, mode="symmetric")
        self._stribeck_reference = np.array(
            [
                self._solve(model, STRIBECK_REFERENCE_SPEED, STRIBECK_REFERENCE_TEMPERATURE, p)
                for p in self.preloads
            ]
        )

    def _solve(self, model: Any, speed: float, temperature: float, preload: float) -> float:
        """One symmetric steady solve of |T| [N m] (> 0: the table interpolates its log)."""
        op = OperatingPoint(
            screw_speed=float(speed), temperature=float(temperature), preload=float(preload)
        )
        torque = float(model.evaluate(op).drag_torque)
        self.solves += 1
        if not torque > 0.0:
            raise ConfigError(
                f"unit table: drag torque {torque!r} N m at {speed:g} rad/s, {temperature:g} K, "
                f"{preload:g} N is not > 0 (its logarithm is interpolated)"
            )
        return torque

    def stribeck_reference(self, contact_preload: FloatArray) -> FloatArray:
        """|T_ss| of the healthy unit at STRIBECK_REFERENCE_SPEED and
        STRIBECK_REFERENCE_TEMPERATURE [N m] at ``contact_preload`` [N] (log-log in between
        the preload nodes, clipped to them)."""
        p = np.clip(contact_preload, self.preloads[0], self.preloads[-1])
        return np.exp(np.interp(np.log(p), np.log(self.preloads), np.log(self._stribeck_reference)))

    def _steady(
        self, speed: FloatArray, temperature: FloatArray, preload: FloatArray, state: FaultState
    ) -> FloatArray:
        """Quasi-static torque of the table of ``state`` [N m] (odd in speed, linear to 0
        below the lowest node)."""
        table = self._tables[state.rounded().model_key]
        magnitude = np.abs(speed)
        clipped = np.clip(magnitude, self.speeds[0], self.speeds[-1])
        t = np.clip(temperature, self.temperatures[0], self.temperatures[-1])
        p = np.clip(preload, self.preloads[0], self.preloads[-1])
        value = np.exp(table(np.column_stack([np.log(clipped), t, np.log(p)])))
        value *= np.minimum(magnitude / self.speeds[0], 1.0)
        return np.asarray(np.sign(speed) * value, dtype=np.float64)

    def steady_torque(
        self,
        speed: FloatArray,
        temperature: FloatArray,
        contact_preload: FloatArray,
        states: list[FaultState] | None = None,
    ) -> FloatArray:
        """The unit's quasi-static drag torque with its Stribeck rise [N m] at arrays of speed
        [rad/s], temperature [K] and contact preload [N]; ``states``: the fault state of each
        instant (default healthy; only their model keys are used here)."""
        out = np.empty_like(np.asarray(speed, dtype=np.float64))
        if states is None:
            out[:] = self._steady(speed, temperature, contact_preload, FaultState())
        else:
            keys = [s.rounded().model_key for s in states]
            by_key: dict[tuple[float, ...], list[int]] = {}
            for i, key in enumerate(keys):
                by_key.setdefault(key, []).append(i)
            for rows in by_key.values():
                idx = np.array(rows)
                out[idx] = self._steady(
                    speed[idx], temperature[idx], contact_preload[idx], states[rows[0]]
                )
        u = self.unit
        if u.stribeck_fraction > 0.0:
            out += (
                np.sign(speed)
                * u.stribeck_fraction
                * self.stribeck_reference(np.asarray(contact_preload, dtype=np.float64))
                * np.exp(-((speed / u.stribeck_speed) ** 2))
            )
        return out


def presliding_reference(
    steady: FloatArray, angle: FloatArray, presliding_angle: float, start: float | None = None
) -> FloatArray:
    """Dahl lag of the friction torque behind its steady value (readable reference of
    :func:`ballscrew_twin.kernels.presliding.presliding_lag`).

    Args:
        steady: the steady torque at each instant, T_ss [N m].
        angle: the screw angle at each instant [rad].
        presliding_angle: phi_c [rad] (0: no lag, ``steady`` returned).
        start: torque at the first instant [N m] (default: ``steady[0]``).

    Returns:
        T with T_k = T_ss,k + (T_k-1 - T_ss,k) exp(-|phi_k - phi_k-1| / phi_c), the exact
        step of dT/d|phi| = (T_ss - T) / phi_c for T_ss constant over the step.
    """
    out = np.array(steady, dtype=np.float64)
    if presliding_angle <= 0.0 or len(out) == 0:
        return out
    previous = out[0] if start is None else start
    for k in range(len(out)):
        travel = abs(angle[k] - angle[k - 1]) if k > 0 else 0.0
        decay = math.exp(-travel / presliding_angle)
        out[k] = steady[k] + (previous - steady[k]) * decay
        previous = out[k]
    return out
