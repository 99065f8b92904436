"""``ballscrew-twin calibrate``: fit the parameters the paper omits to drag-torque targets.

Targets are operating points with a drag torque: by default the paper's statement (section 3)
that at 100 rpm its drag torque matches Eq. 52 with mu_lit = 0.002 at 20 C and 60 C; or a user's
CSV with columns ``speed_rpm, temperature_C, preload_N, torque_Nm``. The fit minimises the
relative torque errors of the steady-state model over the chosen parameters (log-scaled, within
their allowed ranges) with scipy's trust-region least squares, and writes the fitted parameter
set as YAML.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import numpy as np
import yaml
from scipy.optimize import least_squares

from .cli import CELSIUS_ZERO, RPM
from .errors import BallscrewTwinError, ConfigError
from .models.base import OperatingPoint
from .models.catalog import CatalogModel
from .models.steady import SteadyState, SteadyStateModel
from .params import ContactLaw, Lubricant, TwinConfig, config_from_mapping, load_config

#: parameter name -> (section, dataclass) that holds it
FITTABLE: dict[str, tuple[str, type]] = {
    **{f.name: ("lubricant", Lubricant) for f in dataclasses.fields(Lubricant)},
    **{f.name: ("contact", ContactLaw) for f in dataclasses.fields(ContactLaw)},
}
DEFAULT_PARAMETERS = ("eyring_stress", "dry_friction_coefficient")
PAPER_PRELOADS = (500.0, 1000.0, 1500.0, 2000.0, 2500.0, 3000.0)  # N
PAPER_TEMPERATURES = (20.0, 60.0)  # C
FAILED_SOLVE_RESIDUAL = 10.0  # relative error charged to a point that does not converge


@dataclass(frozen=True)
class Target:
    """A measured (or stated) drag torque at an operating point."""

    point: OperatingPoint
    torque: float  # N m


@dataclass(frozen=True)
class CalibrationResult:
    """Fitted parameters and how well they fit."""

    config: TwinConfig
    values: dict[str, float]
    initial: dict[str, float]
    relative_errors: list[float]
    rms_relative_error: float
    max_relative_error: float
    evaluations: int
    wall_time: float  # s


def paper_targets(config: TwinConfig, mu_lit: float = 0.002) -> list[Target]:
    """Eq. 52 with mu_lit at 100 rpm, 20 C and 60 C, preloads 500..3000 N (paper section 3)."""
    zhou = CatalogModel(config, mu_lit=mu_lit, formula="zhou")
    return [
        Target(
            OperatingPoint(screw_speed=100.0 * RPM, temperature=t + CELSIUS_ZERO, preload=preload),
            zhou.torque_at_preload(preload),
        )
        for t in PAPER_TEMPERATURES
        for preload in PAPER_PRELOADS
    ]


def read_targets(path: str | Path) -> list[Target]:
    """Targets from a CSV with columns speed_rpm, temperature_C, preload_N, torque_Nm."""
    columns = ("speed_rpm", "temperature_C", "preload_N", "torque_Nm")
    try:
        with open(path, newline="", encoding="utf-8") as handle:
            reader = csv.DictReader(handle)
            missing = [c for c in columns if c not in (reader.fieldnames or [])]
            if missing:
                raise ConfigError(f"{path}: missing column(s) {missing}; need {list(columns)}")
            targets = []
            for line, row in enumerate(reader, start=2):
                try:
                    values = [float(row[c]) for c in columns]
                except (TypeError, ValueError):
                    raise ConfigError(f"{path}:{line}: non-numeric value in {row}") from None
                if not all(math.isfinite(v) for v in values):
                    raise ConfigError(f"{path}:{line}: non-finite value in {row}")
                point = OperatingPoint(
                    screw_speed=values[0] * RPM,
                    temperature=values[1] + CELSIUS_ZERO,
                    preload=values[2],
                )
                point.validate()
                if values[3] == 0.0 or values[0] == 0.0:
                    raise ConfigError(f"{path}:{line}: torque and speed must be non-zero")
                targets.append(Target(point, values[3]))
    except OSError as err:
        raise ConfigError(f"{path}: cannot read targets ({err.strerror})") from err
    if not targets:
        raise ConfigError(f"{path}: no data rows")
    return targets


def with_parameters(config: TwinConfig, values: dict[str, float]) -> TwinConfig:
    """A copy of ``config`` with the named lubricant/contact parameters replaced."""
    lub = {k: v for k, v in values.items() if FITTABLE[k][0] == "lubricant"}
    law = {k: v for k, v in values.items() if FITTABLE[k][0] == "contact"}
    return dataclasses.replace(
        config,
        lubricant=dataclasses.replace(config.lubricant, **cast(dict[str, Any], lub)),
        contact=dataclasses.replace(config.contact, **cast(dict[str, Any], law)),
    )


def _bounds(name: str) -> tuple[float, float]:
    """Allowed range of a parameter, floored at 1e-12 so that it can be fitted in log space."""
    _, cls = FITTABLE[name]
    meta = next(f for f in dataclasses.fields(cls) if f.name == name).metadata
    if "min" not in meta:
        raise ConfigError(f"cannot fit {name!r}: it is not a number")
    return max(meta["min"], 1e-12), meta["max"]


def calibrate(
    config: TwinConfig,
    targets: Sequence[Target],
    parameters: Sequence[str] = DEFAULT_PARAMETERS,
    progress: bool = True,
) -> CalibrationResult:
    """Fit ``parameters`` so that the steady model's drag torque meets ``targets``."""
    for name in parameters:
        if name not in FITTABLE:
            raise ConfigError(f"cannot fit {name!r}: choose from {sorted(FITTABLE)}")
        _bounds(name)  # raises for a field that is not a number
    section_of = {n: getattr(getattr(config, FITTABLE[n][0]), n) for n in parameters}
    initial = {n: float(v) for n, v in section_of.items()}
    lower = np.log([_bounds(n)[0] for n in parameters])
    upper = np.log([_bounds(n)[1] for n in parameters])
    start = np.clip(np.log([initial[n] for n in parameters]), lower + 1e-9, upper - 1e-9)
    warm: dict[int, SteadyState] = {}
    count = [0]
    began = time.perf_counter()

    def residuals(log_values: np.ndarray) -> np.ndarray:
        count[0] += 1
        values = dict(zip(parameters, np.exp(log_values).tolist(), strict=True))
        model = SteadyStateModel(with_parameters(config, values), mode="auto")
        errors = np.empty(len(targets))
        for i, target in enumerate(targets):
            try:
                solution = model.solve(target.point, warm_start=warm.get(i))
            except BallscrewTwinError:
                errors[i] = FAILED_SOLVE_RESIDUAL
                continue
            warm[i] = solution.state
            errors[i] = solution.output.drag_torque / target.torque - 1.0
        if progress:
            shown = ", ".join(f"{k}={v:.4g}" for k, v in values.items())
            rms = float(np.sqrt(np.mean(errors**2)))
            print(f"  eval {count[0]:3d}: {shown}: rms relative error {rms:.4f}", flush=True)
        return errors

    fit = least_squares(
        residuals, start, bounds=(lower, upper), x_scale=1.0, diff_step=1e-4, max_nfev=60
    )
    values = dict(zip(parameters, np.exp(fit.x).tolist(), strict=True))
    errors = residuals(fit.x).tolist()
    return CalibrationResult(
        config=with_parameters(config, values),
        values=values,
        initial=initial,
        relative_errors=errors,
        rms_relative_error=float(np.sqrt(np.mean(np.square(errors)))),
        max_relative_error=float(np.max(np.abs(errors))),
        evaluations=count[0],
        wall_time=time.perf_counter() - began,
    )


def config_to_mapping(config: TwinConfig) -> dict[str, Any]:
    """Inverse of :func:`ballscrew_twin.params.config_from_mapping` (without ``source``)."""
    data = dataclasses.asdict(config)
    data.pop("source", None)
    return data


def write_config(result: CalibrationResult, targets_name: str, path: str | Path) -> None:
    """Write the fitted parameter set as YAML with a header saying how it was made."""
    header = [
        f"# Calibrated by `ballscrew-twin calibrate` against {targets_name}.",
        "# Fitted: "
        + ", ".join(
            f"{k} = {v:.6g} (from {result.initial[k]:.6g})" for k, v in result.values.items()
        ),
        f"# Relative torque misfit: rms {result.rms_relative_error:.4f}, "
        f"max {result.max_relative_error:.4f} over {len(result.relative_errors)} targets.",
        "# All values SI (m, kg, Pa, K, rad); see config/paper_screw.yaml for their sources.",
    ]
    body = yaml.safe_dump(config_to_mapping(result.config), sort_keys=False)
    config_from_mapping(yaml.safe_load(body), str(path))  # what we write must load back
    Path(path).write_text("\n".join(header) + "\n" + body, encoding="utf-8")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``calibrate``."""
    parser.add_argument("--config", default=None, help="starting parameter YAML (default: paper)")
    parser.add_argument(
        "--data",
        default=None,
        help="CSV of speed_rpm,temperature_C,preload_N,torque_Nm (default: the paper's Eq. 52 "
        "statement at 100 rpm, 20 and 60 C)",
    )
    parser.add_argument(
        "--parameters",
        nargs="+",
        default=list(DEFAULT_PARAMETERS),
        help="lubricant/contact parameters to fit (default: %(default)s)",
    )
    parser.add_argument("--out", default=None, help="write the fitted parameter set here (YAML)")
    parser.add_argument("--json", action="store_true", help="print the result as JSON")


def run(args: argparse.Namespace) -> int:
    """Fit, print the misfit, optionally write the YAML."""
    config = load_config(args.config)
    if args.data is None:
        targets = paper_targets(config)
        name = "Eq. 52 (mu_lit = 0.002) at 100 rpm, 20 and 60 C (paper section 3)"
    else:
        targets = read_targets(args.data)
        name = str(args.data)
    print(f"calibrating {', '.join(args.parameters)} against {len(targets)} targets: {name}")
    result = calibrate(config, targets, args.parameters, progress=not args.json)
    summary = {
        "parameters": result.values,
        "initial": result.initial,
        "rms_relative_error": result.rms_relative_error,
        "max_relative_error": result.max_relative_error,
        "evaluations": result.evaluations,
        "wall_time_s": result.wall_time,
        "targets": [
            {
                "speed_rad_s": t.point.screw_speed,
                "temperature_K": t.point.temperature,
                "preload_N": t.point.preload,
                "target_Nm": t.torque,
                "relative_error": e,
            }
            for t, e in zip(targets, result.relative_errors, strict=True)
        ],
    }
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        for t, e in zip(targets, result.relative_errors, strict=True):
            print(
                f"  {t.point.screw_speed / RPM:7.1f} rpm "
                f"{t.point.temperature - CELSIUS_ZERO:6.1f} C "
                f"{t.point.preload:7.1f} N: target {t.torque * 1e3:8.3f} N mm, error {e:+.4f}"
            )
        fitted = ", ".join(f"{k} = {v:.6g}" for k, v in result.values.items())
        print(
            f"fitted {fitted}; rms relative error {result.rms_relative_error:.4f}, max "
            f"{result.max_relative_error:.4f} ({result.evaluations} evaluations, "
            f"{result.wall_time:.1f} s)"
        )
    if args.out:
        write_config(result, name, args.out)
        print(f"wrote {args.out}")
    return 0
