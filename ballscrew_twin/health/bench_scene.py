"""Bench scene files: operating profile, sensors and injected faults of a generated bench bag.

A scene (``config/bench_scenes/*.yaml``, SI units: s, rad/s, K, N) is a frozen, validated
:class:`BenchScene`. The operating profile is a list of points ``{time, speed, temperature,
preload}`` joined by straight lines (a step is two points close in time) and held after the
last one; the sensors are those of :mod:`~ballscrew_twin.health.sensors` and the faults those
of :mod:`~ballscrew_twin.health.fault_profiles`. Errors name the file and the field.

Keys::

    name: healthy                 # str
    description: ...              # optional
    config: null                  # screw parameter YAML, relative to the scene file (null: shipped)
    duration: 20.0                # s, length of the bag
    seed: 0                       # random seed of the sensor noise (the CLI's --seed overrides)
    model_step: 0.1               # s, spacing of the twin's evaluations (linear in between)
    profile: [{time: 0.0, speed: 10.47, temperature: 293.15, preload: 1500.0}, ...]
    sensors: {torque: {...}, speed: {...}, temperature: {...}, preload: {...}}
    faults: [{class: preload_loss, onset: 8.0, severity: 0.2, growth: ramp, growth_time: 2.0}]
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ConfigError
from ..models.profile import Profile
from ..params import (
    check_number,
    from_mapping,
    path_beside,
    quantity,
    read_yaml,
    validate_fields,
)
from .fault_profiles import FaultSpec, faults_from_list
from .sensors import SensorSet, sensors_from_mapping

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, kw_only=True)
class ProfilePoint:
    """One corner of the piecewise-linear operating profile (a row of the scene file; the
    commands are :class:`~ballscrew_twin.models.profile.Profile` objects, ``profiles``)."""

    time: float = quantity("s", 0.0, 1e6, "time since the start")
    speed: float = quantity("rad/s", -2000.0, 2000.0, "screw speed (sign = direction)")
    temperature: float = quantity("K", 233.15, 473.15, "bulk temperature of nut and lubricant")
    preload: float = quantity("N", 0.0, 5e4, "preload set in the preload device")


@dataclass(frozen=True, kw_only=True)
class BenchScene:
    """A generated bench recording: profile, sensors, faults (see the module docstring)."""

    name: str
    description: str = ""
    config: str | None = None
    duration: float = quantity("s", 0.0, 36000.0, "length of the recording", lo_open=True)
    seed: int = 0
    model_step: float = quantity("s", 1e-3, 10.0, "spacing of the twin evaluations", default=0.1)
    profile: tuple[ProfilePoint, ...] = ()
    sensors: SensorSet = field(default_factory=SensorSet)
    faults: tuple[FaultSpec, ...] = ()
    source: str = ""

    def __post_init__(self) -> None:
        where = self.source or "<bench scene>"
        if not isinstance(self.name, str) or not self.name.strip():
            raise ConfigError(f"{where}: name must be a non-empty string, got {self.name!r}")
        validate_fields(self, where, ": ")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise ConfigError(f"{where}: seed must be a whole number >= 0, got {self.seed!r}")
        if not self.profile:
            raise ConfigError(f"{where}: profile needs at least one point")
        if self.profile[0].time != 0.0:
            raise ConfigError(f"{where}: profile[0].time must be 0 s, got {self.profile[0].time}")
        times = [p.time for p in self.profile]
        for k in range(1, len(times)):
            if times[k] <= times[k - 1]:
                raise ConfigError(
                    f"{where}: profile[{k}].time = {times[k]} s is not after "
                    f"profile[{k - 1}].time = {times[k - 1]} s"
                )
        for k, spec in enumerate(self.faults):
            if spec.onset >= self.duration:
                raise ConfigError(
                    f"{where}: faults[{k}].onset = {spec.onset} s is not before the end of the "
                    f"recording (duration {self.duration} s)"
                )

    @cached_property
    def profiles(self) -> dict[str, Profile]:
        """The speed [rad/s], temperature [K] and preload [N] commands: linear between the
        points of ``profile``."""
        times = tuple(p.time for p in self.profile)
        return {
            name: Profile(times, tuple(getattr(p, name) for p in self.profile))
            for name in ("speed", "temperature", "preload")
        }

    def profile_at(self, time: ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Speed [rad/s], temperature [K] and preload [N] of the profile at ``time`` [s]."""
        profiles = self.profiles
        return (
            profiles["speed"].at(time),
            profiles["temperature"].at(time),
            profiles["preload"].at(time),
        )

    def breakpoints(self) -> FloatArray:
        """Times [s] where the inputs of the twin change slope or jump: profile corners and
        fault onsets and ramp ends, within [0, duration]."""
        points = [p.time for p in self.profile]
        for spec in self.faults:
            points.append(spec.onset)
            if spec.growth == "ramp":
                points.append(spec.onset + spec.growth_time)
        return np.unique(np.clip(np.array([*points, 0.0, self.duration]), 0.0, self.duration))

    def config_path(self) -> Path | None:
        """Screw parameter file: ``config`` resolved against the scene file's folder."""
        if self.config is None:
            return None
        return path_beside(self.config, self.source)


#: The unit and range of each numeric field of :class:`BenchScene` (its field metadata).
_LIMITS = {f.name: f.metadata for f in fields(BenchScene) if "min" in f.metadata}

SCENE_KEYS = (
    "name",
    "description",
    "config",
    "duration",
    "seed",
    "model_step",
    "profile",
    "sensors",
    "faults",
)


def bench_scene_from_mapping(data: Any, source: str = "<mapping>") -> BenchScene:
    """Validate a parsed YAML mapping into a :class:`BenchScene`; errors name ``source``."""
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: top level must be a mapping of bench-scene keys")
    unknown = sorted(set(map(str, data)) - set(SCENE_KEYS))
    if unknown:
        raise ConfigError(f"{source}: unknown key(s) {unknown}; allowed: {list(SCENE_KEYS)}")
    for key in ("name", "duration", "profile"):
        if key not in data:
            raise ConfigError(f"{source}: {key}: missing")
    profile = data["profile"]
    if not isinstance(profile, list):
        raise ConfigError(f"{source}: profile must be a list of points")
    points = tuple(
        from_mapping(ProfilePoint, item, f"{source}: profile[{k}]")
        for k, item in enumerate(profile)
    )
    config = data.get("config")
    if config is not None and not isinstance(config, str):
        raise ConfigError(f"{source}: config must be a path string or null, got {config!r}")
    values: dict[str, Any] = {
        "name": data["name"],
        "description": str(data.get("description") or ""),
        "config": config,
        "duration": check_number(data["duration"], _LIMITS["duration"], f"{source}: duration"),
        "profile": points,
        "sensors": sensors_from_mapping(data.get("sensors"), f"{source}: sensors"),
        "faults": faults_from_list(data.get("faults"), f"{source}: faults"),
        "source": source,
    }
    if "seed" in data:
        values["seed"] = data["seed"]
    if "model_step" in data:
        values["model_step"] = check_number(
            data["model_step"], _LIMITS["model_step"], f"{source}: model_step"
        )
    return BenchScene(**values)


def load_bench_scene(path: str | Path) -> BenchScene:
    """Read and validate a bench scene YAML file (ConfigError naming file and field)."""
    file = Path(path)
    return bench_scene_from_mapping(read_yaml(file, "bench scene file"), str(file))
