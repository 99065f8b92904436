"""Validation and unit conversion of the twin node's commanded inputs (no rclpy here).

The node keeps the last good value of every input; a command that fails these checks is
rejected with a reason that the node logs. All values are SI: rad/s, K, N.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: Offset between the Celsius and kelvin scales [K].
CELSIUS_TO_KELVIN_OFFSET = 273.15


def celsius_to_kelvin(celsius: float) -> float:
    """Convert a temperature from degrees Celsius to kelvin [K]."""
    return celsius + CELSIUS_TO_KELVIN_OFFSET


@dataclass(frozen=True, kw_only=True)
class InputLimits:
    """Plausibility limits of commanded inputs; outside them a command is rejected.

    Attributes:
        max_screw_speed: largest accepted magnitude of the screw speed [rad/s].
        min_temperature: lowest accepted temperature [K].
        max_temperature: highest accepted temperature [K].
        max_preload: largest accepted preload [N]; the smallest is 0 N.
    """

    max_screw_speed: float = 2000.0
    min_temperature: float = 233.15
    max_temperature: float = 473.15
    max_preload: float = 50_000.0

    def __post_init__(self) -> None:
        """Reject limits that are not finite or not ordered."""
        values = (self.max_screw_speed, self.min_temperature, self.max_temperature,
                  self.max_preload)
        if not all(math.isfinite(v) for v in values):
            raise ValueError(f"input limits must be finite: {self}")
        if self.max_screw_speed <= 0.0 or self.max_preload <= 0.0:
            raise ValueError(f"max_screw_speed and max_preload must be > 0: {self}")
        if not 0.0 < self.min_temperature < self.max_temperature:
            raise ValueError(f"need 0 K < min_temperature < max_temperature: {self}")


def check_screw_speed(value: float, limits: InputLimits) -> str | None:
    """Return why a commanded screw speed [rad/s] is rejected, or None if accepted."""
    if not math.isfinite(value):
        return f"screw speed {value!r} rad/s is not a finite number"
    if abs(value) > limits.max_screw_speed:
        return (f"screw speed {value:g} rad/s exceeds the limit of "
                f"±{limits.max_screw_speed:g} rad/s")
    return None


def check_temperature(value: float, limits: InputLimits) -> str | None:
    """Return why a temperature [K] is rejected, or None if accepted."""
    if not math.isfinite(value):
        return f"temperature {value!r} K is not a finite number"
    if not limits.min_temperature <= value <= limits.max_temperature:
        return (f"temperature {value:g} K is outside "
                f"[{limits.min_temperature:g}, {limits.max_temperature:g}] K")
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
