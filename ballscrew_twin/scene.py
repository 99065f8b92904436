"""Scenes: what the user wants simulated, read from YAML, for the fidelity selection.

A scene names the screw and lubricant (a parameter file), the orientation of the screw, the
command profiles over time (screw speed, temperature, preload, optional external axial load),
the faults to inject, the outputs wanted and the error the user accepts, the output rate and the
duration. ``ballscrew-twin scene FILE`` (:mod:`ballscrew_twin.run_scene`) picks the cheapest model
within that error (:mod:`ballscrew_twin.fidelity`) and runs the profiles through it.

**The file is SI throughout**: times in s, speed in rad/s, temperature in K, forces in N, rates
in Hz; accepted errors are relative (dimensionless). Like the parameter and scenario files, the
loader rejects unknown keys, missing required keys, non-finite numbers and out-of-range values
with a message naming the file, the field, the value and the unit (with a hint when the value
looks like rpm or degrees Celsius).

A command profile is a constant number, or a mapping with ``points`` (piecewise-linear
breakpoints ``[[t0, v0], [t1, v1], ...]``, held constant before the first and after the last)
and/or ``steps`` (smooth cubic steps ``{time, duration, change}`` added on top, see
:func:`ballscrew_twin.models.profile.smooth_step`). Example: ``config/scenes/*.yaml``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, get_args

import numpy as np
from numpy.typing import NDArray

from .errors import ConfigError
from .models.base import OperatingPoint
from .models.faults import Faults, faults_from_mapping
from .models.profile import Profile, SmoothStep
from .params import Orientation, check_number, limits, path_beside, range_hint, read_yaml

FloatArray = NDArray[np.float64]
Output = Literal["drag", "per_nut", "per_sphere"]
OUTPUTS: tuple[str, ...] = get_args(Output)
QUANTITIES = ("speed", "temperature", "preload", "axial_load")

#: quantity -> (unit, lowest, highest allowed value at any time)
LIMITS: dict[str, tuple[str, float, float]] = {
    "speed": ("rad/s", -1e4, 1e4),
    "temperature": ("K", 139.0, 500.0),
    "preload": ("N", 0.0, 1e5),
    "axial_load": ("N", -1e5, 1e5),
}
MAX_DURATION = 3600.0  # s
MAX_OUTPUT_RATE = 1e6  # Hz
RATE_LIMITS = limits(
    "Hz", 0.0, MAX_OUTPUT_RATE, lo_open=True, hint="output_rate is in samples per second"
)
#: an accepted error, relative [-]
TOLERANCE_LIMITS = limits(
    "- (relative)", 0.0, 10.0, lo_open=True, hint="a relative error: 1 % is 0.01"
)
#: accepted-error keys -> what they bound
TOLERANCES: dict[str, str] = {
    "drag_torque": "relative error of the drag torque (and of each nut's torque)",
    "contact_force": "error of the contact normal forces relative to the largest one",
}


@dataclass(frozen=True, kw_only=True)
class Scene:
    """A validated scene (SI units). See the module docstring for the file format.

    Attributes:
        name: name of the scene.
        source: file read from ("" when built in code).
        config: parameter YAML resolved against the scene's folder (None: shipped default).
        orientation: screw axis, overrides the parameter file's.
        duration: simulated time [s].
        output_rate: samples written per second [Hz].
        speed, temperature, preload, axial_load: command profiles [rad/s], [K], [N], [N].
        faults: defects to inject (models/faults.py); raw mapping kept for the dynamic model.
        outputs: what is wanted, a subset of drag / per_nut / per_sphere.
        tolerance: accepted error per quantity, keys of :data:`TOLERANCES` [-].
    """

    name: str
    source: str = ""
    config: Path | None = None
    orientation: Orientation | None = None
    duration: float
    output_rate: float
    speed: Profile
    temperature: Profile
    preload: Profile
    axial_load: Profile = field(default_factory=lambda: Profile((), ()))
    faults: Faults = field(default_factory=Faults)
    faults_mapping: Any = None
    outputs: tuple[str, ...] = ("drag",)
    tolerance: dict[str, float] = field(default_factory=dict)

    def profile(self, quantity: str) -> Profile:
        """The profile of ``quantity`` (one of :data:`QUANTITIES`)."""
        return getattr(self, quantity)

    def operating_point(self, t: float) -> OperatingPoint:
        """The commanded operating point at time ``t`` [s]."""
        return OperatingPoint(
            screw_speed=self.speed(t),
            temperature=self.temperature(t),
            preload=self.preload(t),
            axial_load=self.axial_load(t),
        )

    def output_times(self) -> FloatArray:
        """Sample times 0, 1/rate, ... up to and including ``duration`` [s]."""
        count = math.floor(self.duration * self.output_rate + 1e-9) + 1
        return np.arange(count) / self.output_rate

    def range(self, quantity: str) -> tuple[float, float]:
        """Lowest and highest value of ``quantity`` over the run, at :meth:`Profile.knots`."""
        prof = self.profile(quantity)
        times = [0.0, self.duration] + [t for t in prof.knots() if 0.0 <= t <= self.duration]
        values = [prof(t) for t in times]
        return min(values), max(values)

    def speed_magnitude_range(self) -> tuple[float, float]:
        """Lowest and highest |screw speed| over the run [rad/s] (0 when it crosses zero)."""
        lo, hi = self.range("speed")
        if lo <= 0.0 <= hi:
            return 0.0, max(-lo, hi)
        return min(abs(lo), abs(hi)), max(abs(lo), abs(hi))

    @property
    def has_faults(self) -> bool:
        """True when any defect is injected."""
        return bool(self.faults.spheres or self.faults.spalls)

    def wants(self, output: str) -> bool:
        """True when ``output`` (drag / per_nut / per_sphere) is requested."""
        return output in self.outputs


# --------------------------------------------------------------------------------- loading

_TOP_KEYS = {
    "name",
    "description",
    "config",
    "orientation",
    "duration",
    "output_rate",
    "commands",
    "faults",
    "outputs",
    "tolerance",
}
_REQUIRED = ("name", "duration", "output_rate", "commands", "tolerance")


def _profile(raw: Any, quantity: str, where: str, duration: float) -> Profile:
    """Validate one command profile (a number or {points, steps})."""
    unit, lo, hi = LIMITS[quantity]
    path = f"{where}: commands.{quantity}"
    if not isinstance(raw, dict):
        value = check_number(raw, limits(unit, lo, hi), path)
        return Profile((0.0,), (value,))
    unknown = sorted(set(map(str, raw)) - {"points", "steps"})
    if unknown:
        raise ConfigError(f"{path}: unknown key(s) {unknown}; allowed: ['points', 'steps']")
    if "points" not in raw and "steps" not in raw:
        raise ConfigError(f"{path}: give points and/or steps")
    times: list[float] = []
    values: list[float] = []
    points = raw.get("points") or []
    if not isinstance(points, list):
        raise ConfigError(f"{path}.points: expected a list of [time s, value {unit}] pairs")
    for k, pair in enumerate(points):
        here = f"{path}.points[{k}]"
        if not isinstance(pair, list | tuple) or len(pair) != 2:
            raise ConfigError(f"{here}: expected [time s, value {unit}], got {pair!r}")
        t = check_number(pair[0], limits("s", 0.0, duration), f"{here}[0] (time)")
        if times and t <= times[-1]:
            raise ConfigError(
                f"{here}[0] (time) = {t} s must be later than the previous breakpoint "
                f"({times[-1]} s)"
            )
        times.append(t)
        values.append(check_number(pair[1], limits(unit, lo, hi), f"{here}[1] (value)"))
    steps: list[SmoothStep] = []
    raw_steps = raw.get("steps") or []
    if not isinstance(raw_steps, list):
        raise ConfigError(f"{path}.steps: expected a list of {{time, duration, change}}")
    for k, item in enumerate(raw_steps):
        here = f"{path}.steps[{k}]"
        if not isinstance(item, dict):
            raise ConfigError(f"{here}: expected a mapping {{time, duration, change}}")
        bad = sorted(set(map(str, item)) - {"time", "duration", "change"})
        if bad:
            raise ConfigError(f"{here}: unknown key(s) {bad}; allowed: time, duration, change")
        for key in ("time", "change"):
            if key not in item:
                raise ConfigError(f"{here}.{key}: missing")
        start = check_number(item["time"], limits("s", 0.0, duration), f"{here}.time")
        length = check_number(
            item.get("duration", 0.0), limits("s", 0.0, duration), f"{here}.duration"
        )
        change = check_number(item["change"], limits(unit, lo - hi, hi - lo), f"{here}.change")
        steps.append(SmoothStep(start, start + length, change))
    if not times:  # steps alone: on top of 0 from t = 0 on
        times, values = [0.0], [0.0]
    profile = Profile(tuple(times), tuple(values), tuple(steps))
    # The sum of pieces and steps must itself stay in range at every time.
    check = sorted({0.0, duration, *(t for t in profile.knots() if 0.0 <= t <= duration)})
    for t in check:
        value = profile(t)
        if not lo <= value <= hi:
            raise ConfigError(
                f"{path}: the profile reaches {value:.6g} {unit} at t = {t:.6g} s, outside "
                f"[{lo:g}, {hi:g}] {unit}{range_hint(value, limits(unit, lo, hi))}"
            )
    return profile


def scene_from_mapping(data: Any, source: str = "<mapping>") -> Scene:
    """Validate a parsed YAML mapping into a :class:`Scene`; errors name ``source``."""
    where = source
    if not isinstance(data, dict):
        raise ConfigError(f"{where}: top level must be a mapping of scene fields")
    unknown = sorted(set(map(str, data)) - _TOP_KEYS)
    if unknown:
        raise ConfigError(f"{where}: unknown key(s) {unknown}; allowed: {sorted(_TOP_KEYS)}")
    for key in _REQUIRED:
        if key not in data:
            raise ConfigError(f"{where}: {key}: missing")
    name = data["name"]
    if not isinstance(name, str) or not name.strip():
        raise ConfigError(f"{where}: name must be a non-empty string, got {name!r}")
    config: Path | None = None
    if data.get("config") is not None:
        if not isinstance(data["config"], str) or not data["config"]:
            raise ConfigError(f"{where}: config must be a path string, got {data['config']!r}")
        config = path_beside(data["config"], source)
    orientation = data.get("orientation")
    if orientation is not None and orientation not in get_args(Orientation):
        raise ConfigError(
            f"{where}: orientation = {orientation!r} is not one of {list(get_args(Orientation))}"
        )
    duration = check_number(
        data["duration"], limits("s", 0.0, MAX_DURATION, lo_open=True), f"{where}: duration"
    )
    rate = check_number(data["output_rate"], RATE_LIMITS, f"{where}: output_rate")
    if duration * rate < 1.0:
        raise ConfigError(
            f"{where}: output_rate = {rate} Hz gives no sample after t = 0 in duration = "
            f"{duration} s"
        )
    commands = data["commands"]
    if not isinstance(commands, dict):
        raise ConfigError(f"{where}: commands must be a mapping of {list(QUANTITIES)}")
    bad = sorted(set(map(str, commands)) - set(QUANTITIES))
    if bad:
        raise ConfigError(f"{where}: commands: unknown key(s) {bad}; allowed: {list(QUANTITIES)}")
    profiles: dict[str, Profile] = {}
    for quantity in QUANTITIES:
        if quantity not in commands:
            if quantity == "axial_load":
                continue
            raise ConfigError(f"{where}: commands.{quantity}: missing")
        profiles[quantity] = _profile(commands[quantity], quantity, where, duration)
    outputs_raw = data.get("outputs", ["drag"])
    if isinstance(outputs_raw, str):
        outputs_raw = [outputs_raw]
    if not isinstance(outputs_raw, list) or not outputs_raw:
        raise ConfigError(f"{where}: outputs must be a non-empty list of {list(OUTPUTS)}")
    for item in outputs_raw:
        if item not in OUTPUTS:
            raise ConfigError(f"{where}: outputs: {item!r} is not one of {list(OUTPUTS)}")
    outputs = tuple(o for o in OUTPUTS if o in outputs_raw)
    tolerance = _tolerance(data["tolerance"], where, outputs)
    faults = faults_from_mapping(data.get("faults"), 500, f"{where}: faults")
    return Scene(
        name=name,
        source=source,
        config=config,
        orientation=orientation,
        duration=duration,
        output_rate=rate,
        faults=faults,
        faults_mapping=data.get("faults"),
        outputs=outputs,
        tolerance=tolerance,
        **profiles,
    )


def _tolerance(raw: Any, where: str, outputs: tuple[str, ...]) -> dict[str, float]:
    """Accepted relative errors; contact_force is required when per-sphere states are wanted."""
    if not isinstance(raw, dict):
        raise ConfigError(f"{where}: tolerance must be a mapping of {sorted(TOLERANCES)}")
    bad = sorted(set(map(str, raw)) - set(TOLERANCES))
    if bad:
        raise ConfigError(
            f"{where}: tolerance: unknown key(s) {bad}; allowed: {sorted(TOLERANCES)}"
        )
    if "drag_torque" not in raw:
        raise ConfigError(f"{where}: tolerance.drag_torque: missing (relative error, e.g. 0.01)")
    if "per_sphere" in outputs and "contact_force" not in raw:
        raise ConfigError(
            f"{where}: tolerance.contact_force: missing (per_sphere outputs are wanted)"
        )
    out: dict[str, float] = {}
    for key, value in raw.items():
        path = f"{where}: tolerance.{key}"
        number = check_number(value, TOLERANCE_LIMITS, path)
        if number > 1.0 and isinstance(value, int | float) and value == int(value):
            raise ConfigError(f"{path} = {value!r}: relative error, not per cent (1 % is 0.01)")
        out[str(key)] = number
    return out


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene YAML file.

    Raises:
        ConfigError: unreadable file, invalid YAML or any invalid field (message names both).
    """
    file = Path(path)
    return scene_from_mapping(read_yaml(file, "scene file"), str(file))
