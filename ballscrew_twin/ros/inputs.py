"""Validation, unit conversion and book-keeping of the twin node's inputs (no rclpy here).

The node keeps the last good value of every input; a command that fails these checks is
rejected with a reason that the node logs and reports on ``/diagnostics``. All values are SI:
rad/s, K, N; times are integer nanoseconds of the node's clock.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import ConfigError
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

    max_screw_speed: float = 2000.0
    min_temperature: float = 233.15
    max_temperature: float = 473.15
    max_preload: float = 50_000.0
    max_axial_load: float = 50_000.0

    def __post_init__(self) -> None:
        """Reject limits that are not finite or not ordered."""
        values = (
            self.max_screw_speed,
            self.min_temperature,
            self.max_temperature,
            self.max_preload,
            self.max_axial_load,
        )
        if not all(math.isfinite(v) for v in values):
            raise ConfigError(f"input limits must be finite: {self}")
        if self.max_screw_speed <= 0.0 or self.max_preload <= 0.0 or self.max_axial_load <= 0.0:
            raise ConfigError(f"max_screw_speed, max_preload, max_axial_load must be > 0: {self}")
        if not 0.0 < self.min_temperature < self.max_temperature:
            raise ConfigError(f"need 0 K < min_temperature < max_temperature: {self}")


def check_screw_speed(value: float, limits: InputLimits) -> str | None:
    """Return why a commanded screw speed [rad/s] is rejected, or None if accepted.

    A speed beyond the limit that would be plausible if it were in rpm is reported as a likely
    unit mistake (topics carry rad/s, REP 103).
    """
    if not math.isfinite(value):
        return f"screw speed {value!r} rad/s is not a finite number"
    if abs(value) > limits.max_screw_speed:
        reason = (
            f"screw speed {value:g} rad/s exceeds the limit of ±{limits.max_screw_speed:g} rad/s"
        )
        if abs(value) * RPM <= limits.max_screw_speed:
            reason += (
                f"; was it sent in rpm? ({value:g} rpm = "
                f"{value * RPM:.4g} rad/s; the topic carries rad/s)"
            )
        return reason
    return None


def check_temperature(value: float, limits: InputLimits) -> str | None:
    """Return why a temperature [K] is rejected, or None if accepted.

    A value that is plausible once the Celsius offset is taken off again is reported as a
    likely unit mistake (``sensor_msgs/Temperature`` carries degrees Celsius).
    """
    if not math.isfinite(value):
        return f"temperature {value!r} K is not a finite number"
    if not limits.min_temperature <= value <= limits.max_temperature:
        reason = (
            f"temperature {value:g} K is outside "
            f"[{limits.min_temperature:g}, {limits.max_temperature:g}] K"
        )
        if limits.min_temperature <= value - CELSIUS_ZERO <= limits.max_temperature:
            reason += "; was it sent in kelvin? sensor_msgs/Temperature carries degrees Celsius"
        return reason
    return None


def check_preload(value: float, limits: InputLimits) -> str | None:
    """Return why a commanded preload [N] is rejected, or None if accepted."""
    if not math.isfinite(value):
        return f"preload {value!r} N is not a finite number"
    if value < 0.0:
        return f"preload {value:g} N is negative"
    if value > limits.max_preload:
        return f"preload {value:g} N exceeds the limit of {limits.max_preload:g} N"
    return None


def check_axial_load(value: float, limits: InputLimits) -> str | None:
    """Return why a commanded external axial load [N] is rejected, or None if accepted."""
    if not math.isfinite(value):
        return f"axial load {value!r} N is not a finite number"
    if abs(value) > limits.max_axial_load:
        return f"axial load {value:g} N exceeds the limit of ±{limits.max_axial_load:g} N"
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
