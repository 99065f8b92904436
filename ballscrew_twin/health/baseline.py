"""The commissioned unit: what the health monitor knows of one real screw, and its uncertainty.

A :class:`Baseline` holds the parameters that differ from unit to unit and that the torque
alone can identify: the contact preload over the load cell's reading (preload tolerance of
the nut pair), a shift of the torque-temperature curve (thermometer offset, lubricant batch),
the torque sensor's gain (which also takes a friction level common to every mechanism) and
bias, the scales k of its dry friction coefficient mu_dry and Eyring stress tau_0 (run-in of
the grooves, the lubricant's additives), a correction S of the speed dependence that those
leave, and the rotating inertia the sensor sees. The monitor predicts the measured block mean
as

    z = g (mean_i S(w_i) T_unit(w_i, T + dT, k_F F; k) + J dw/dt) + b,
    S(w) = 1 + beta_1 x + beta_2 x^2,  x = log10(|w| / 30 rad/s),

T_unit the real-time map along the measured speeds w_i of the block times the steady model's
response to k (:class:`.residuals.UnitTwin`),
and compares with the 1-sigma uncertainty

    sigma^2 = sigma_s^2 / n + (e_rel |T|)^2 + e_abs^2 + (e_J J dw/dt)^2
              + (J (c_0 + c_1) / (4 span))^2 + (e_T |T| d_T)^2
              + (|dT| / 5 K |T(T_meas) - T(T_edge)|)^2,

the sensor noise of the block mean, the twin's own error after commissioning (relative and
absolute), the inertia's, the speed interpolation's at the block edges (c_k the second
differences of the speed samples there: :attr:`.residuals.Block.edge_curvature`), the growth
of the error with the distance d_T [K] of the temperature from the range commissioned in the
block's speed band, or with a reach at the speeds near the block's
(:meth:`Baseline.temperature_distance`, :meth:`Baseline.reached_range`), and outside that
range the part of the twin's change from the nearest commissioned temperature T_edge that a
fitted shift dT leaves uncertain (:meth:`Baseline.extrapolation_error`).
:func:`.commission.commission` fits all of them on a healthy recording; without one the nominal
baseline (:meth:`Baseline.nominal`) is used with the default model error of the accuracy
benchmark. Saved as YAML (SI units, every field documented in the file).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import NDArray

from ..errors import ConfigError
from ..models.base import OperatingPoint
from ..params import (
    TwinConfig,
    config_fingerprint,
    finite,
    limits,
    not_negative,
    positive,
    read_yaml,
    validate_fields,
)
from .correction import ResidualSurface

FloatArray = NDArray[np.float64]

#: Format version of baseline files.
BASELINE_VERSION = 1
#: Speed about which the shape correction is taken [rad/s].
SHAPE_REFERENCE_SPEED = 30.0
#: Edges of the speed bands of the model error [rad/s].
ERROR_BAND_EDGES = (3.0, 10.0, 30.0, 100.0, 300.0)
#: The temperature shift [K] at which the twin's change of drag from the commissioned range
#: to a temperature outside it counts as its 1-sigma error there (:meth:`Baseline.
#: extrapolation_error`); the production spread of the shift (commissioning prior).
SHIFT_EXTRAPOLATION = 5.0
#: How far along the speed [decades] the temperatures commissioned at other speeds count
#: (:meth:`Baseline.nearest_commissioned`); 0 takes those of the block's speed band. 0.5
#: since round 37 of issue 13 (held out on units 33000-33014: one jam found sooner, nothing lost).
BAND_REACH = 0.5
#: The fine speed bins in which a baseline keeps the temperatures it saw for the reach:
#: width [decades], the lower edge of the first [log10(rad/s)] and their count (0.01 rad/s to
#: 10^4 rad/s; slower and faster speeds fall in the end bins).
SPEED_BIN_WIDTH = 0.1
SPEED_BIN_LOW = -2.0
SPEED_BIN_COUNT = 60
#: Fields that hold one number per speed band or per fine speed bin (lists in the file).
TUPLE_FIELDS = (
    "error_bands",
    "band_temperature_min",
    "band_temperature_max",
    "bin_temperature_min",
    "bin_temperature_max",
)

FIELD_DOCS: dict[str, str] = {
    "config": "screw parameter set the baseline was fitted with (its name)",
    "fingerprint": "SHA-256 of that parameter set's physical values",
    "source": "recording the baseline was fitted on",
    "torque_gain": "g, torque sensor gain times common friction level [-]",
    "torque_bias": "b, torque sensor bias [N m]",
    "preload_scale": "k_F, contact preload over the load cell's reading [-]",
    "temperature_shift": "dT, the twin is read at the measured temperature + dT [K]",
    "inertia": "J, rotating inertia between torque sensor and screw [kg m^2]",
    "dry_friction_scale": "k_mu, the unit's dry friction coefficient mu_dry over nominal [-]",
    "eyring_scale": "k_tau, the unit's Eyring stress tau_0 over nominal [-]",
    "shape_slope": "beta_1, drag change per decade of speed about 30 rad/s [-]",
    "shape_curvature": "beta_2, drag change per decade of speed squared [-]",
    "sensor_noise": "sigma_s, noise of one torque sample [N m]",
    "error_relative": "e_rel, twin error relative to the drag torque after the fit (1 sigma) [-]",
    "error_bands": "e_rel in the speed bands split at 3, 10, 30, 100, 300 rad/s [-] (empty: one)",
    "error_absolute": "e_abs, twin error floor (1 sigma) [N m]",
    "inertia_error": "e_J, relative error of the inertia torque (1 sigma) [-]",
    "unseen_error": "e_rel where the residual surface has no support (not commissioned) [-]",
    "temperature_error": "e_T, relative error growth per K outside the temperatures commissioned "
    "in the block's speed band [1/K]",
    "shift_extrapolation": "the temperature shift at which the twin's change of drag from the "
    "nearest commissioned temperature counts as its 1-sigma error outside the range [K]",
    "band_reach": "how far along the speed the temperatures commissioned at other speeds count, "
    "in decades [-] (0: those of the block's speed band)",
    "temperature_min": "lowest temperature of the commissioning recording [K]",
    "temperature_max": "highest temperature of the commissioning recording [K]",
    "band_temperature_min": "lowest temperature commissioned in each speed band of error_bands "
    "[K] (empty: temperature_min)",
    "band_temperature_max": "highest temperature commissioned in each speed band [K] (empty: "
    "temperature_max)",
    "bin_temperature_min": "lowest temperature commissioned in each fine speed bin (0.1 "
    "decades from 0.01 rad/s) [K] (.inf, and -.inf in the max: a bin not seen; empty: none kept)",
    "bin_temperature_max": "highest temperature commissioned in each fine speed bin [K]",
    "fit_rms": "rms relative block residual of the fit (not scaled) [-]",
    "settling_angle": "screw rotation after a reversal or stop from which the unit's torque is "
    "predicted as well as anywhere, measured at commissioning [rad] (null: the monitor's gate)",
    "surface": "c(x, T), the residual surface over log speed and temperature: values [-] and "
    "support [blocks] at the nodes of health/correction.py (null: none)",
    "blocks": "blocks used by the fit [-]",
}


@dataclass(frozen=True, kw_only=True)
class Baseline:
    """A commissioned unit (see the module docstring; units in :data:`FIELD_DOCS`)."""

    config: str
    fingerprint: str
    source: str = "nominal"
    torque_gain: float = field(default=1.0, metadata=positive("-"))
    torque_bias: float = field(default=0.0, metadata=finite("N m"))
    preload_scale: float = field(default=1.0, metadata=positive("-"))
    temperature_shift: float = field(default=0.0, metadata=finite("K"))
    inertia: float = field(metadata=positive("kg m^2"))
    dry_friction_scale: float = field(default=1.0, metadata=positive("-"))
    eyring_scale: float = field(default=1.0, metadata=positive("-"))
    shape_slope: float = field(default=0.0, metadata=finite("-"))
    shape_curvature: float = field(default=0.0, metadata=finite("-"))
    sensor_noise: float | None = field(default=None, metadata=positive("N m"))
    error_relative: float = field(default=0.03, metadata=not_negative("-"))
    error_bands: tuple[float, ...] = ()
    error_absolute: float = field(default=1.0e-4, metadata=not_negative("N m"))
    inertia_error: float = field(default=0.15, metadata=not_negative("-"))
    temperature_error: float = field(default=0.0, metadata=not_negative("1/K"))
    shift_extrapolation: float = field(default=SHIFT_EXTRAPOLATION, metadata=positive("K"))
    band_reach: float = field(default=BAND_REACH, metadata=limits("-", 0.0, 3.0))
    unseen_error: float = field(default=0.03, metadata=not_negative("-"))
    temperature_min: float = field(default=0.0, metadata=not_negative("K"))
    temperature_max: float = field(default=1.0e4, metadata=not_negative("K"))
    band_temperature_min: tuple[float, ...] = ()
    band_temperature_max: tuple[float, ...] = ()
    bin_temperature_min: tuple[float, ...] = ()
    bin_temperature_max: tuple[float, ...] = ()
    fit_rms: float = math.nan
    blocks: int = 0
    surface: ResidualSurface | None = None
    settling_angle: float | None = field(default=None, metadata=positive("rad"))

    def __post_init__(self) -> None:
        """Every number through the package's one number check
        (:func:`~ballscrew_twin.params.validate_fields`: the message names the field, its
        value, its unit and its range), then the per-band lists and the temperature order."""
        validate_fields(self, "baseline", ": ")
        if any(not (math.isfinite(e) and e >= 0.0) for e in self.error_bands):
            raise ConfigError(f"baseline: error_bands = {self.error_bands!r} must be >= 0")
        if self.temperature_min > self.temperature_max:
            raise ConfigError("baseline: temperature_min is above temperature_max")
        low, high = self.band_temperature_min, self.band_temperature_max
        if len(low) != len(high) or len(low) not in (0, len(ERROR_BAND_EDGES) + 1):
            raise ConfigError(
                "baseline: band_temperature_min and band_temperature_max must both hold one "
                f"value per speed band ({len(ERROR_BAND_EDGES) + 1}) or be empty"
            )
        if any(
            not (math.isfinite(a) and math.isfinite(b) and a <= b)
            for a, b in zip(low, high, strict=True)
        ):
            raise ConfigError("baseline: a band temperature is not finite or its min is above max")
        low, high = self.bin_temperature_min, self.bin_temperature_max
        if len(low) != len(high) or len(low) not in (0, SPEED_BIN_COUNT):
            raise ConfigError(
                "baseline: bin_temperature_min and bin_temperature_max must both hold one value "
                f"per fine speed bin ({SPEED_BIN_COUNT}) or be empty"
            )
        if any(
            not (
                (a == math.inf and b == -math.inf)
                or (math.isfinite(a) and math.isfinite(b) and a <= b)
            )
            for a, b in zip(low, high, strict=True)
        ):
            raise ConfigError(
                "baseline: a fine speed bin's temperatures are neither finite with min <= max "
                "nor .inf and -.inf (not seen)"
            )

    def unit_point(self, measured: OperatingPoint) -> OperatingPoint:
        """The unit's own operating point where ``measured`` is read: the load cell's preload
        [N] x the preload scale, the thermometer's temperature [K] + the temperature shift
        (where the twin is read for this unit)."""
        return replace(
            measured,
            temperature=measured.temperature + self.temperature_shift,
            preload=measured.preload * self.preload_scale,
        )

    @classmethod
    def nominal(cls, config: TwinConfig) -> Baseline:
        """The nominal twin: scales 1, the screw's inertia, default model error."""
        return cls(
            config=config.name,
            fingerprint=config_fingerprint(config),
            inertia=config.screw.screw_inertia,
        )

    def shape(self, speed: FloatArray) -> FloatArray:
        """1 + beta_1 x + beta_2 x^2, x = log10(|w| / 30 rad/s) [-] at ``speed`` [rad/s]: the
        unit's departure from the twin's speed dependence (its mu_dry, which acts at low
        speed, and its Eyring stress, at high speed, are not the nominal ones)."""
        x = np.log10(np.maximum(np.abs(speed), 1e-6) / SHAPE_REFERENCE_SPEED)
        return np.asarray(1.0 + self.shape_slope * x + self.shape_curvature * x * x)

    def surface_factor(self, speed: FloatArray, temperature: float) -> FloatArray:
        """1 + c(x, T) [-] at each ``speed`` [rad/s] and ``temperature`` [K] (ones without a
        surface): the drag the unit shows over the adjusted twin's (:mod:`.correction`)."""
        if self.surface is None:
            return np.ones(len(speed))
        return np.asarray(1.0 + self.surface.at(speed, temperature))

    def error_at(self, speed: float, temperature: float) -> float:
        """e_rel at ``speed`` [rad/s] and ``temperature`` [K]: the band's value (or
        ``error_relative``), raised towards ``unseen_error`` by the share of the residual
        surface's value there that comes from nodes with thin support (fewer than MIN_SUPPORT
        blocks: regimes the recording hardly saw; :meth:`ResidualSurface.unlearnt_share`)."""
        if len(self.error_bands) != len(ERROR_BAND_EDGES) + 1:
            error = self.error_relative
        else:
            error = self.error_bands[int(np.searchsorted(ERROR_BAND_EDGES, abs(speed)))]
        if self.surface is None:
            return error
        thin = self.surface.unlearnt_share(speed, temperature)
        return math.hypot(error, thin * self.unseen_error)

    def temperature_distance(self, temperature: float, speed: float) -> float:
        """How far ``temperature`` [K] lies outside the temperatures the commissioning saw at
        ``speed`` [rad/s] (:meth:`nearest_commissioned`) [K] (0 inside).
        Per band, not over the whole recording: held-out unit 12015 (round 13 of issue 13)
        was commissioned from -17.9 C, but below 3 rad/s only at 32-38 C; at 2.9 rad/s and
        -8.4 C the twin was 13.7 % high against a 1-sigma error of 3.6 %, and the CUSUM
        alarmed 13 s before the fault."""
        return abs(temperature - self.nearest_commissioned(temperature, speed))

    def nearest_commissioned(self, temperature: float, speed: float) -> float:
        """The temperature nearest ``temperature`` [K] that the commissioning saw within
        ``band_reach`` decades of ``speed`` [rad/s] (:meth:`reached_range`); with no reach,
        or none seen there, in the speed band of ``speed`` (the whole recording's range
        without band ranges) [K]."""
        low, high = self.temperature_min, self.temperature_max
        reached = self.reached_range(speed)
        if reached is not None:
            low, high = reached
        elif self.band_temperature_min:
            band = int(np.searchsorted(ERROR_BAND_EDGES, abs(speed)))
            low, high = self.band_temperature_min[band], self.band_temperature_max[band]
        return min(max(temperature, low), high)

    def reached_range(self, speed: float) -> tuple[float, float] | None:
        """The lowest and highest temperature [K] the commissioning saw at the speeds within
        ``band_reach`` decades of |``speed``| [rad/s] (the fine speed bins that overlap
        them), or None without a reach, without fine bins or with none seen there. A speed
        band's edges are where its error is tabulated, not where the twin's error changes:
        dev unit 32028 (round 37 of issue 13) stroked at 11-26 rad/s and -9.7 C, commissioned
        from -10.2 C at 30-300 rad/s but at 10-30 rad/s only from 29 C, and its sigma
        carried 38.7 K of growth where the twin was 1.7 % off."""
        if self.band_reach <= 0.0 or not self.bin_temperature_min:
            return None
        first, last = (
            speed_bin(abs(speed) * 10.0**-self.band_reach),
            speed_bin(abs(speed) * 10.0**self.band_reach),
        )
        low = min(self.bin_temperature_min[first : last + 1])
        high = max(self.bin_temperature_max[first : last + 1])
        return (low, high) if low <= high else None  # a bin not seen holds (inf, -inf)

    def extrapolation_error(self, edge_change: float) -> float:
        """1-sigma error of the twin outside the temperatures commissioned at the block's
        speed from its shift [N m]: ``edge_change`` [N m], how much the adjusted twin's drag
        changes from the nearest such temperature (:meth:`nearest_commissioned`) to the
        block's, times |dT| / ``shift_extrapolation`` (default SHIFT_EXTRAPOLATION).
        A shift explains the commissioned torques, but a unit's viscosity, Eyring stress or
        thermometer all fit that way and part outside the range. Dev units 9013, 5017 and
        8020, shifts of 10.4, -5.4 and -2.0 K: the twin 24, 28 and 13 % off at 6-7 K below
        the range, 1.3, 0.9 and 0.44 times the change to the edge; six units with shifts of
        0.1-2.4 K: within 4 % at speed, 5-19 K below."""
        return abs(self.temperature_shift) / self.shift_extrapolation * abs(edge_change)

    def check_config(self, config: TwinConfig) -> None:
        """ConfigError unless the baseline was fitted with ``config``'s physical values."""
        if self.fingerprint != config_fingerprint(config):
            raise ConfigError(
                f"baseline fitted with parameter set {self.config!r}, not with {config.name!r} "
                "(fingerprints differ): commission again with this parameter set"
            )

    def to_yaml(self) -> str:
        """The baseline as a commented YAML document."""
        lines = [
            "# ballscrew_twin baseline of a commissioned unit (ballscrew-twin commission)",
            f"# format {BASELINE_VERSION}; SI units; fields:",
        ]
        lines += [f"#   {name}: {doc}" for name, doc in FIELD_DOCS.items()]
        body = {"format": BASELINE_VERSION, **asdict(self)}
        for name in TUPLE_FIELDS:
            body[name] = list(getattr(self, name))
        if self.surface is not None:
            body["surface"] = {
                "values": self.surface.values.tolist(),
                "support": self.surface.support.tolist(),
            }
        return (
            "\n".join(lines) + "\n" + yaml.safe_dump(body, sort_keys=False, default_flow_style=None)
        )

    def save(self, path: str | Path) -> Path:
        """Write :meth:`to_yaml` to ``path`` (its folder is created if missing)."""
        file = Path(path)
        try:
            file.parent.mkdir(parents=True, exist_ok=True)
            file.write_text(self.to_yaml(), encoding="utf-8")
        except OSError as err:
            raise ConfigError(f"{file}: cannot write baseline ({err.strerror})") from err
        return file


def speed_bin(speed: float) -> int:
    """The fine speed bin (:data:`SPEED_BIN_WIDTH` decades wide from
    10^:data:`SPEED_BIN_LOW` rad/s) that holds |``speed``| [rad/s]; the end bins take the
    speeds beyond them."""
    position = (math.log10(max(abs(speed), 1e-300)) - SPEED_BIN_LOW) / SPEED_BIN_WIDTH
    return min(max(math.floor(position), 0), SPEED_BIN_COUNT - 1)


def baseline_from_mapping(data: Any, source: str) -> Baseline:
    """Validate a parsed YAML mapping into a :class:`Baseline` (errors name ``source``)."""
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: a baseline file holds a mapping of fields")
    values = dict(data)
    version = values.pop("format", None)
    if version != BASELINE_VERSION:
        raise ConfigError(f"{source}: format {version!r}, expected {BASELINE_VERSION}")
    known = {f.name for f in fields(Baseline)}
    unknown = sorted(set(map(str, values)) - known)
    if unknown:
        raise ConfigError(f"{source}: unknown field(s) {unknown}")
    for name, value in values.items():
        if name in ("config", "fingerprint", "source"):
            if not isinstance(value, str):
                raise ConfigError(f"{source}: {name} must be a string")
        elif name in TUPLE_FIELDS:
            if not isinstance(value, list) or not all(
                isinstance(v, int | float) and not isinstance(v, bool) for v in value
            ):
                raise ConfigError(f"{source}: {name} must be a list of numbers")
            values[name] = tuple(float(v) for v in value)
        elif name == "surface":
            values[name] = _surface_from(value, source)
        elif name == "blocks":
            if isinstance(value, bool) or not isinstance(value, int):
                raise ConfigError(f"{source}: blocks must be a whole number")
        elif value is not None and (isinstance(value, bool) or not isinstance(value, int | float)):
            raise ConfigError(f"{source}: {name} = {value!r} must be a number")
        elif isinstance(value, int) and not isinstance(value, bool):
            values[name] = float(value)
    try:
        return Baseline(**values)
    except TypeError as err:
        raise ConfigError(f"{source}: {err}") from None
    except ConfigError as err:
        raise ConfigError(f"{source}: {err}") from None


def _surface_from(value: Any, source: str) -> ResidualSurface | None:
    """The residual surface of a baseline file (None when null)."""
    if value is None:
        return None
    if not isinstance(value, dict) or set(value) != {"values", "support"}:
        raise ConfigError(f"{source}: surface must be a mapping of 'values' and 'support'")
    try:
        arrays = {k: np.array(value[k], dtype=np.float64) for k in ("values", "support")}
    except (TypeError, ValueError):
        raise ConfigError(f"{source}: surface values and support must be number lists") from None
    try:
        return ResidualSurface(arrays["values"], arrays["support"])
    except ConfigError as err:
        raise ConfigError(f"{source}: {err}") from None


def load_baseline(path: str | Path) -> Baseline:
    """Read a baseline file (ConfigError naming the file and the field)."""
    file = Path(path)
    return baseline_from_mapping(read_yaml(file, "baseline file"), str(file))
