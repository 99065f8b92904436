"""Scenarios of the dynamic model: commanded preload and speed over time, loaded from YAML.

A :class:`Scenario` is a frozen, validated dataclass in SI units (temperature in K, speed in
rad/s, force in N, time in s). Every numeric field carries its unit and allowed range in the
field metadata, as the parameter sets of :mod:`ballscrew_twin.params` do; the loader rejects
unknown keys, non-finite numbers and out-of-range values with a message naming the file and the
field, and the cross-field checks (ramp end before its start, an averaging window longer than
the run, ...) name the fields involved.

The default timings are the paper's protocol (section 3): preload smooth-stepped over the first
5 ms, speed smooth-stepped from 0.05 s to 0.1 s, held for 0.5 s (0.6 s in all), quantities
averaged over the last 0.2 s.
"""

from __future__ import annotations

from dataclasses import MISSING, dataclass, field, fields
from functools import cached_property
from pathlib import Path
from typing import Any, Literal, get_args

from ..errors import ConfigError
from ..params import check_number, path_beside, quantity, read_yaml, validate_fields
from .dynamic_state import Commands, SpeedController
from .faults import faults_from_mapping
from .profile import Profile, SmoothStep

Backend = Literal["compiled", "reference"]

#: Relative tolerance when checking that an interval is a whole number of time steps [-].
STEP_MULTIPLE_TOLERANCE = 1e-6

_DEFAULT_CONTROLLER = SpeedController()


@dataclass(frozen=True, kw_only=True)
class Scenario:
    """One run of the dynamic model: operating point, command ramps, step and outputs (SI).

    The preload is smooth-stepped from 0 at t = 0 to ``preload`` at ``preload_ramp_end``; the
    speed command from 0 at ``speed_ramp_start`` to ``speed`` at ``speed_ramp_end``. The
    summary averages over the last ``average_window`` seconds of ``duration``, which must begin
    after both ramps have ended.

    ``source`` is the file the scenario was read from (used in messages and to resolve
    ``config``); it is not a YAML key.
    """

    name: str = field(metadata={"doc": "name of the scenario"})
    config: str | None = field(
        default=None,
        metadata={"doc": "parameter YAML, relative to the scenario file (default: shipped one)"},
    )
    balls_per_nut: int | None = quantity(
        "-",
        1,
        500,
        "override of the configuration's loaded spheres per nut",
        default=None,
        integer=True,
    )
    temperature: float = quantity("K", 139.0, 500.0, "bulk temperature, constant during the run")
    preload: float = quantity("N", 0.0, 1e5, "final preload force pushing the nuts apart")
    preload_ramp_end: float = quantity(
        "s", 0.0, 100.0, "end of the preload smooth step", default=5e-3
    )
    speed: float = quantity("rad/s", -1e4, 1e4, "final screw speed command (sign = direction)")
    speed_ramp_start: float = quantity(
        "s", 0.0, 100.0, "start of the speed smooth step", default=0.05
    )
    speed_ramp_end: float = quantity("s", 0.0, 100.0, "end of the speed smooth step", default=0.1)
    duration: float = quantity("s", 0.0, 100.0, "simulated time", default=0.6, lo_open=True)
    average_window: float = quantity(
        "s", 0.0, 100.0, "summary averaged over the last window", default=0.2, lo_open=True
    )
    time_step: float = quantity("s", 0.0, 1e-4, "integration step", default=1e-6, lo_open=True)
    jacobian_interval: int = quantity(
        "-", 1, 100_000, "steps between Jacobian refreshes", default=10, integer=True
    )
    fine_time_step: float | None = quantity(
        "s",
        0.0,
        1e-4,
        "semi-implicit step of the start phase and of the redone steps that did not converge "
        "with implicit positions (each time_step split into steps of this)",
        default=None,
        lo_open=True,
    )
    fine_until: float = quantity(
        "s", 0.0, 100.0, "end of the start phase run at fine_time_step (0: none)", default=0.0
    )
    output_interval: float = quantity(
        "s", 0.0, 100.0, "time-series sampling period", default=1e-4, lo_open=True
    )
    contact_output_interval: float = quantity(
        "s", 0.0, 100.0, "contact-state sampling period", default=1e-3, lo_open=True
    )
    controller_proportional: float = quantity(
        "N m s/rad", 0.0, 1e3, "PI speed controller k_p", default=_DEFAULT_CONTROLLER.proportional
    )
    controller_integral: float = quantity(
        "N m/rad", 0.0, 1e6, "PI speed controller k_i", default=_DEFAULT_CONTROLLER.integral
    )
    backend: Backend = field(
        default="compiled", metadata={"doc": "contact laws: compiled (numba) or reference"}
    )
    sphere_contacts: bool = field(
        default=False,
        metadata={"doc": "contacts between neighbouring spheres (Python step, slower)"},
    )
    implicit_positions: bool = field(
        default=False,
        metadata={
            "doc": "contact actions at the end-of-step positions (backward Euler in positions "
            "too, stable above the contact springs' ~3 us limit) instead of the start's"
        },
    )
    faults: Any = field(
        default=None,
        metadata={
            "doc": "defects: {spheres: [{nut, index, radius_change}], spalls: "
            "[{half_groove, centre, width, depth}], jams: [{nut, index, start}]} "
            "(models/faults.py), SI units"
        },
    )
    source: str = field(default="", metadata={"doc": "file read from (not a YAML key)"})

    def __post_init__(self) -> None:
        self.validate()

    # ------------------------------------------------------------------ validation

    @property
    def _where(self) -> str:
        return self.source or "<scenario>"

    def validate(self) -> None:
        """Check every field against its metadata and the cross-field rules.

        Raises:
            ConfigError: naming the file (``source``) and the field.
        """
        where = self._where
        # Sphere indices are checked against the parameter file's count when the model is
        # built; here against the largest count allowed.
        faults_from_mapping(self.faults, self.balls_per_nut or 500, f"{where}: faults")
        if not isinstance(self.name, str) or not self.name.strip():
            raise ConfigError(f"{where}: name must be a non-empty string, got {self.name!r}")
        if self.config is not None and (not isinstance(self.config, str) or not self.config):
            raise ConfigError(f"{where}: config must be a path string, got {self.config!r}")
        for flag in ("sphere_contacts", "implicit_positions"):
            if not isinstance(getattr(self, flag), bool):
                raise ConfigError(
                    f"{where}: {flag} must be true or false, got {getattr(self, flag)!r}"
                )
        if self.backend not in get_args(Backend):
            raise ConfigError(
                f"{where}: backend = {self.backend!r} is not one of {list(get_args(Backend))}"
            )
        validate_fields(self, where, ": ")
        self._validate_timing(where)

    def _validate_timing(self, where: str) -> None:
        if self.speed_ramp_end < self.speed_ramp_start:
            raise ConfigError(
                f"{where}: speed_ramp_end = {self.speed_ramp_end} s is before "
                f"speed_ramp_start = {self.speed_ramp_start} s"
            )
        if self.duration < self.average_window:
            raise ConfigError(
                f"{where}: duration = {self.duration} s is shorter than "
                f"average_window = {self.average_window} s"
            )
        window_start = self.duration - self.average_window
        for ramp in ("preload_ramp_end", "speed_ramp_end"):
            end = getattr(self, ramp)
            if end > window_start * (1.0 + 1e-12):
                raise ConfigError(
                    f"{where}: {ramp} = {end} s is inside the averaging window, which starts at "
                    f"duration - average_window = {window_start:.6g} s; lengthen duration or "
                    "shorten average_window"
                )
        for name in ("duration", "output_interval", "contact_output_interval", "average_window"):
            value = getattr(self, name)
            ratio = value / self.time_step
            if abs(ratio - round(ratio)) > STEP_MULTIPLE_TOLERANCE * max(ratio, 1.0):
                raise ConfigError(
                    f"{where}: {name} = {value} s is not a whole number of "
                    f"time_step = {self.time_step} s"
                )
        self._validate_fine_phase(where, window_start)
        for name in ("output_interval", "contact_output_interval"):
            if getattr(self, name) > self.duration:
                raise ConfigError(
                    f"{where}: {name} = {getattr(self, name)} s exceeds duration = "
                    f"{self.duration} s"
                )

    def _validate_fine_phase(self, where: str, window_start: float) -> None:
        """fine_time_step divides time_step; fine_until: only with fine_time_step, a whole
        number of time_step, before the averaging window."""
        checks = []
        if self.fine_time_step is not None:
            checks.append(("time_step", self.time_step, self.fine_time_step))
        if self.fine_until > 0.0:
            if self.fine_time_step is None:
                raise ConfigError(f"{where}: fine_until = {self.fine_until} s needs fine_time_step")
            checks.append(("fine_until", self.fine_until, self.time_step))
        for name, value, unit in checks:
            ratio = value / unit
            if abs(ratio - round(ratio)) > STEP_MULTIPLE_TOLERANCE * max(ratio, 1.0):
                raise ConfigError(f"{where}: {name} = {value} s is not a whole number of {unit} s")
        if self.fine_until > 0.0 and self.fine_until > window_start * (1.0 + 1e-12):
            raise ConfigError(
                f"{where}: fine_until = {self.fine_until} s is inside the averaging window, "
                f"which starts at {window_start:.6g} s"
            )

    # ------------------------------------------------------------------ derived

    @property
    def substeps(self) -> int:
        """Steps of fine_time_step in one time_step during the start phase [-] (1: none)."""
        if self.fine_until <= 0.0 or self.fine_time_step is None:
            return 1
        return max(1, round(self.time_step / self.fine_time_step))

    @property
    def fallback_substeps(self) -> int:
        """With implicit sphere positions and fine_time_step: a step of time_step whose Newton
        iterations do not converge is redone as this many semi-implicit steps of
        fine_time_step [-] (1: never)."""
        if not self.implicit_positions or self.fine_time_step is None:
            return 1
        return max(1, round(self.time_step / self.fine_time_step))

    @property
    def fine_steps(self) -> int:
        """Steps of time_step in the start phase [-], each split into ``substeps``."""
        return round(self.fine_until / self.time_step) if self.substeps > 1 else 0

    @property
    def controller(self) -> SpeedController:
        """The PI gains as the dynamic model takes them."""
        return SpeedController(
            proportional=self.controller_proportional, integral=self.controller_integral
        )

    @property
    def steps(self) -> int:
        """Number of integration steps of the run [-]."""
        return round(self.duration / self.time_step)

    def steps_per(self, interval: float) -> int:
        """Whole number of steps in ``interval`` [s] (>= 1)."""
        return max(1, round(interval / self.time_step))

    def config_path(self) -> Path | None:
        """Parameter file to load: ``config`` resolved against the scenario file's folder
        (None: the shipped default)."""
        if self.config is None:
            return None
        return path_beside(self.config, self.source)

    @cached_property
    def speed_profile(self) -> Profile:
        """The speed command [rad/s]: 0, then a smooth step to ``speed`` from
        ``speed_ramp_start`` to ``speed_ramp_end``."""
        return Profile(steps=(SmoothStep(self.speed_ramp_start, self.speed_ramp_end, self.speed),))

    @cached_property
    def preload_profile(self) -> Profile:
        """The preload command [N]: a smooth step from 0 at t = 0 to ``preload`` at
        ``preload_ramp_end``."""
        return Profile(steps=(SmoothStep(0.0, self.preload_ramp_end, self.preload),))

    def commands_at(self, t: float) -> Commands:
        """Commanded screw speed [rad/s] and preload [N] at time ``t`` [s]."""
        return Commands(screw_speed=self.speed_profile(t), preload=self.preload_profile(t))

    def to_dict(self) -> dict[str, Any]:
        """The scenario as a JSON/YAML-ready mapping (SI units; ``source`` included)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}


def scenario_from_mapping(data: Any, source: str = "<mapping>") -> Scenario:
    """Validate a parsed YAML mapping into a :class:`Scenario`; errors name ``source``."""
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: top level must be a mapping of scenario fields")
    known = {f.name: f for f in fields(Scenario) if f.name != "source"}
    unknown = sorted(set(map(str, data)) - set(known) - {"description"})
    if unknown:
        raise ConfigError(f"{source}: unknown key(s) {unknown}; allowed: {sorted(known)}")
    values: dict[str, Any] = {}
    for name, fld in known.items():
        if name not in data:
            if fld.default is MISSING:
                raise ConfigError(f"{source}: {name}: missing")
            continue
        raw = data[name]
        if raw is None and fld.default is None:
            continue
        if "min" in fld.metadata and isinstance(raw, str):  # PyYAML reads 1e-6 as a string
            raw = check_number(raw, fld.metadata, f"{source}: {name}")
        values[name] = raw
    if isinstance(values.get("config"), Path):
        values["config"] = str(values["config"])
    return Scenario(**values, source=source)


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario YAML file.

    Raises:
        ConfigError: unreadable file, invalid YAML or any invalid field (message names both).
    """
    file = Path(path)
    return scenario_from_mapping(read_yaml(file, "scenario file"), str(file))
