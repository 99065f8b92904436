"""Frozen, validated parameter sets loaded from YAML.

Every numeric field carries its SI unit and an allowed range in the field metadata; the loader
rejects unknown or missing keys, non-finite numbers and out-of-range values with a message that
names the file, the section and the field. The ranges are deliberately tight enough to catch a
value given in the wrong unit (a radius of 8 is 8 m, not 8 mm, and is rejected).

A parameter set is a :class:`TwinConfig`; :func:`load_config` reads one. Nothing about the paper's
screw is hard-coded here: it lives in ``config/paper_screw.yaml``.
"""

from __future__ import annotations

import hashlib
import math
import reprlib
import sys
from collections.abc import Mapping
from dataclasses import MISSING, dataclass, field, fields, replace
from pathlib import Path
from typing import Any, Literal, TypeVar, get_args

import yaml

from .errors import BallscrewTwinError, ConfigError
from .units import CELSIUS_ZERO, RPM

_T = TypeVar("_T")

#: Short, recursion-safe reprs of offending values in messages (a value may be any YAML tree).
_SHOWN = reprlib.Repr()
_SHOWN.maxlevel, _SHOWN.maxstring, _SHOWN.maxother = 3, 40, 40

#: Largest difference between the nominal contact angle and the free contact angle of the groove
#: geometry [rad] (2 deg): Table A.1 prints 45.13 deg for a geometry whose free angle is
#: 44.97 deg (0.16 deg); the loaded angle of the steady model moves by up to +4.5 deg at 5000 N
#: preload, but that is the loaded, not the nominal, angle (docs/model.md section 1).
NOMINAL_ANGLE_TOLERANCE = math.radians(2.0)
#: Room the design containment window (Eq. 22) must leave on each side of the free contact
#: angle [rad] (15 deg). The steady model's loaded contacts sit within -10.4/+8.8 deg of the
#: free angle over the envelope on the paper screw (its real-time table: centrifugal load at
#: 6000 rpm moves them apart, preload up to +4.5 deg), and a window that clips them leaves a
#: sphere with no equilibrium: windows of 44-46, 46-80, 10-44 and 42-48 deg failed to converge
#: (docs/model.md, "A table for any screw").
CONTAINMENT_MARGIN = math.radians(15.0)

ViscosityLaw = Literal["roelands", "exponential", "walther"]
Orientation = Literal["vertical", "horizontal"]


def limits(
    unit: str,
    lo: float,
    hi: float,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
    integer: bool = False,
    hint: str | None = "",
) -> dict[str, Any]:
    """What :func:`check_number` checks a value against (the metadata of a :func:`quantity`):
    its SI ``unit``, the range [lo, hi] (without lo when ``lo_open``, without hi when
    ``hi_open``; an end may be infinite), whole numbers only when ``integer``; ``hint``
    replaces the unit-slip hints of an out-of-range value (:func:`range_hint`), None: no hint
    at all."""
    return {
        "unit": unit,
        "min": lo,
        "max": hi,
        "min_open": lo_open,
        "max_open": hi_open,
        "integer": integer,
        "hint": hint,
    }


def finite(unit: str) -> dict[str, Any]:
    """The :func:`limits` of any finite number in ``unit``."""
    return limits(unit, -math.inf, math.inf)


def positive(unit: str) -> dict[str, Any]:
    """The :func:`limits` of a finite number > 0 in ``unit``."""
    return limits(unit, 0.0, math.inf, lo_open=True)


def not_negative(unit: str) -> dict[str, Any]:
    """The :func:`limits` of a finite number >= 0 in ``unit``."""
    return limits(unit, 0.0, math.inf)


def quantity(
    unit: str,
    lo: float,
    hi: float,
    doc: str,
    *,
    default: Any = MISSING,
    lo_open: bool = False,
    integer: bool = False,
    hint: str = "",
) -> Any:
    """A numeric dataclass field whose metadata is its :func:`limits` and its description
    ``doc``; required unless ``default`` is given (None: an optional field, unset)."""
    meta = {**limits(unit, lo, hi, lo_open=lo_open, integer=integer, hint=hint), "doc": doc}
    return field(default=default, metadata=meta)


def check_number(
    raw: Any,
    meta: Mapping[str, Any],
    path: str,
    *,
    text: bool = True,
    error: type[BallscrewTwinError] = ConfigError,
) -> float | int:
    """``raw`` as a number within the :func:`limits` ``meta`` (an int when they want whole
    numbers), else an ``error`` (a ConfigError unless the caller's own kind is given) naming
    ``path``, the unit and the allowed range.

    With ``text``, strings that read as numbers are accepted: PyYAML (YAML 1.1) parses
    ``210.0e9`` without an exponent sign as a string, and users write exponents that way.
    """
    unit, lo, hi = meta["unit"], meta["min"], meta["max"]
    lo_open, hi_open = meta.get("min_open", False), meta.get("max_open", False)
    span = f"{'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"
    if (
        isinstance(raw, bool)
        or not isinstance(raw, int | float | str)
        or (isinstance(raw, str) and not text)
    ):
        raise error(f"{path}: expected a number in {unit} within {span}, got {_SHOWN.repr(raw)}")
    try:
        value = float(raw)
    except ValueError:
        raise error(
            f"{path}: expected a number in {unit} within {span}, got {_SHOWN.repr(raw)}"
        ) from None
    if not math.isfinite(value):
        raise error(
            f"{path}: {_SHOWN.repr(raw)} is not a finite number (allowed range {span} {unit})"
        )
    integer = meta.get("integer", False)
    if integer and value != int(value):
        raise error(f"{path}: expected a whole number, got {raw!r} (allowed range {span} {unit})")
    if (value <= lo if lo_open else value < lo) or (value >= hi if hi_open else value > hi):
        raise error(
            f"{path} = {raw!r} is outside the allowed range {span} {unit}" + range_hint(value, meta)
        )
    return int(value) if integer else value


def range_hint(value: float, meta: Mapping[str, Any]) -> str:
    """Why the out-of-range ``value`` may have been given (the metadata's own hint, else a
    likely unit slip: degrees Celsius for K, degrees for rad, rpm for rad/s, GPa for Pa,
    milli-units for dimensioned SI values but rates, nanometres for m; a negative value where
    none is allowed); "" if none fits or the metadata's hint is None."""
    lo, hi, unit = meta["min"], meta["max"], meta["unit"]
    if meta.get("hint"):
        return f" ({meta['hint']})"
    if "hint" in meta and meta["hint"] is None:
        return ""
    if unit == "K" and value < lo and lo <= value + CELSIUS_ZERO <= hi:
        return " (temperatures are in kelvin, not degrees Celsius)"
    if unit == "rad" and lo <= math.radians(value) <= hi:
        return " (given in degrees? angles are in rad)"
    if unit == "rad/s" and abs(value) > hi and abs(value * RPM) <= hi:
        return " (speeds are in rad/s, not rpm)"
    if value < 0.0 <= lo:
        return " (must not be negative)"
    if unit == "Pa" and 0.0 < value < lo and lo <= value * 1e9 <= hi:
        return " (given in GPa? values are SI, Pa)"
    if unit in ("-", "Hz") or not (value > hi > 0):  # no milli-units of a rate
        return ""
    if lo <= value * 1e-3 <= hi:
        return " (given in milli-units? values are SI)"
    if unit == "m" and lo <= value * 1e-9 <= hi:  # a roughness or film thickness in nm
        return " (given in nanometres? lengths are in m)"
    return ""


def validate_fields(obj: Any, where: str, separator: str = ".") -> None:
    """Check every field of the dataclass ``obj`` that has :func:`limits` (an optional field
    left unset, None, is skipped; a string is no number here: the loaders convert them); the
    ConfigError names ``where``, ``separator`` and the field."""
    for fld in fields(obj):
        if "min" not in fld.metadata:
            continue
        value = getattr(obj, fld.name)
        if value is None and fld.default is None:
            continue
        check_number(value, fld.metadata, f"{where}{separator}{fld.name}", text=False)


@dataclass(frozen=True, kw_only=True)
class ScrewGeometry:
    """Ball-screw geometry (paper Table A.1), all lengths in metres."""

    pitch_radius: float = quantity("m", 1e-3, 0.5, "r_m, ball-centre helix radius")
    lead: float = quantity("m", 1e-4, 0.2, "p, axial advance per screw revolution")
    ball_radius: float = quantity("m", 1e-4, 0.05, "r_b, sphere radius")
    centre_offset: float = quantity("m", 0.0, 5e-3, "H, gothic-arch centre radius offset")
    ogival_offset: float = quantity("m", 0.0, 5e-3, "L, gothic-arch ogival (axial) offset")
    conformity: float = quantity("-", 0.5, 0.7, "f = r_s / (2 r_b), groove conformity")
    balls_per_nut: int = quantity("-", 1, 500, "Z_eff, loaded spheres per nut", integer=True)
    balls_total_per_nut: int = quantity(
        "-", 1, 500, "Z_tot, spheres per nut incl. recirculation", integer=True
    )
    loaded_turns: float = quantity("-", 0.1, 20.0, "n_t, loaded turns per nut")
    nut_mass: float = quantity("kg", 1e-3, 100.0, "M_n, mass of one nut")
    screw_inertia: float = quantity("kg m^2", 1e-9, 10.0, "I_s, screw moment of inertia about z")
    ball_roughness: float = quantity("m", 0.0, 5e-6, "sigma_b, RMS roughness of the spheres")
    groove_roughness: float = quantity("m", 0.0, 5e-6, "sigma_g, RMS roughness of the grooves")
    inner_containment_angle: float = quantity("rad", 0.0, 1.5, "DCA_i, inner design containment")
    outer_containment_angle: float = quantity("rad", 0.1, 1.57, "DCA_o, outer design containment")
    critical_speed: float = quantity("rad/s", 1.0, 1e5, "critical screw angular speed")
    nominal_contact_angle: float = quantity(
        "rad", 0.1, 1.5, "alpha_0, nominal contact angle used by the catalogue formulas (Eq. 52)"
    )
    orientation: Orientation = field(
        default="vertical",
        metadata={"doc": "screw axis: vertical (master nut above) or horizontal"},
    )

    @property
    def groove_radius(self) -> float:
        """r_s = 2 f r_b, gothic-arch half-groove radius [m]."""
        return 2.0 * self.conformity * self.ball_radius

    @property
    def helix_angle(self) -> float:
        """alpha_e = atan(p / (2 pi r_m)), helix angle at the pitch radius [rad]."""
        return math.atan(self.lead / (2.0 * math.pi * self.pitch_radius))

    @property
    def free_contact_angle(self) -> float:
        """Contact angle at first touch of a radially centred sphere, acos(H/(r_s - r_b)) [rad]."""
        return math.acos(self.centre_offset / (self.groove_radius - self.ball_radius))

    def _validate_containment(self, where: str) -> None:
        """The containment window must hold the loaded contacts: free angle +- the margin."""
        free = self.free_contact_angle
        limits = (
            ("inner_containment_angle", self.inner_containment_angle, free - CONTAINMENT_MARGIN),
            ("outer_containment_angle", self.outer_containment_angle, free + CONTAINMENT_MARGIN),
        )
        for index, (name, value, bound) in enumerate(limits):
            if (value > bound) if index == 0 else (value < bound):
                relation = "<=" if index == 0 else ">="
                raise ConfigError(
                    f"{where}.{name} = {value:.6g} rad ({math.degrees(value):.4g} deg) must be "
                    f"{relation} {bound:.6g} rad ({math.degrees(bound):.4g} deg): the loaded "
                    f"contacts sit up to {math.degrees(CONTAINMENT_MARGIN):g} deg from the free "
                    f"contact angle {math.degrees(free):.4g} deg, and a containment window that "
                    "clips them leaves the steady state without a solution"
                )

    def validate(self, where: str) -> None:
        """Cross-field checks; raise ConfigError naming ``where``."""
        if self.conformity <= 0.5:
            raise ConfigError(
                f"{where}.conformity = {self.conformity} must be > 0.5: a groove radius of "
                "2 f r_b <= r_b leaves the sphere no room"
            )
        clearance = self.groove_radius - self.ball_radius
        if math.hypot(self.centre_offset, self.ogival_offset) >= clearance:
            raise ConfigError(
                f"{where}: hypot(centre_offset, ogival_offset) = "
                f"{math.hypot(self.centre_offset, self.ogival_offset):.4g} m must be smaller than "
                f"r_s - r_b = {clearance:.4g} m, or a centred sphere is already interfering"
            )
        if self.centre_offset >= clearance:
            raise ConfigError(f"{where}: centre_offset must be < r_s - r_b = {clearance:.4g} m")
        mismatch = abs(self.nominal_contact_angle - self.free_contact_angle)
        if mismatch > NOMINAL_ANGLE_TOLERANCE:
            raise ConfigError(
                f"{where}.nominal_contact_angle = {self.nominal_contact_angle:.6g} rad "
                f"({math.degrees(self.nominal_contact_angle):.4g} deg) is "
                f"{math.degrees(mismatch):.3g} deg away from the contact angle the groove gives, "
                f"acos(centre_offset / (2 conformity ball_radius - ball_radius)) = "
                f"{self.free_contact_angle:.6g} rad ({math.degrees(self.free_contact_angle):.4g} "
                f"deg); allowed: {math.degrees(NOMINAL_ANGLE_TOLERANCE):g} deg"
            )
        if self.balls_per_nut > self.balls_total_per_nut:
            raise ConfigError(f"{where}: balls_per_nut exceeds balls_total_per_nut")
        if self.inner_containment_angle >= self.outer_containment_angle:
            raise ConfigError(f"{where}: inner_containment_angle must be < outer_containment_angle")
        self._validate_containment(where)
        # Spheres must fit side by side along the loaded helix.
        helix_length = (
            2.0 * math.pi * self.pitch_radius * self.loaded_turns / math.cos(self.helix_angle)
        )
        if 2.0 * self.ball_radius * self.balls_per_nut > helix_length * 1.0001:
            raise ConfigError(
                f"{where}: {self.balls_per_nut} spheres of radius {self.ball_radius} m do not fit "
                f"on {self.loaded_turns} turns (helix length {helix_length:.4g} m)"
            )


@dataclass(frozen=True, kw_only=True)
class Material:
    """Isotropic elastic solid."""

    young_modulus: float = quantity("Pa", 1e9, 1e12, "E, Young's modulus")
    poisson_ratio: float = quantity(
        "-",
        0.0,
        0.5,
        "nu, Poisson's ratio",
        hint="the Poisson's ratio of an isotropic solid is physically between 0 and 0.5 "
        "(steel about 0.3)",
    )
    density: float = quantity("kg/m^3", 500.0, 25000.0, "rho, mass density")
    thermal_expansion: float = quantity("1/K", 0.0, 1e-4, "linear thermal expansion coefficient")


@dataclass(frozen=True, kw_only=True)
class Materials:
    """Materials of the three bodies."""

    ball: Material
    screw: Material
    nut: Material


@dataclass(frozen=True, kw_only=True)
class Lubricant:
    """Base (or bled) oil of the grease that forms the film (paper Table A.2)."""

    reference_temperature: float = quantity("K", 200.0, 500.0, "T_0 of eta_0 and rho_0")
    viscosity_reference: float = quantity("Pa s", 1e-5, 1e3, "eta_0, dynamic viscosity at T_0")
    second_temperature: float = quantity("K", 200.0, 500.0, "T_1 of the second viscosity point")
    viscosity_second: float = quantity("Pa s", 1e-5, 1e3, "eta_1, dynamic viscosity at T_1")
    density_reference: float = quantity("kg/m^3", 500.0, 2000.0, "rho_0, density at T_0")
    pressure_viscosity_coefficient: float = quantity("1/Pa", 1e-9, 1e-7, "alpha_pv")
    viscosity_temperature_coefficient: float = quantity("1/K", 1e-3, 0.2, "beta (Eq. 24, 32)")
    viscosity_law: ViscosityLaw = field(
        default="roelands",
        metadata={"doc": "viscosity-temperature law: roelands|exponential|walther"},
    )
    density_temperature_coefficient: float = quantity(
        "kg/(m^3 K)", 0.0, 5.0, "alpha_rho, additive thermal term of Eq. 25"
    )
    thermal_conductivity: float = quantity("W/(m K)", 0.01, 1.0, "k_h (Eq. 32)")
    eyring_stress: float = quantity("Pa", 1e3, 1e8, "tau_e, Eyring stress (Eq. 35)")
    limiting_shear_stress: float = quantity("Pa", 0.0, 1e9, "tau_L at zero pressure")
    limiting_shear_pressure_coefficient: float = quantity(
        "-", 0.0, 0.5, "xi: tau_lim = tau_L + xi p"
    )
    residual_layer: float = quantity("m", 0.0, 1e-6, "h_R, residual thickener layer (Eq. 33)")

    def validate(self, where: str) -> None:
        """Cross-field checks; raise ConfigError naming ``where``."""
        if abs(self.second_temperature - self.reference_temperature) < 1.0:
            raise ConfigError(f"{where}: the two viscosity temperatures must differ by > 1 K")
        hot_first = (self.second_temperature - self.reference_temperature) * (
            self.viscosity_second - self.viscosity_reference
        )
        if hot_first >= 0.0:
            raise ConfigError(f"{where}: viscosity must fall as temperature rises")


@dataclass(frozen=True, kw_only=True)
class ContactLaw:
    """Contact parameters the paper does not give (see docs/model.md for their sources)."""

    dry_friction_coefficient: float = quantity("-", 0.0, 1.0, "mu_dry, boundary friction (Eq. 36)")
    dry_friction_regularisation_speed: float = quantity(
        "m/s", 1e-9, 1e-1, "v_r: dry friction grows as tanh(v / v_r) from zero slip"
    )
    damping_coefficient: float = quantity(
        "N s m^-1 (N m^-1.5)^-0.5", 0.0, 1e3, "b_h of Eq. 19, C_H = b_h sqrt(K_H)"
    )


@dataclass(frozen=True, kw_only=True)
class Environment:
    """Surroundings."""

    gravity: float = quantity("m/s^2", 0.0, 100.0, "gravitational acceleration")


@dataclass(frozen=True, kw_only=True)
class TwinConfig:
    """A complete parameter set of one ball screw with its lubricant."""

    name: str
    screw: ScrewGeometry
    materials: Materials
    lubricant: Lubricant
    contact: ContactLaw
    environment: Environment
    source: str = ""

    @property
    def ball_mass(self) -> float:
        """Mass of one sphere [kg]."""
        return self.materials.ball.density * 4.0 / 3.0 * math.pi * self.screw.ball_radius**3

    @property
    def composite_roughness(self) -> float:
        """sqrt(sigma_b^2 + sigma_g^2), denominator of the Tallian parameter, Eq. 38 [m]."""
        return math.hypot(self.screw.ball_roughness, self.screw.groove_roughness)


def config_fingerprint(config: TwinConfig, *, any_orientation: bool = False) -> str:
    """SHA-256 (hex) of every physical parameter of ``config``: its name and source are
    ignored, and with ``any_orientation`` its screw's orientation too (for what holds for both
    orientations, the fidelity bounds). The one fingerprint of the package: a real-time table,
    a commissioned baseline and a fidelity-bounds file are each used only for the parameter
    set it names."""
    plain = replace(config, name="", source="")
    if any_orientation:
        plain = replace(plain, screw=replace(plain.screw, orientation="vertical"))
    return hashlib.sha256(repr(plain).encode()).hexdigest()


# ---------------------------------------------------------------------------------------------
# Loading


def from_mapping(cls: type[_T], data: Any, where: str, **extra: Any) -> _T:
    """The dataclass ``cls`` built from a YAML mapping, every field checked against its
    metadata (a number: :func:`check_number`; a Literal type of this module: one of its
    values); ``extra``: values of fields the mapping does not hold.

    Raises:
        ConfigError: not a mapping, an unknown key, a missing required field or an invalid
            value (naming ``where`` and the field), or a check of ``cls`` across its fields
            (prefixed with ``where``).
    """
    if not isinstance(data, dict):
        raise ConfigError(f"{where}: expected a mapping, got {type(data).__name__}")
    known = {f.name: f for f in fields(cls) if f.init and f.name not in extra}  # type: ignore[arg-type]
    unknown = sorted(str(key) for key in set(data) - set(known))
    if unknown:
        raise ConfigError(f"{where}: unknown key(s) {unknown}; allowed: {sorted(known)}")
    values: dict[str, Any] = dict(extra)
    for name, fld in known.items():
        path = f"{where}.{name}"
        if name not in data:
            if fld.default is MISSING and fld.default_factory is MISSING:
                raise ConfigError(f"{path}: missing")
            continue
        raw = data[name]
        meta = fld.metadata
        if "min" in meta:
            values[name] = check_number(raw, meta, path)
        elif isinstance(fld.type, str) and fld.type in _LITERALS:
            allowed = get_args(_LITERALS[fld.type])
            if raw not in allowed:
                raise ConfigError(f"{path}: {_SHOWN.repr(raw)} is not one of {list(allowed)}")
            values[name] = raw
        else:
            values[name] = raw
    try:
        return cls(**values)
    except ConfigError as err:  # a check of the dataclass across its fields
        raise ConfigError(f"{where}: {err}") from None


_LITERALS: dict[str, Any] = {"ViscosityLaw": ViscosityLaw, "Orientation": Orientation}


def config_from_mapping(data: Any, source: str = "<mapping>") -> TwinConfig:
    """Validate a parsed YAML mapping into a :class:`TwinConfig`; errors name ``source``."""
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: top level must be a mapping")
    required = {"name", "screw", "materials", "lubricant", "contact", "environment"}
    missing = sorted(str(key) for key in required - set(data))
    if missing:
        raise ConfigError(f"{source}: missing section(s) {missing}")
    unknown = sorted(str(key) for key in set(data) - required - {"description"})
    if unknown:
        raise ConfigError(f"{source}: unknown section(s) {unknown}")
    screw = from_mapping(ScrewGeometry, data["screw"], f"{source}: screw")
    screw.validate(f"{source}: screw")
    mats = data["materials"]
    if not isinstance(mats, dict):
        raise ConfigError(f"{source}: materials must be a mapping of ball/screw/nut")
    materials = Materials(
        **{
            body: from_mapping(Material, mats.get(body), f"{source}: materials.{body}")
            for body in ("ball", "screw", "nut")
        }
    )
    lubricant = from_mapping(Lubricant, data["lubricant"], f"{source}: lubricant")
    lubricant.validate(f"{source}: lubricant")
    return TwinConfig(
        name=str(data["name"]),
        screw=screw,
        materials=materials,
        lubricant=lubricant,
        contact=from_mapping(ContactLaw, data["contact"], f"{source}: contact"),
        environment=from_mapping(Environment, data["environment"], f"{source}: environment"),
        source=source,
    )


DEFAULT_CONFIG_NAME = "paper_screw_calibrated.yaml"


def default_config_path() -> Path:
    """The shipped default parameter set: the paper's screw, calibrated to the paper's statement.

    ``config/paper_screw.yaml`` holds the tables with literature values for what the paper
    omits; ``config/paper_screw_calibrated.yaml`` is what ``ballscrew-twin calibrate`` fitted
    from it (docs/model.md, section 9).
    """
    candidates = [
        Path(__file__).resolve().parent.parent / "config" / DEFAULT_CONFIG_NAME,
        Path(sys.prefix) / "share" / "ballscrew_twin" / "config" / DEFAULT_CONFIG_NAME,
    ]
    for path in candidates:
        if path.is_file():
            return path
    raise ConfigError(f"default parameter file not found in {[str(c) for c in candidates]}")


#: The safe YAML loader, on libyaml's parser when PyYAML was built with it (the same values
#: and the same error classes and marks as the pure-Python one; the paper's parameter file
#: parses in 0.65 ms instead of 4.6 ms).
YAML_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def read_yaml(file: Path, what: str) -> Any:
    """Parsed content of a YAML file; ConfigError naming the file when unreadable or invalid.

    Every failure is one line: unreadable file, text that is not UTF-8, YAML syntax (with the
    line and column), nesting too deep for the parser.
    """
    try:
        text = file.read_text(encoding="utf-8")
    except OSError as err:
        raise ConfigError(f"{file}: cannot read {what} ({err.strerror})") from err
    except UnicodeDecodeError as err:
        raise ConfigError(
            f"{file}: {what} is not UTF-8 text (byte 0x{err.object[err.start]:02x} at offset "
            f"{err.start})"
        ) from err
    try:
        return yaml.load(text, Loader=YAML_LOADER)
    except yaml.YAMLError as err:
        raise ConfigError(f"{file}: not valid YAML ({_yaml_problem(err)})") from err
    except RecursionError as err:
        raise ConfigError(f"{file}: {what} is nested too deeply to be parsed") from err


def _yaml_problem(err: yaml.YAMLError) -> str:
    """One line of a YAML error: the problem and where it is (1-based line and column)."""
    problem = getattr(err, "problem", None) or str(err).splitlines()[0]
    mark = getattr(err, "problem_mark", None)
    if mark is not None:
        return f"{problem} at line {mark.line + 1}, column {mark.column + 1}"
    return str(problem)


def path_beside(path: str, source: str | None) -> Path:
    """``path`` (``~`` expanded) as a file named in the YAML file ``source`` means it: a relative
    path is relative to that file's folder (to the working directory when ``source`` is not a
    file, e.g. ``"<mapping>"``)."""
    resolved = Path(path).expanduser()
    if not resolved.is_absolute() and source and not source.startswith("<"):
        resolved = Path(source).resolve().parent / resolved
    return resolved


def load_config(path: str | Path | None = None) -> TwinConfig:
    """Read and validate a YAML parameter file (``None``: the paper's screw)."""
    file = Path(path) if path is not None else default_config_path()
    return config_from_mapping(read_yaml(file, "parameter file"), str(file))
