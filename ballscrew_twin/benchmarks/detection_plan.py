"""The plan of ``ballscrew-twin bench detection`` (what each unit goes through, which units) and
its command-line arguments (:mod:`.detection` runs it)."""

from __future__ import annotations

import argparse
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np

from ..errors import ConfigError
from ..health.bench_units import BenchUnit, draw_unit
from ..health.commission import KEYWORD_LIMITS
from ..health.duty_cycles import COMMISSIONING_WARMUP, Trajectory, draw_trajectory
from ..health.monitor_settings import MonitorSettings
from ..params import check_number

#: Default unit ranges: the held-out test units and the training units tuning may use.
TEST_UNITS = (2000, 2030)
TRAINING_UNITS = (0, 30)
#: Keywords of :func:`~ballscrew_twin.health.commission.commission` that a compared monitor
#: may change (``--compare-setting commission.unseen_error=0.015``), each within its limits
#: (:data:`~ballscrew_twin.health.commission.KEYWORD_LIMITS`) [-].
COMMISSION_KEYWORDS = tuple(KEYWORD_LIMITS)
#: Commissioning keywords as (name, value) pairs, sorted by name.
Keywords = tuple[tuple[str, float], ...]


@dataclass(frozen=True)
class Plan:
    """What one unit goes through (lengths [s]): a commissioning recording (a cold start), a
    healthy recording, ``faults`` fault recordings of ``fault_length``, and with ``service`` >
    0 a second healthy recording, a run of the unit's duty cycles at an ambient temperature,
    commissioned together with the first (``commission`` on both recordings)."""

    commission: float
    healthy: float
    faults: int
    fault_length: float
    service: float = 0.0


@dataclass(frozen=True)
class Contender:
    """One monitor of a side-by-side run: its settings, and the keywords (name, value) its
    unit's commissioning is run with (none: the defaults). Monitors whose keywords are equal
    share one commissioning of the unit."""

    settings: MonitorSettings = field(default_factory=MonitorSettings)
    commissioning: Keywords = ()


@dataclass(frozen=True)
class UnitDraw:
    """What a unit's number draws (:func:`unit_draw`): the unit, its set preload [N], the
    seeds of its recordings (the commissioning's trajectory and noise, the healthy
    recording's one seed for both, then a trajectory and a noise seed per fault run; the
    first three do not depend on the number of fault runs) and the generator the fault runs'
    own draws go on from."""

    unit: BenchUnit
    preload: float
    seeds: tuple[int, ...]
    rng: np.random.Generator


def unit_draw(number: int, faults: int) -> UnitDraw:
    """The draws of unit ``number`` with ``faults`` fault runs: the same from every caller, so
    that what ``bench detection`` ran can be run again piece by piece."""
    rng = np.random.default_rng([number, 0xBE7C])
    preload = float(rng.uniform(600.0, 2500.0))
    seeds = tuple(int(s) for s in rng.integers(0, 2**31, size=3 + 2 * faults))
    return UnitDraw(draw_unit(number), preload, seeds, rng)


def with_preload(trajectory: Trajectory, preload: float) -> Trajectory:
    """``trajectory`` at the constant ``preload`` [N]."""
    return replace(trajectory, preload=np.full_like(trajectory.time, preload))


def commissioning_trajectory(draw: UnitDraw, plan: Plan) -> Trajectory:
    """The unit's commissioning run: a cold start warming up over ``plan.commission`` [s]."""
    trajectory = draw_trajectory(
        draw.seeds[0], plan.commission, cold_start=True, warmup=COMMISSIONING_WARMUP
    )
    return with_preload(trajectory, draw.preload)


def healthy_trajectory(draw: UnitDraw, plan: Plan) -> Trajectory:
    """The unit's healthy run of ``plan.healthy`` [s] (its noise seed is the same number)."""
    return with_preload(draw_trajectory(draw.seeds[2], plan.healthy), draw.preload)


def unit_range(text: str) -> range:
    """The units of ``--units FIRST:STOP``; ConfigError naming the expected form."""
    try:
        low, high = (int(v) for v in text.split(":"))
    except ValueError:
        raise ConfigError(f"--units {text!r}: expected FIRST:STOP, e.g. 1000:1030") from None
    if not 0 <= low < high:
        raise ConfigError(f"--units {text!r}: need 0 <= FIRST < STOP")
    return range(low, high)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``bench detection``."""
    parser.add_argument("--out", default=None, help="directory for detection.md, PNGs, JSON")
    parser.add_argument("--quick", action="store_true", help="smoke test: 2 units, short runs")
    parser.add_argument(
        "--units",
        default=f"{TEST_UNITS[0]}:{TEST_UNITS[1]}",
        help=f"unit numbers FIRST:STOP (test {TEST_UNITS[0]}:{TEST_UNITS[1]}, training "
        f"{TRAINING_UNITS[0]}:{TRAINING_UNITS[1]})",
    )
    parser.add_argument(
        "--commission", type=float, default=600.0, help="commissioning warm-up run [s]"
    )
    parser.add_argument(
        "--service",
        type=float,
        default=0.0,
        help="a second healthy recording commissioned with the first: a run of the unit's duty "
        "cycles at an ambient temperature [s] (0: none)",
    )
    parser.add_argument("--healthy", type=float, default=1200.0, help="healthy run per unit [s]")
    parser.add_argument("--faults", type=int, default=4, help="fault runs per unit [-]")
    parser.add_argument("--fault-length", type=float, default=60.0, help="fault run [s]")
    parser.add_argument("--workers", type=int, default=2, help="processes [-]")
    parser.add_argument("--config", default=None, help="screw parameter YAML (default: paper)")
    parser.add_argument(
        "--compare-detectors",
        default=None,
        metavar="A,B",
        help="also run a monitor with only these detectors on the same recordings and report "
        "it beside the default (e.g. cusum,spectral: the monitor before the local test)",
    )
    parser.add_argument(
        "--compare-setting",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="also run a monitor with this one numeric setting changed, on the same recordings, "
        "reported beside the default (repeatable: one monitor each; e.g. "
        "classification_patience=8; unit_friction_responses=1 (0 or 1) for a switch; "
        "residual.partial_share=1 or tracker.temperature_drift=0.02 "
        "for a field of the residual or tracker settings; commission.unseen_error=0.015, "
        "commission.unseen_quantile=0.95, commission.error_scale=2 or "
        "commission.temperature_error=0.005 for a keyword of the "
        "unit's commissioning, which is then run again for that monitor; several changes to "
        "one monitor separated by commas)",
    )


def requested_plan(args: argparse.Namespace) -> tuple[range, Plan]:
    """The units and the plan the arguments ask for (``--quick``: units 0 and 1, commissioning
    120 s, healthy 60 s, one fault run of 30 s); ConfigError for a plan that cannot run."""
    if args.quick:
        return range(2), Plan(commission=120.0, healthy=60.0, faults=1, fault_length=30.0)
    plan = Plan(args.commission, args.healthy, args.faults, args.fault_length, args.service)
    if plan.faults < 0 or min(plan.commission, plan.healthy, plan.fault_length) <= 10.0:
        raise ConfigError("--faults must be >= 0 and every length > 10 s")
    if not (plan.service == 0.0 or plan.service > 10.0):
        raise ConfigError(f"--service {plan.service:g}: 0 (none) or a length > 10 s")
    return unit_range(args.units), plan


def comparison_settings(args: argparse.Namespace) -> tuple[tuple[str, Contender], ...]:
    """The extra monitors ``--compare-detectors`` and ``--compare-setting`` ask for, each
    with the title of its report; ConfigError naming the numeric settings for a name that is
    not one, or for a value that is not a number."""
    extra: list[tuple[str, Contender]] = []
    if args.compare_detectors:
        names = tuple(n.strip() for n in args.compare_detectors.split(",") if n.strip())
        extra.append(
            (f"detectors {', '.join(names)} only", Contender(MonitorSettings(detectors=names)))
        )
    defaults = MonitorSettings()
    numeric = sorted(
        [f.name for f in fields(defaults) if type(getattr(defaults, f.name)) is float]
        + [
            f"{group}.{f.name}"
            for group in ("residual", "tracker")
            for f in fields(getattr(defaults, group))
            if type(getattr(getattr(defaults, group), f.name)) is float
        ]
        + [f"commission.{name}" for name in COMMISSION_KEYWORDS]
        + switches(defaults)
    )
    for item in args.compare_setting:
        contender = Contender()
        for change in item.split(","):
            contender = _changed(contender, change, item, numeric)
        title = ", ".join(c.strip().replace("=", " = ") for c in item.split(","))
        extra.append((title, contender))
    return tuple(extra)


def switches(settings: MonitorSettings) -> list[str]:
    """The on/off settings of the monitor (``--compare-setting NAME=0`` or ``NAME=1``)."""
    return [f.name for f in fields(settings) if type(getattr(settings, f.name)) is bool]


def _changed(contender: Contender, change: str, item: str, numeric: list[str]) -> Contender:
    """``contender`` with the one NAME=VALUE ``change`` of the ``--compare-setting`` ``item``;
    ConfigError naming ``numeric`` for a name that is not one, or for a value that is not a
    number (or, for a commissioning keyword, one outside its limits)."""
    name, _, text = change.partition("=")
    name = name.strip()
    if name not in numeric:
        raise ConfigError(f"--compare-setting {item!r}: NAME must be one of {numeric}")
    try:
        value = float(text)
    except ValueError:
        raise ConfigError(f"--compare-setting {item!r}: VALUE must be a number") from None
    group, _, field_name = name.rpartition(".")
    if name in switches(contender.settings):
        if value not in (0.0, 1.0):
            raise ConfigError(f"--compare-setting {item!r}: {name} is a switch: 0 or 1")
        switched: dict[str, Any] = {name: value == 1.0}
        return replace(contender, settings=replace(contender.settings, **switched))
    if group == "commission":
        limits = KEYWORD_LIMITS[field_name]
        check_number(value, limits, f"--compare-setting {item!r}: {name}", text=False)
        keywords = dict(contender.commissioning) | {field_name: value}
        return replace(contender, commissioning=tuple(sorted(keywords.items())))
    settings = contender.settings
    changed: dict[str, Any] = {field_name: value}
    if group:  # a field of the residual or tracker settings
        settings = replace(settings, **{group: replace(getattr(settings, group), **changed)})
    else:
        settings = replace(settings, **changed)
    return replace(contender, settings=settings)
