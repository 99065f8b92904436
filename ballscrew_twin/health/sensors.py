"""Sensor models of a ball-screw test bench: what the bench would record of the true signals.

Each sensor samples at its own rate and adds what real instruments add (all SI):

- torque meter (between drive and screw): measures the drive torque, i.e. the drag torque plus
  the screw's inertia torque I_s dw/dt; constant bias, white noise, quantisation;
- encoder: screw speed and angle; the drive's speed ripple of ``ripple_order`` periods per
  screw revolution (relative amplitude ``ripple``) is a real speed fluctuation, seen in the
  measured speed and in the inertia torque; white speed noise; angle quantised to the
  encoder's counts;
- thermometer: linear drift of the reading with time, white noise, quantisation; the variance
  it reports is ``noise**2``;
- load cell: the preload force of the preload device, bias, white noise, quantisation.

Random numbers come from a ``numpy.random.Generator`` passed in, so a seed reproduces a bag.
Numeric fields are :func:`~ballscrew_twin.params.quantity` fields, checked against their unit
and range by the package's one check (:func:`~ballscrew_twin.params.validate_fields`, used by
the fault and scene dataclasses too) and built from YAML by
:func:`~ballscrew_twin.params.from_mapping`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ConfigError
from ..params import from_mapping, quantity, validate_fields

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, kw_only=True)
class TorqueMeter:
    """Rotary torque transducer between drive and screw."""

    rate: float = quantity("Hz", 1.0, 1e5, "sampling rate", default=200.0)
    noise: float = quantity("N m", 0.0, 1.0, "standard deviation of white noise", default=2e-4)
    bias: float = quantity("N m", -1.0, 1.0, "constant offset of the reading", default=0.0)
    resolution: float = quantity("N m", 0.0, 0.1, "quantisation step (0: none)", default=1e-5)

    def __post_init__(self) -> None:
        validate_fields(self, "sensors.torque")


@dataclass(frozen=True, kw_only=True)
class Encoder:
    """Screw speed and angle (encoder on the drive)."""

    rate: float = quantity("Hz", 1.0, 1e5, "sampling rate", default=100.0)
    noise: float = quantity("rad/s", 0.0, 100.0, "white noise of the speed", default=0.01)
    ripple: float = quantity("-", 0.0, 0.5, "relative speed ripple amplitude", default=0.0)
    ripple_order: float = quantity("-", 0.0, 100.0, "ripple periods per revolution", default=1.0)
    angle_resolution: float = quantity(
        "rad",
        0.0,
        1.0,
        "angle quantisation (one encoder count; 0: none)",
        default=2 * math.pi / 4096,
    )

    def __post_init__(self) -> None:
        validate_fields(self, "sensors.speed")


@dataclass(frozen=True, kw_only=True)
class Thermometer:
    """Temperature of the nut (thermocouple or RTD)."""

    rate: float = quantity("Hz", 0.01, 1e4, "sampling rate", default=10.0)
    noise: float = quantity("K", 0.0, 10.0, "standard deviation of white noise", default=0.05)
    drift: float = quantity("K/s", -0.1, 0.1, "drift of the reading with time", default=0.0)
    resolution: float = quantity("K", 0.0, 1.0, "quantisation step (0: none)", default=0.01)

    def __post_init__(self) -> None:
        validate_fields(self, "sensors.temperature")


@dataclass(frozen=True, kw_only=True)
class LoadCell:
    """Force sensor in the preload device."""

    rate: float = quantity("Hz", 0.01, 1e5, "sampling rate", default=20.0)
    noise: float = quantity("N", 0.0, 1e4, "standard deviation of white noise", default=5.0)
    bias: float = quantity("N", -1e4, 1e4, "constant offset of the reading", default=0.0)
    resolution: float = quantity("N", 0.0, 100.0, "quantisation step (0: none)", default=0.5)

    def __post_init__(self) -> None:
        validate_fields(self, "sensors.preload")


@dataclass(frozen=True, kw_only=True)
class SensorSet:
    """The four bench sensors."""

    torque: TorqueMeter = field(default_factory=TorqueMeter)
    speed: Encoder = field(default_factory=Encoder)
    temperature: Thermometer = field(default_factory=Thermometer)
    preload: LoadCell = field(default_factory=LoadCell)

    def to_dict(self) -> dict[str, dict[str, float]]:
        """Every sensor parameter, SI (for the ground truth)."""
        return {
            f.name: {
                g.name: float(getattr(getattr(self, f.name), g.name))
                for g in fields(getattr(self, f.name))
            }
            for f in fields(self)
        }


SENSOR_CLASSES: dict[str, type[Any]] = {
    "torque": TorqueMeter,
    "speed": Encoder,
    "temperature": Thermometer,
    "preload": LoadCell,
}


def sensors_from_mapping(data: Any, where: str) -> SensorSet:
    """Validate ``{torque: {...}, speed: {...}, temperature: {...}, preload: {...}}`` (each
    optional, defaults otherwise) into a :class:`SensorSet`."""
    if data is None:
        return SensorSet()
    if not isinstance(data, dict):
        raise ConfigError(f"{where}: expected a mapping of sensors, got {type(data).__name__}")
    unknown = sorted(set(map(str, data)) - set(SENSOR_CLASSES))
    if unknown:
        raise ConfigError(
            f"{where}: unknown sensor(s) {unknown}; allowed: {sorted(SENSOR_CLASSES)}"
        )
    return SensorSet(
        **{
            name: from_mapping(cls, data[name] or {}, f"{where}.{name}")
            for name, cls in SENSOR_CLASSES.items()
            if name in data
        }
    )


# ---------------------------------------------------------------------------------------------
# Pure functions


def sample_times(rate: float, duration: float) -> FloatArray:
    """Sampling instants k / rate in [0, duration) [s] of a sensor at ``rate`` [Hz]."""
    count = math.ceil(duration * rate - 1e-9)
    return np.arange(max(count, 0), dtype=np.float64) / rate


def quantise(values: ArrayLike, resolution: float) -> FloatArray:
    """Round to the nearest multiple of ``resolution`` (same unit; 0: unchanged)."""
    x = np.asarray(values, dtype=np.float64)
    if resolution <= 0.0:
        return x.copy()
    return np.round(x / resolution) * resolution


def speed_with_ripple(
    speed: ArrayLike, angle: ArrayLike, ripple: float, order: float
) -> FloatArray:
    """Screw speed with the drive's ripple: w (1 + ripple sin(order * angle)) [rad/s]."""
    w = np.asarray(speed, dtype=np.float64)
    return w * (1.0 + ripple * np.sin(order * np.asarray(angle, dtype=np.float64)))


def cumulative_angle(time: ArrayLike, speed: ArrayLike) -> FloatArray:
    """Angle [rad] as the trapezoidal integral of ``speed`` [rad/s] over ``time`` [s], 0 at
    the first instant."""
    t = np.asarray(time, dtype=np.float64)
    w = np.asarray(speed, dtype=np.float64)
    steps = 0.5 * (w[1:] + w[:-1]) * np.diff(t)
    return np.concatenate(([0.0], np.cumsum(steps)))


def measure(
    true_values: ArrayLike,
    noise: float,
    bias: float,
    resolution: float,
    rng: np.random.Generator,
) -> FloatArray:
    """Reading of an instrument: quantise(true + bias + N(0, noise^2)), units of the input."""
    x = np.asarray(true_values, dtype=np.float64)
    return quantise(x + bias + noise * rng.standard_normal(x.shape), resolution)
