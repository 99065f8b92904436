"""Validity envelope of the models: outside it the answer is a clamped value plus a warning.

The envelope bounds the operating point (temperature, speed, preload, external axial load) to
where the models of this package have been checked to give admissible answers
(docs/model.md, "Validity envelope"). :func:`clamp_operating_point` moves a point into it and
says what it moved; :class:`ValidatedModel` wraps any model (steady-state or time-stepping),
evaluates it at the clamped point, appends the warnings to the output's notes and refuses to
return a non-finite output. Inputs that are not a physical operating point at all (NaN, a
temperature at or below 138 K, which is most likely given in degrees Celsius, a negative
preload) are not clamped: they raise :class:`~ballscrew_twin.errors.OperatingPointError`.

All quantities SI: K, rad/s, N.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import MISSING, dataclass, fields, replace
from typing import Any

import numpy as np

from ..errors import ConfigError, NonFiniteOutputError, OperatingPointError
from ..params import TwinConfig, quantity, validate_fields
from ..units import CELSIUS_ZERO, celsius_to_kelvin
from .base import OperatingPoint, SteadyStateModel, TimeSteppingModel, TwinOutput

#: Lower temperature bound [K] (-40 C): coldest temperature of the steady model's property test
#: and solver-coverage grid (docs/model.md section 9); Roelands (Eq. 24) is extrapolated below
#: the Table A.2 data (25 and 80 C) on both sides.
DEFAULT_MIN_TEMPERATURE = 233.15
#: Upper temperature bound [K] (100 C): hottest temperature of the same checks.
DEFAULT_MAX_TEMPERATURE = 373.15
#: Largest preload [N]: top of the steady model's property test (0-5000 N); the paper covers
#: 0-3000 N. At 5000 N preload plus 5000 N axial load the highest Hertz pressure is 3.9 GPa
#: (steady model), below the 4.2 GPa on which static load ratings are based (ISO 76).
DEFAULT_MAX_PRELOAD = 5000.0
#: Largest external axial load magnitude [N]: the same bound as the preload (see above).
DEFAULT_MAX_AXIAL_LOAD = 5000.0
#: Relative distance beyond a bound still counted as on it [-]: -40 C entered as
#: -40 + 273.15 = 233.14999999999998 K is not a clamp worth a warning.
BOUND_TOLERANCE = 1e-9
#: Fingerprint of the table whose low-preload error was measured: the packaged table of the
#: paper screw (``models/steady_map.py``, ``data/steady_map.npz``).
MEASURED_TABLE_FINGERPRINT = "d0618dc8a021d7fa17062e0409ac84e8e3ee509ec91faee02c8fce1404c13707"
#: Largest drag-torque error [-] of that table against the steady model solved cold (its
#: start-up branch, docs/model.md "One branch"), by preload band [N): (lower, upper, error,
#: preloads measured in the band). Measured by ``ballscrew-twin bench accuracy
#: --low-preload-only`` (2026-11-27, docs/benchmarks.md, issue 14 item 4; the table of 41
#: preload nodes and format 3's temperature nodes, its nut torque interpolated along the preload
#: first with limited slopes; the reference's start-up path at its own tolerance): 12 preloads
#: from 0 to 200 N at 130-3900 rpm and -20..60 C, all 360 points solved. At 150 and 200 N every
#: point is within 0.45 %. Measured again on the table of format 4 (the fold rule, 2026-11-28):
#: the same four bounds to the digit.
REALTIME_LOW_PRELOAD_ERRORS = (
    (0.0, 20.0, 1.93, "0-15 N"),
    (20.0, 50.0, 0.0040, "20 and 30 N"),
    (50.0, 100.0, 0.0037, "50 and 75 N"),
    (100.0, 150.0, 0.0015, "100 N"),
)
#: The real-time table's stated accuracy [-]: a band of :data:`REALTIME_LOW_PRELOAD_ERRORS`
#: measured within it carries no note.
REALTIME_TABLE_ACCURACY = 0.01
#: Name of the real-time table model (``RealTimeModel.name``).
REALTIME_MODEL_NAME = "realtime_map"


def _bound(unit: str, doc: str, *, default: float | None = None) -> Any:
    """A float field > 0 with its unit, range and description as metadata
    (:func:`~ballscrew_twin.params.quantity`; ``default`` None: required)."""
    given = MISSING if default is None else default
    return quantity(unit, 0.0, math.inf, doc, default=given, lo_open=True)


@dataclass(frozen=True, kw_only=True)
class ValidityEnvelope:
    """Where the models' answers are valid (SI units); see the module constants for sources.

    Attributes:
        max_speed: largest screw speed magnitude [rad/s]; :meth:`for_config` takes the screw's
            critical speed (paper Table A.1: 1884.96 rad/s = 18000 rpm), beyond which shaft
            whirl, not modelled here, takes over.
        min_temperature: lowest bulk temperature [K].
        max_temperature: highest bulk temperature [K].
        max_preload: largest preload [N] (the smallest is 0, a valid point).
        max_axial_load: largest magnitude of the external axial load [N].
    """

    max_speed: float = _bound("rad/s", "largest |screw speed|")
    min_temperature: float = _bound("K", "lowest temperature", default=DEFAULT_MIN_TEMPERATURE)
    max_temperature: float = _bound("K", "highest temperature", default=DEFAULT_MAX_TEMPERATURE)
    max_preload: float = _bound("N", "largest preload", default=DEFAULT_MAX_PRELOAD)
    max_axial_load: float = _bound("N", "largest |axial load|", default=DEFAULT_MAX_AXIAL_LOAD)

    def __post_init__(self) -> None:
        validate_fields(self, "validity envelope", ": ")
        if self.min_temperature <= 138.0:
            raise ConfigError(
                f"validity envelope: min_temperature = {self.min_temperature} K must be above "
                "138 K, where the Roelands law is undefined (temperatures are in kelvin)"
            )
        if self.min_temperature >= self.max_temperature:
            raise ConfigError(
                f"validity envelope: min_temperature = {self.min_temperature} K must be below "
                f"max_temperature = {self.max_temperature} K"
            )

    @classmethod
    def for_config(cls, config: TwinConfig, **overrides: float) -> ValidityEnvelope:
        """The default envelope of ``config``'s screw: speed up to its critical speed [rad/s].

        Args:
            config: the parameter set (its ``screw.critical_speed`` bounds the speed).
            overrides: any field of the envelope, in its SI unit.
        """
        values: dict[str, float] = {"max_speed": config.screw.critical_speed}
        values.update(overrides)
        return cls(**values)


def _breaches(
    op: OperatingPoint, envelope: ValidityEnvelope
) -> tuple[OperatingPoint, list[tuple[str, str]]]:
    """``op`` moved into ``envelope`` and, per moved quantity, (what is wrong, value used)."""
    breaches: list[tuple[str, str]] = []
    grow = 1.0 + BOUND_TOLERANCE
    speed = op.screw_speed
    if abs(speed) > envelope.max_speed * grow:
        speed = math.copysign(envelope.max_speed, speed)
        breaches.append(
            (
                f"|screw_speed| = {abs(op.screw_speed):.6g} rad/s exceeds "
                f"{envelope.max_speed:.6g} rad/s",
                f"{speed:.6g} rad/s",
            )
        )
    temperature = op.temperature
    if not envelope.min_temperature / grow <= temperature <= envelope.max_temperature * grow:
        temperature = min(max(temperature, envelope.min_temperature), envelope.max_temperature)
        breaches.append(
            (
                f"temperature = {op.temperature:.6g} K is outside "
                f"[{envelope.min_temperature:.6g}, {envelope.max_temperature:.6g}] K",
                f"{temperature:.6g} K",
            )
        )
    preload = op.preload
    if preload > envelope.max_preload * grow:
        preload = envelope.max_preload
        breaches.append(
            (
                f"preload = {op.preload:.6g} N exceeds {envelope.max_preload:.6g} N",
                f"{preload:.6g} N",
            )
        )
    axial_load = op.axial_load
    if abs(axial_load) > envelope.max_axial_load * grow:
        axial_load = math.copysign(envelope.max_axial_load, axial_load)
        breaches.append(
            (
                f"|axial_load| = {abs(op.axial_load):.6g} N exceeds "
                f"{envelope.max_axial_load:.6g} N",
                f"{axial_load:.6g} N",
            )
        )
    if not breaches:
        return op, []
    clamped = OperatingPoint(
        screw_speed=speed, temperature=temperature, preload=preload, axial_load=axial_load
    )
    return clamped, breaches


def clamp_operating_point(
    op: OperatingPoint, envelope: ValidityEnvelope
) -> tuple[OperatingPoint, tuple[str, ...]]:
    """Move ``op`` into ``envelope``; return the clamped point and one warning per clamp.

    The speed and axial load keep their sign; each warning names the quantity, the requested
    value, the bound and the value used, in SI units. A point inside the envelope is returned
    unchanged with no warning.

    Raises:
        OperatingPointError: ``op`` is not a physical operating point (NaN, infinite,
            temperature <= 138 K, negative preload): an input error, not a validity question.
    """
    op.validate()
    clamped, breaches = _breaches(op, envelope)
    return clamped, tuple(f"validity: {what}: evaluated at {used}" for what, used in breaches)


def refuse_outside(
    points: Iterable[OperatingPoint], envelope: ValidityEnvelope, where: str
) -> None:
    """Raise :class:`OperatingPointError` if any of ``points`` is outside ``envelope``.

    For runs that a clamp would turn into another run (a simulated scenario, a scene's
    profile): the message names ``where`` (file or command), every quantity beyond its bound
    and the section of docs/model.md that gives the envelope.
    """
    problems: list[str] = []
    for op in points:
        op.validate()
        problems += [what for what, _ in _breaches(op, envelope)[1] if what not in problems]
    if problems:
        raise OperatingPointError(
            f"{where}: outside the validity envelope (docs/model.md section 13): "
            + "; ".join(problems)
        )


def kelvin_from_command_line(
    celsius: float, what: str, envelope: ValidityEnvelope | None = None
) -> float:
    """Kelvin [K] of a temperature typed in degrees Celsius; refuse one that looks like kelvin.

    A value whose Celsius reading is outside the envelope but whose kelvin reading is inside
    (``293`` meant as 293 K) raises :class:`OperatingPointError` saying so, instead of being
    clamped; ``what`` names the option in the message. ``envelope`` None: the default
    temperature bounds.
    """
    kelvin = celsius_to_kelvin(celsius)
    lo, hi = DEFAULT_MIN_TEMPERATURE, DEFAULT_MAX_TEMPERATURE
    if envelope is not None:
        lo, hi = envelope.min_temperature, envelope.max_temperature
    grow = 1.0 + BOUND_TOLERANCE
    if not lo / grow <= kelvin <= hi * grow and lo <= celsius <= hi:
        raise OperatingPointError(
            f"{what} = {celsius:g} C is {kelvin:g} K, outside the validity envelope "
            f"[{lo - CELSIUS_ZERO:.6g}, {hi - CELSIUS_ZERO:.6g}] C; it looks like a value in "
            f"kelvin: {what} is in degrees Celsius ({celsius:g} K = "
            f"{celsius - CELSIUS_ZERO:.6g} C)"
        )
    return kelvin


def all_finite(arrays: Iterable[np.ndarray]) -> bool:
    """Whether every element of every numeric array of ``arrays`` is finite (one ``isfinite``
    over the arrays joined: ~5 us for the 15 contact-state arrays of 200 elements, against
    ~25 us array by array)."""
    flat = [np.ravel(a) for a in arrays]
    return bool(np.isfinite(np.concatenate(flat)).all()) if flat else True


def low_preload_note(model: object, op: OperatingPoint) -> str | None:
    """The validity note of the real-time table at a preload below 150 N, or None.

    For the packaged table the note carries the error measured in the preload's band
    (:data:`REALTIME_LOW_PRELOAD_ERRORS`) where that is above the table's 1 %
    (:data:`REALTIME_TABLE_ACCURACY`); a table of another screw was not measured there.
    """
    if getattr(model, "name", None) != REALTIME_MODEL_NAME:
        return None
    table = getattr(model, "map", None)
    measured = getattr(table, "fingerprint", None) == MEASURED_TABLE_FINGERPRINT
    for low, high, error, where in REALTIME_LOW_PRELOAD_ERRORS:
        if low <= op.preload < high:
            if not measured:
                return (
                    f"validity: preload {op.preload:.4g} N is below 150 N, where this screw's "
                    "real-time table was not checked against the steady model (the paper "
                    f"screw's table is off by up to {100 * error:.3g} % in {low:g}-{high:g} N)"
                )
            if error <= REALTIME_TABLE_ACCURACY:
                return None
            return (
                f"validity: preload {op.preload:.4g} N is in {low:g}-{high:g} N, where the "
                f"real-time table's drag torque is off the steady model by up to "
                f"{100 * error:.3g} % (measured at {where}, 130-3900 rpm, -20..60 C)"
            )
    return None


def check_finite_output(out: TwinOutput) -> None:
    """Raise :class:`NonFiniteOutputError` naming the first non-finite number of ``out``."""
    values: dict[str, float] = {
        "drag_torque": out.drag_torque,
        "nut_torque[master]": out.nut_torque[0],
        "nut_torque[slave]": out.nut_torque[1],
    }
    for fld in fields(out.breakdown):
        values[f"breakdown.{fld.name}"] = getattr(out.breakdown, fld.name)
    if out.contacts is not None:
        arrays = {f.name: getattr(out.contacts, f.name) for f in fields(out.contacts)}
        floats = {name: a for name, a in arrays.items() if a.dtype.kind == "f"}
        if not all_finite(floats.values()):
            for name, array in floats.items():
                if not np.isfinite(array).all():
                    values[f"contacts.{name}"] = math.nan
    for name, value in values.items():
        if not math.isfinite(value):
            raise NonFiniteOutputError(
                f"{out.fidelity}: {name} = {value} is not finite at {out.operating_point}"
            )


class ValidatedModel:
    """A model that is only ever evaluated inside its validity envelope.

    Wraps a :class:`~ballscrew_twin.models.base.SteadyStateModel` (``evaluate``) or a
    :class:`~ballscrew_twin.models.base.TimeSteppingModel` (``reset``/``step``); the methods the
    wrapped model lacks raise ``TypeError``. Each output is the wrapped model's output at the
    clamped operating point, with ``operating_point`` the point actually evaluated and one note
    per clamped quantity, and for the real-time table at a preload below 150 N the error
    measured there where it exceeds 1 % (:func:`low_preload_note`); a non-finite output raises
    :class:`NonFiniteOutputError` instead of being returned.

    Args:
        model: the model to wrap.
        envelope: its validity envelope.
    """

    def __init__(
        self, model: SteadyStateModel | TimeSteppingModel, envelope: ValidityEnvelope
    ) -> None:
        self.model = model
        self.envelope = envelope
        self.name = model.name
        # The last output found finite: a model that returns its cached output for an unchanged
        # command (the real-time model) is not scanned again at every tick.
        self._checked: TwinOutput | None = None

    #: ``step`` takes ``contacts=False`` (passed on to a model that has this flag).
    optional_contacts = True

    def _finish(self, out: TwinOutput, warnings: tuple[str, ...]) -> TwinOutput:
        if out is not self._checked:
            check_finite_output(out)
            self._checked = out
        if warnings:
            out = replace(out, notes=(*out.notes, *warnings))
        return out

    def _with_low_preload(self, op: OperatingPoint, warnings: tuple[str, ...]) -> tuple[str, ...]:
        note = low_preload_note(self.model, op)
        return warnings if note is None else (*warnings, note)

    def evaluate(self, op: OperatingPoint) -> TwinOutput:
        """The wrapped steady-state model at ``op`` clamped into the envelope."""
        evaluate = getattr(self.model, "evaluate", None)
        if evaluate is None:
            raise TypeError(f"{self.name} is not a steady-state model (no evaluate)")
        clamped, warnings = clamp_operating_point(op, self.envelope)
        return self._finish(evaluate(clamped), self._with_low_preload(clamped, warnings))

    def reset(self, op: OperatingPoint) -> None:
        """Reset the wrapped time-stepping model in the steady state of clamped ``op``."""
        reset = getattr(self.model, "reset", None)
        if reset is None:
            raise TypeError(f"{self.name} is not a time-stepping model (no reset)")
        clamped, _ = clamp_operating_point(op, self.envelope)
        reset(clamped)

    def step(self, op: OperatingPoint, dt: float, contacts: bool = True) -> TwinOutput:
        """Advance the wrapped time-stepping model by ``dt`` [s] under clamped ``op``.

        ``contacts=False`` is passed on to a model with ``optional_contacts`` (it then leaves
        the contact states out); other models ignore it.
        """
        step = getattr(self.model, "step", None)
        if step is None:
            raise TypeError(f"{self.name} is not a time-stepping model (no step)")
        if not (math.isfinite(dt) and dt > 0.0):
            raise OperatingPointError(f"time step dt = {dt!r} s must be finite and > 0")
        clamped, warnings = clamp_operating_point(op, self.envelope)
        warnings = self._with_low_preload(clamped, warnings)
        if not contacts and getattr(self.model, "optional_contacts", False):
            return self._finish(step(clamped, dt, contacts=False), warnings)
        return self._finish(step(clamped, dt), warnings)
