"""``ballscrew-twin calibrate``: fit the parameters the paper omits to drag-torque targets.

Targets are operating points with a drag torque:

- by default the paper's statement (section 3) that at 100 rpm its drag torque matches Eq. 52
  with mu_lit = 0.002 at 20 C and 60 C;
- a user's CSV with columns ``speed_rpm, temperature_C, preload_N, torque_Nm``;
- a bench bag (the bench-bag schema of docs/bench_data.md, topics as ``detect`` takes them, read by
  :func:`ballscrew_twin.bags.bench.read_bench_bag`): its steady segments, found by
  :func:`steady_segments`, each one target (mean torque, speed, temperature and load-cell
  preload over the segment).

The fit minimises the relative torque errors of the steady-state model over the chosen
parameters (log-scaled, within their allowed ranges) with scipy's trust-region least squares.
Each fitted value comes with a standard uncertainty from the Jacobian J of the fit at the
solution: cov(log p) = s^2 (J^T J)^-1 with s^2 = sum(r^2) / (m - n) the scatter of the m
relative errors about n parameters (assumed independent and of equal variance), and
sigma_p = p sigma_log p to first order; none with m <= n or a singular J^T J. The fitted set is
written as YAML (``--out``), the targets used as CSV (``--save-targets``) and a plot of
measured against predicted torque, the relative errors and the fitted values with their
uncertainty as PNG (``--plot``).
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import itertools
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import numpy as np
import yaml
from numpy.typing import NDArray
from scipy.optimize import least_squares

from .bags.bench import read_bench_bag
from .bags.recording import BenchRecording, BenchTopics
from .errors import BallscrewTwinError, ConfigError
from .models.base import OperatingPoint
from .models.catalog import CatalogModel
from .models.steady import SteadyState, SteadyStateModel
from .models.validity import ValidityEnvelope, kelvin_from_command_line, refuse_outside
from .params import ContactLaw, Lubricant, TwinConfig, config_from_mapping, load_config
from .units import CELSIUS_ZERO, RPM

#: parameter name -> (section, dataclass) that holds it
FITTABLE: dict[str, tuple[str, type]] = {
    **{f.name: ("lubricant", Lubricant) for f in dataclasses.fields(Lubricant)},
    **{f.name: ("contact", ContactLaw) for f in dataclasses.fields(ContactLaw)},
}
DEFAULT_PARAMETERS = ("eyring_stress", "dry_friction_coefficient")
PAPER_PRELOADS = (500.0, 1000.0, 1500.0, 2000.0, 2500.0, 3000.0)  # N
PAPER_TEMPERATURES = (20.0, 60.0)  # C
FAILED_SOLVE_RESIDUAL = 10.0  # relative error charged to a point that does not converge
#: Condition number of J^T J above which the fitted parameters are not told apart [-].
SINGULAR_CONDITION = 1e12
#: Bench channels a calibration target is made of.
STEADY_CHANNELS = ("torque", "speed", "temperature", "preload")
#: File names read as a bag rather than a CSV (a bag folder is a directory).
BAG_SUFFIXES = (".mcap", ".db3")


@dataclass(frozen=True)
class Target:
    """A measured (or stated) drag torque at an operating point."""

    point: OperatingPoint
    torque: float  # N m


@dataclass(frozen=True)
class SteadyCriteria:
    """When a stretch of a bench recording counts as steady (one calibration target).

    The recording is cut into consecutive windows of ``window``; a window is steady when, for
    speed, temperature and preload, the means of its two halves differ by at most the
    tolerance (a trend, not the sensor noise), and its mean speed is at least ``min_speed``.
    Consecutive steady windows whose means stay within the tolerances of the segment's first
    window form one segment.

    Attributes:
        window: window length [s].
        speed_tolerance: relative speed tolerance [-] (of the mean speed) ...
        speed_floor: ... plus this absolute one [rad/s].
        temperature_tolerance: [K].
        preload_tolerance: relative preload tolerance [-] ...
        preload_floor: ... plus this absolute one [N].
        min_speed: slowest mean speed of a segment [rad/s] (below it presliding and Stribeck
            friction, which the steady model does not describe, dominate).
        min_samples: fewest torque samples in a window [-].
    """

    window: float = 1.0
    speed_tolerance: float = 0.02
    speed_floor: float = 0.05
    temperature_tolerance: float = 0.5
    preload_tolerance: float = 0.02
    preload_floor: float = 10.0
    min_speed: float = 1.0
    min_samples: int = 10


@dataclass(frozen=True)
class Segment:
    """A steady stretch of a recording: its span [s] and the means over it (SI)."""

    start: float  # s
    stop: float  # s
    speed: float  # rad/s
    temperature: float  # K
    preload: float  # N
    torque: float  # N m
    samples: int  # torque samples


@dataclass(frozen=True)
class CalibrationResult:
    """Fitted parameters, their standard uncertainty and how well they fit.

    ``uncertainty`` is in each parameter's unit, NaN when the fit cannot tell it (see the
    module docstring); ``predicted`` is the fitted model's drag torque of each target [N m]
    (NaN where the solve failed).
    """

    config: TwinConfig
    values: dict[str, float]
    uncertainty: dict[str, float]
    initial: dict[str, float]
    predicted: list[float]
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


def steady_segments(recording: BenchRecording, criteria: SteadyCriteria) -> list[Segment]:
    """The steady segments of a bench recording (see :class:`SteadyCriteria`)."""
    torque = recording.series("torque")
    t = torque.time

    def on_torque_times(channel: str) -> NDArray[np.float64]:
        series = recording.series(channel)
        return np.interp(t, series.time, series.value)

    channels = {
        "speed": on_torque_times("speed"),
        "temperature": on_torque_times("temperature"),
        "preload": on_torque_times("preload"),
    }

    def tolerance(name: str, level: float) -> float:
        if name == "speed":
            return criteria.speed_tolerance * abs(level) + criteria.speed_floor
        if name == "preload":
            return criteria.preload_tolerance * abs(level) + criteria.preload_floor
        return criteria.temperature_tolerance

    def close(a: dict[str, float], b: dict[str, float]) -> bool:
        return all(abs(a[n] - b[n]) <= tolerance(n, b[n]) for n in channels)

    segments: list[Segment] = []
    current: list[NDArray[np.intp]] = []
    first: dict[str, float] = {}

    def flush() -> None:
        if current:
            rows = np.concatenate(current)
            segments.append(
                Segment(
                    start=float(t[rows[0]]),
                    stop=float(t[rows[-1]]),
                    speed=float(np.mean(channels["speed"][rows])),
                    temperature=float(np.mean(channels["temperature"][rows])),
                    preload=float(np.mean(channels["preload"][rows])),
                    torque=float(np.mean(torque.value[rows])),
                    samples=len(rows),
                )
            )
            current.clear()

    edges = np.arange(t[0], t[-1] + criteria.window, criteria.window)
    for lo, hi in itertools.pairwise(edges):
        rows = np.flatnonzero((t >= lo) & (t < hi))
        steady = len(rows) >= criteria.min_samples
        means: dict[str, float] = {}
        if steady:
            half = len(rows) // 2
            for name, values in channels.items():
                means[name] = float(np.mean(values[rows]))
                trend = np.mean(values[rows[half:]]) - np.mean(values[rows[:half]])
                steady = steady and bool(abs(trend) <= tolerance(name, means[name]))
            steady = steady and abs(means["speed"]) >= criteria.min_speed
        if not steady:
            flush()
            continue
        if current and not close(means, first):
            flush()
        if not current:
            first = means
        current.append(rows)
    flush()
    return segments


def bag_targets(
    path: str | Path, topics: BenchTopics, criteria: SteadyCriteria
) -> tuple[list[Target], list[Segment]]:
    """Targets of the steady segments of the bag at ``path`` (its bench ``topics``; the screw's
    angle is not needed)."""
    recording = read_bench_bag(path, topics, required=STEADY_CHANNELS)
    segments = steady_segments(recording, criteria)
    if not segments:
        raise ConfigError(
            f"{path}: no steady segment (speed, temperature and preload steady over "
            f"{criteria.window:g} s at >= {criteria.min_speed:g} rad/s)"
        )
    targets = []
    for seg in segments:
        point = OperatingPoint(
            screw_speed=seg.speed, temperature=seg.temperature, preload=seg.preload
        )
        point.validate()
        targets.append(Target(point, seg.torque))
    return targets, segments


def is_bag(path: str | Path) -> bool:
    """``path`` names a bag (a folder, ``.mcap`` or ``.db3``) rather than a CSV table."""
    file = Path(path)
    return file.is_dir() or file.suffix in BAG_SUFFIXES


def load_targets(
    args: argparse.Namespace, topics: BenchTopics, log: Callable[[str], None] = print
) -> tuple[list[Target], str]:
    """The targets of ``args.data`` (CSV or bag, read on its bench ``topics``; None: the
    paper's statement) and their name.

    A bag's steady segments are logged (one line each) as they are found.
    """
    if args.data is None:
        name = "Eq. 52 (mu_lit = 0.002) at 100 rpm, 20 and 60 C (paper section 3)"
        return paper_targets(load_config(args.config)), name
    if not is_bag(args.data):
        return read_targets(args.data), str(args.data)
    criteria = SteadyCriteria(window=args.steady_window)
    targets, segments = bag_targets(args.data, topics, criteria)
    log(f"{args.data}: {len(segments)} steady segment(s) of >= {criteria.window:g} s")
    for seg in segments:
        log(
            f"  {seg.start:7.2f}-{seg.stop:7.2f} s: {seg.speed / RPM:8.1f} rpm "
            f"{seg.temperature - CELSIUS_ZERO:6.2f} C {seg.preload:7.1f} N: "
            f"torque {seg.torque * 1e3:8.3f} mN m ({seg.samples} samples)"
        )
    return targets, f"steady segments of {args.data}"


def write_targets(targets: Sequence[Target], path: str | Path) -> Path:
    """Write ``targets`` as a CSV that :func:`read_targets` reads (rpm, deg C, N, N m)."""
    file = Path(path)
    file.parent.mkdir(parents=True, exist_ok=True)
    with file.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle)
        writer.writerow(("speed_rpm", "temperature_C", "preload_N", "torque_Nm"))
        for target in targets:
            p = target.point
            writer.writerow(
                (
                    f"{p.screw_speed / RPM:.6g}",
                    f"{p.temperature - CELSIUS_ZERO:.6g}",
                    f"{p.preload:.6g}",
                    f"{target.torque:.6g}",
                )
            )
    return file


def parameter_covariance(
    jacobian: NDArray[np.float64], residuals: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Covariance s^2 (J^T J)^-1 of the unknowns of a least-squares fit at its solution, with
    s^2 = sum(r^2) / (m - n); NaN where it cannot be told (m <= n, singular J^T J).

    Args:
        jacobian: d residual / d unknown, shape (m, n).
        residuals: residuals at the solution, shape (m,).
    """
    m, n = jacobian.shape
    normal = jacobian.T @ jacobian
    if m <= n or not np.all(np.isfinite(normal)) or np.linalg.cond(normal) > SINGULAR_CONDITION:
        return np.full((n, n), np.nan)
    scatter = float(np.sum(np.square(residuals))) / (m - n)
    return scatter * np.linalg.inv(normal)


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
    errors = residuals(fit.x)
    log_sigma = np.sqrt(np.diag(parameter_covariance(np.asarray(fit.jac), errors)))
    sigma = {n: values[n] * float(s) for n, s in zip(parameters, log_sigma, strict=True)}
    failed = errors == FAILED_SOLVE_RESIDUAL
    predicted = np.where(failed, np.nan, [t.torque for t in targets] * (1.0 + errors))
    return CalibrationResult(
        config=with_parameters(config, values),
        values=values,
        uncertainty=sigma,
        initial=initial,
        predicted=predicted.tolist(),
        relative_errors=errors.tolist(),
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
        "# Fitted (standard uncertainty from the fit's Jacobian): "
        + ", ".join(
            f"{k} = {v:.6g} +- {result.uncertainty[k]:.2g} (from {result.initial[k]:.6g})"
            for k, v in result.values.items()
        ),
        f"# Relative torque misfit: rms {result.rms_relative_error:.4f}, "
        f"max {result.max_relative_error:.4f} over {len(result.relative_errors)} targets.",
        "# All values SI (m, kg, Pa, K, rad); see config/paper_screw.yaml for their sources.",
    ]
    body = yaml.safe_dump(config_to_mapping(result.config), sort_keys=False)
    config_from_mapping(yaml.safe_load(body), str(path))  # what we write must load back
    file = Path(path)
    file.parent.mkdir(parents=True, exist_ok=True)
    file.write_text("\n".join(header) + "\n" + body, encoding="utf-8")


def refuse_outside_envelope(targets: Sequence[Target], config: TwinConfig, where: str) -> None:
    """Refuse targets outside the validity envelope (docs/model.md section 13) with one line
    naming ``where``; for a CSV, a temperature column that reads as kelvin gets that hint."""
    envelope = ValidityEnvelope.for_config(config)
    if not is_bag(where):
        for target in targets:
            celsius = target.point.temperature - CELSIUS_ZERO
            kelvin_from_command_line(celsius, f"{where}: temperature_C", envelope)
    refuse_outside([t.point for t in targets], envelope, str(where))


def parameter_unit(name: str) -> str:
    """SI unit of a fittable parameter (``-`` for a ratio)."""
    _, cls = FITTABLE[name]
    return str(next(f for f in dataclasses.fields(cls) if f.name == name).metadata["unit"])


def plot_calibration(
    result: CalibrationResult, targets: Sequence[Target], title: str, path: str | Path
) -> Path:
    """PNG: (a) predicted against target torque with the 1:1 line, (b) relative error of each
    target against its speed (or its preload, or its temperature: the first that varies among
    the targets), (c) each fitted value over its starting value with its standard uncertainty
    (error bar), the values themselves in the legend."""
    from matplotlib.figure import Figure

    from .plots.save import save_png

    fig = Figure(figsize=(15, 4.8), layout="constrained")
    measured_ax, error_ax, value_ax = fig.subplots(1, 3)
    measured = np.array([t.torque for t in targets]) * 1e3
    predicted = np.array(result.predicted) * 1e3
    temperature = np.array([t.point.temperature for t in targets]) - CELSIUS_ZERO
    candidates = (
        (np.array([t.point.screw_speed for t in targets]) / RPM, "screw speed [rpm]"),
        (np.array([t.point.preload for t in targets]), "preload [N]"),
        (temperature, "temperature [°C]"),
    )
    x, x_label = next(
        ((v, label) for v, label in candidates if np.ptp(v) > 1e-6 * np.max(np.abs(v))),
        candidates[0],
    )
    errors = np.array(result.relative_errors) * 100.0
    for k, level in enumerate(np.unique(np.round(temperature, 1))):
        at = np.round(temperature, 1) == level
        style = {"color": f"C{k % 10}", "label": f"{level:g} °C"}
        measured_ax.plot(measured[at], predicted[at], "o", **style)
        error_ax.plot(x[at], errors[at], "o", **style)
    finite = np.concatenate([measured, predicted[np.isfinite(predicted)]])
    span = [float(np.min(finite)), float(np.max(finite))]
    measured_ax.plot(span, span, "k-", lw=0.8, label="predicted = target")
    measured_ax.set_xlabel("target drag torque (measured or stated) [mN m]")
    measured_ax.set_ylabel("predicted drag torque [mN m]")
    measured_ax.set_title(f"(a) {len(targets)} targets, rms error {result.rms_relative_error:.2%}")
    measured_ax.legend(loc="best", fontsize="small")
    error_ax.axhline(0.0, color="k", lw=0.8)
    error_ax.set_xlabel(x_label)
    error_ax.set_ylabel("relative error (predicted / target - 1) [%]")
    error_ax.set_title("(b) residuals")
    names = list(result.values)
    ratio = np.array([result.values[n] / result.initial[n] for n in names])
    sigma = np.array([result.uncertainty[n] / result.initial[n] for n in names])
    positions = np.arange(len(names))
    for k, name in enumerate(names):
        label = (
            f"{name} = {result.values[name]:.4g} ± {result.uncertainty[name]:.2g} "
            f"{parameter_unit(name)} (from {result.initial[name]:.4g})"
        )
        value_ax.errorbar(
            [positions[k]],
            [ratio[k]],
            yerr=[0.0 if math.isnan(sigma[k]) else sigma[k]],
            fmt="s",
            capsize=6,
            color=f"C{k % 10}",
            label=label,
        )
    value_ax.axhline(1.0, color="grey", ls=":", lw=1)
    value_ax.set_xticks(positions, names)
    value_ax.set_xlim(-0.5, len(names) - 0.5)
    value_ax.set_xlabel("fitted parameter [-]")
    value_ax.set_ylabel("fitted / starting value [-]")
    value_ax.set_title("(c) fitted values ± standard uncertainty")
    value_ax.legend(loc="best", fontsize="small")
    for ax in (measured_ax, error_ax, value_ax):
        ax.grid(True, alpha=0.3)
    fig.suptitle(f"calibration against {title}")
    return save_png(fig, path)
