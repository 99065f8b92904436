"""Validation, unit conversion and book-keeping of the twin node's inputs, and the health
node's check of a bench sample (no rclpy here).

The twin node keeps the last good value of every input; a command that fails these checks is
rejected with a reason that the node logs and reports on ``/diagnostics``: the package's one
number check (:func:`~ballscrew_twin.params.check_number`) names the input, its unit and its
range. All values are SI: rad/s, K, N; times are integer nanoseconds of the node's clock. The
health node drops a sample that :func:`check_sample` refuses (the same check: finite numbers).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import ConfigError
from ..params import check_number, finite, limits, quantity, validate_fields
from ..units import CELSIUS_ZERO, NS_PER_S, RPM


@dataclass(frozen=True, kw_only=True)
class InputLimits:
    """Plausibility limits of commanded inputs; outside them a command is rejected.

    Attributes:
        max_screw_speed: largest accepted magnitude of the screw speed [rad/s].
        min_temperature: lowest accepted temperature [K].
        max_temperature: highest accepted temperature [K].
        max_preload: largest accepted preload [N]; the smallest is 0 N.
        max_axial_load: largest accepted magnitude of the external axial load [N].
    """

    max_screw_speed: float = quantity(
        "rad/s", 0.0, math.inf, "largest |screw speed|", default=2000.0, lo_open=True
    )
    min_temperature: float = quantity(
        "K", 0.0, math.inf, "lowest temperature", default=233.15, lo_open=True
    )
    max_temperature: float = quantity(
        "K", 0.0, math.inf, "highest temperature", default=473.15, lo_open=True
    )
    max_preload: float = quantity(
        "N", 0.0, math.inf, "largest preload", default=50_000.0, lo_open=True
    )
    max_axial_load: float = quantity(
        "N", 0.0, math.inf, "largest |axial load|", default=50_000.0, lo_open=True
    )

    def __post_init__(self) -> None:
        """Reject limits that are not finite and positive (the package's one number check,
        naming the parameter) or not ordered."""
        validate_fields(self, "limits")
        if not self.min_temperature < self.max_temperature:
            raise ConfigError(
                f"limits.min_temperature = {self.min_temperature:g} K must be below "
                f"limits.max_temperature = {self.max_temperature:g} K"
            )


def _refusal(
    value: float, what: str, unit: str, lo: float, hi: float, hint: str | None
) -> str | None:
    """Why ``value`` [unit] is refused for the input ``what`` by the package's one number
    check (finite, within [lo, hi]; the reason names the input, the unit and the range, with
    ``hint`` when out of range), or None when accepted."""
    try:
        check_number(value, limits(unit, lo, hi, hint=hint), what, text=False)
    except ConfigError as err:
        return str(err)
    return None


def check_screw_speed(value: float, limits: InputLimits) -> str | None:
    """Return why a commanded screw speed [rad/s] is rejected, or None if accepted.

    A speed beyond the limit that would be plausible if it were in rpm is reported as a likely
    unit mistake (topics carry rad/s, REP 103).
    """
    top = limits.max_screw_speed
    hint = None
    if abs(value) * RPM <= top:
        hint = (
            f"was it sent in rpm? {value:g} rpm = {value * RPM:.4g} rad/s; the topic carries rad/s"
        )
    return _refusal(value, "screw speed", "rad/s", -top, top, hint)


def check_temperature(value: float, limits: InputLimits) -> str | None:
    """Return why a temperature [K] is rejected, or None if accepted.

    A value that is plausible once the Celsius offset is taken off again is reported as a
    likely unit mistake (``sensor_msgs/Temperature`` carries degrees Celsius).
    """
    lo, hi = limits.min_temperature, limits.max_temperature
    hint = None
    if lo <= value - CELSIUS_ZERO <= hi:
        hint = "was it sent in kelvin? sensor_msgs/Temperature carries degrees Celsius"
    return _refusal(value, "temperature", "K", lo, hi, hint)


def check_preload(value: float, limits: InputLimits) -> str | None:
    """Return why a commanded preload [N] is rejected, or None if accepted."""
    hint = "must not be negative" if value < 0.0 else None
    return _refusal(value, "preload", "N", 0.0, limits.max_preload, hint)


def check_axial_load(value: float, limits: InputLimits) -> str | None:
    """Return why a commanded external axial load [N] is rejected, or None if accepted."""
    top = limits.max_axial_load
    return _refusal(value, "axial load", "N", -top, top, None)


#: Unit of the values of each of the health node's sample channels (converted to SI).
SAMPLE_UNITS = {"torque": "N m", "speed": "rad/s", "temperature": "K", "preload": "N"}
#: What a sample's stamp and each channel's value are checked against: any finite number.
_STAMP_LIMITS = finite("s")
_SAMPLE_LIMITS = {channel: finite(unit) for channel, unit in SAMPLE_UNITS.items()}


def check_sample(channel: str, stamp: float, value: float) -> str | None:
    """Return why a health-node sample of ``channel`` (a key of :data:`SAMPLE_UNITS`) at
    ``stamp`` [s] with ``value`` [its unit] is dropped, or None when both are finite numbers
    (the package's one number check: the reason names the channel, the unit and the value).
    Called for every sample: the limits are built once, the reason only for a refusal."""
    try:
        check_number(stamp, _STAMP_LIMITS, "stamp", text=False)
        check_number(value, _SAMPLE_LIMITS[channel], "value", text=False)
    except ConfigError as err:
        return f"{channel} sample at {stamp!r} s: {err}"
    return None


def check_stamp(
    stamp_ns: int, *, last_stamp_ns: int | None, now_ns: int, max_age_ns: int
) -> str | None:
    """Return why a message's header stamp makes it unusable, or None if accepted.

    A zero stamp means "not stamped" and is accepted (many bench publishers leave it unset).

    Args:
        stamp_ns: header stamp of the message [ns].
        last_stamp_ns: stamp of the last accepted message of the same input, or None [ns].
        now_ns: the node's clock now [ns].
        max_age_ns: largest accepted |now - stamp| [ns]; 0 switches the age check off.
    """
    if stamp_ns == 0:
        return None
    if last_stamp_ns is not None and stamp_ns < last_stamp_ns:
        return (
            f"stamp {stamp_ns / NS_PER_S:.6f} s is older than the last accepted one "
            f"({last_stamp_ns / NS_PER_S:.6f} s): out of order"
        )
    if max_age_ns > 0:
        age = now_ns - stamp_ns
        if age > max_age_ns:
            return (
                f"stamp {stamp_ns / NS_PER_S:.6f} s is {age / NS_PER_S:.3f} s old "
                f"(limit {max_age_ns / NS_PER_S:g} s): stale"
            )
        if -age > max_age_ns:
            return (
                f"stamp {stamp_ns / NS_PER_S:.6f} s is {-age / NS_PER_S:.3f} s ahead of the "
                f"node's clock (limit {max_age_ns / NS_PER_S:g} s)"
            )
    return None


class InputChannel:
    """Last good value of one input with its history: arrivals, stamps, rejections.

    Args:
        name: what the input is, e.g. ``"screw speed"``.
        unit: unit of :attr:`value`, e.g. ``"rad/s"``.
        value: value in force until the first accepted message [unit].
    """

    def __init__(self, name: str, unit: str, value: float) -> None:
        self.name = name
        self.unit = unit
        self.value = value
        #: Node clock at the last accepted message, None before the first one [ns].
        self.last_arrival_ns: int | None = None
        #: Header stamp of the last accepted stamped message [ns].
        self.last_stamp_ns: int | None = None
        self.accepted = 0
        self.rejected = 0
        self.last_rejection = ""
        #: Rejected and received messages at the last :meth:`window_counts`.
        self._reported = (0, 0)

    def accept(self, value: float, now_ns: int, stamp_ns: int = 0) -> None:
        """Take a checked value [unit] that arrived at ``now_ns`` with header ``stamp_ns``."""
        self.value = value
        self.last_arrival_ns = now_ns
        if stamp_ns:
            self.last_stamp_ns = stamp_ns
        self.accepted += 1

    def reject(self, reason: str) -> None:
        """Count a rejected message; the last good value stays in force."""
        self.rejected += 1
        self.last_rejection = reason

    def window_counts(self) -> tuple[int, int]:
        """Messages rejected and received since the last call (one /diagnostics window)."""
        rejected, received = self.rejected, self.accepted + self.rejected
        counts = (rejected - self._reported[0], received - self._reported[1])
        self._reported = (rejected, received)
        return counts

    def forget_times(self) -> None:
        """Forget arrival time and stamp (after the clock jumped backwards)."""
        self.last_arrival_ns = None
        self.last_stamp_ns = None

    def age(self, now_ns: int) -> float | None:
        """Time since the last accepted message [s], None if none arrived yet."""
        if self.last_arrival_ns is None:
            return None
        return (now_ns - self.last_arrival_ns) / NS_PER_S

    def is_stale(self, now_ns: int, stale_after: float) -> bool:
        """Whether no message was accepted for longer than ``stale_after`` [s] (or ever)."""
        age = self.age(now_ns)
        return age is None or age > stale_after
