"""``ballscrew-twin bench extrapolation``: how wrong the commissioned twin is outside the
temperatures its commissioning saw, against the growth e_T the monitor's sigma gives it.

Each unit of ``bench detection`` (the same draws, :func:`.detection_plan.unit_draw`) is
commissioned on its cold start as that benchmark does, and again on the first and on the last
part of it alone (``--first``, ``--last``: a unit commissioned cold and run warm, and the other
way round), and its healthy recording is run through a monitor of each baseline. For every
compared block the monitor's own parts of its 1-sigma are kept (:class:`_Probe`): the band
error e_rel, the distance d_T [K] outside the temperatures commissioned at the block's speed,
the fitted shift's term E_dT and the transient terms. Steady blocks (transient terms below
:data:`STEADY_SHARE` of the drag), where the temperature is the one question left, are
grouped by d_T; per group the table gives the twin's |relative error| and, for each growth of
``--growths``, the ratio of the error to the sigma the monitor would give the block with that
e_T (sensor noise apart): a ratio that stays at or below what the blocks inside the range
reach says the growth is wide enough there. A second table pools the three commissionings and
gives, at the first growth, the ratio with E_dT made on other scales ``--shift-scales`` (the
baseline's ``shift_extrapolation`` [K]; ``inf`` leaves the term out). ``--band-reach``
commissions every unit with that reach of the temperatures seen along the speed
(:meth:`.Baseline.reached_range`; each record keeps it), so that two runs compare it with the
speed bands' own ranges. Tune e_T, the scale and the reach on training units only.
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from ..errors import ConfigError
from ..health.baseline import BAND_REACH, SHIFT_EXTRAPOLATION, Baseline
from ..health.bench_data import generate_unit_data
from ..health.commission import KEYWORD_LIMITS, TEMPERATURE_ERROR, Channels, commission
from ..health.monitor import HealthMonitor, feed
from ..health.monitor_settings import MonitorSettings
from ..health.residuals import Block, UnitTwin
from ..health.sensors import sensors_from_mapping
from ..params import TwinConfig, check_number, load_config
from .detection import SENSORS, channels_of
from .detection_plan import (
    TRAINING_UNITS,
    Plan,
    commissioning_trajectory,
    healthy_trajectory,
    unit_draw,
    unit_range,
)

DESCRIPTION = "the twin's error outside the commissioned temperatures against the growth e_T"
#: Blocks whose transient terms stay below this share of the drag count as steady [-].
STEADY_SHARE = 0.003
#: Upper edges of the groups of the distance outside the commissioned temperatures [K].
DISTANCE_EDGES = (2.0, 5.0, 10.0, 20.0, math.inf)

#: One compared block: variant, unit, d_T [K], |relative error| [-], band error [-], shift
#: term [-], transient terms [-] (relative to the block's drag).
Row = tuple[str, int, float, float, float, float, float]
#: The keys of a row in extrapolation.json, in its order; each record also carries
#: ``shift_scale``, the scale [K] its shift term was made on (:data:`SHIFT_EXTRAPOLATION`).
ROW_KEYS = ("variant", "unit", "distance", "error", "band", "shift", "transient")


class _Probe(HealthMonitor):
    """A monitor that keeps, per block time [s], the parts of its sigma (relative)."""

    def __init__(self, config: TwinConfig, baseline: Baseline, twin: UnitTwin) -> None:
        super().__init__(config, MonitorSettings(), baseline=baseline, twin=twin)
        #: block time [s] -> drag [N m], d_T [K], e_rel, E_dT and transient terms [-]
        self.parts: dict[float, tuple[float, float, float, float, float]] = {}

    def block_sigma(self, block: Block, drag: float, transient: float, edge_change: float) -> float:
        b = self.baseline
        speed = float(np.mean(block.speed))
        size = max(abs(drag), 1e-12)
        self.parts[block.time] = (
            drag,
            b.temperature_distance(block.temperature, speed),
            b.error_at(speed, block.temperature),
            b.extrapolation_error(edge_change) / size,
            math.sqrt(transient) / size,
        )
        return super().block_sigma(block, drag, transient, edge_change)


def _cut(channels: Channels, start: float, stop: float) -> Channels:
    """The samples of ``channels`` from ``start`` to ``stop`` [s] after the first stamp."""
    first = min(float(stamps[0]) for stamps, _ in channels.values())
    cut = {}
    for name, (stamps, values) in channels.items():
        keep = (stamps - first >= start) & (stamps - first < stop)
        cut[name] = (stamps[keep], values[keep])
    return cut


def unit_rows(
    number: int, plan: Plan, first: float, last: float, config: TwinConfig, band_reach: float
) -> list[Row]:
    """Every compared block of unit ``number``'s healthy recording, under the baselines of
    its whole cold start, of its first ``first`` [s] and of its last ``last`` [s], each
    commissioned with the reach ``band_reach`` [decades] (:meth:`.Baseline.reached_range`)."""
    twin = UnitTwin(config)
    sensors = sensors_from_mapping(SENSORS, "bench extrapolation sensors")
    draw = unit_draw(number, 0)
    recorded = {
        name: channels_of(
            generate_unit_data(config, draw.unit, trajectory, sensors=sensors, seed=seed, name=name)
        )
        for name, trajectory, seed in (
            ("commissioning", commissioning_trajectory(draw, plan), draw.seeds[1]),
            ("run", healthy_trajectory(draw, plan), draw.seeds[2]),
        )
    }
    whole = recorded["commissioning"]
    variants = {
        "whole": whole,
        f"first {first:g} s": _cut(whole, 0.0, first),
        f"last {last:g} s": _cut(whole, plan.commission - last, math.inf),
    }
    residual = MonitorSettings().residual
    rows: list[Row] = []
    for name, channels in variants.items():
        baseline = commission(channels, config, residual, twin=twin, band_reach=band_reach).baseline
        probe = _Probe(config, baseline, twin)
        for sample in feed(probe, recorded["run"]):
            parts = probe.parts.get(sample.time)
            if parts is None or not math.isfinite(sample.residual):
                continue
            drag, distance, band, shift, transient = parts
            relative = abs(sample.residual) / max(abs(drag) * baseline.torque_gain, 1e-12)
            rows.append((name, number, distance, relative, band, shift, transient))
    return rows


def read_rows(path: Path) -> list[Row]:
    """The rows an earlier run wrote to ``path`` (its extrapolation.json), the shift term
    brought to today's :data:`SHIFT_EXTRAPOLATION` from the scale the run made it on;
    ConfigError naming the file when it cannot be read or is not such a list."""
    try:
        records = json.loads(path.read_text(encoding="utf-8"))
        rows: list[Row] = []
        for r in records:
            distance, error, band, shift, transient = (float(r[k]) for k in ROW_KEYS[2:])
            shift *= float(r["shift_scale"]) / SHIFT_EXTRAPOLATION
            rows.append(
                (str(r["variant"]), int(r["unit"]), distance, error, band, shift, transient)
            )
        return rows
    except (OSError, UnicodeDecodeError, ValueError, TypeError, KeyError) as exc:
        raise ConfigError(
            f"--rows {path}: not the extrapolation.json of a run ({type(exc).__name__}: {exc})"
        ) from None


def _job(job: tuple[int, Plan, float, float, TwinConfig, float]) -> list[Row]:
    return unit_rows(*job)


def all_rows(
    units: range,
    plan: Plan,
    first: float,
    last: float,
    config: TwinConfig,
    workers: int,
    band_reach: float = BAND_REACH,
) -> Iterator[list[Row]]:
    """:func:`unit_rows` of every unit, in ``workers`` processes."""
    jobs = [(n, plan, first, last, config, band_reach) for n in units]
    if workers <= 1:
        yield from map(_job, jobs)
        return
    with multiprocessing.get_context("spawn").Pool(workers) as pool:
        yield from pool.imap_unordered(_job, jobs)


def _group(distance: float) -> int:
    """0 inside the commissioned range, then 1 + the index of DISTANCE_EDGES' group."""
    return 0 if distance <= 0.0 else 1 + int(np.searchsorted(DISTANCE_EDGES, distance))


def _group_names() -> list[str]:
    """The names of the groups of :func:`_group`, in its order."""
    lows = (0.0, *DISTANCE_EDGES[:-1])
    names = ["inside", *(f"{lo:g}-{hi:g} K" for lo, hi in zip(lows, DISTANCE_EDGES, strict=True))]
    names[-1] = f"> {lows[-1]:g} K"
    return names


def _ratio_cells(ratio: np.ndarray) -> str:
    return f"{np.quantile(ratio, 0.99):.2f} / {ratio.max():.2f}"


def _group_cells(
    picked: list[Row], terms: list[tuple[float, float]], shift_median: bool
) -> Iterator[tuple[str, list[str]]]:
    """Per group of d_T that holds a row of ``picked``: its name and cells, the count of
    blocks and units, the 99th percentile and largest |relative error| [%], the median shift
    term [%] if ``shift_median``, and per (e_T [1/K], factor on E_dT [-]) of ``terms`` the
    99th percentile and largest ratio |error| / sqrt(e_rel^2 + (e_T d_T)^2 + (factor
    E_dT)^2 + transient^2) [-]."""
    units = np.array([r[1] for r in picked])
    distance, error, band, shift, transient = np.array([r[2:] for r in picked]).T
    groups = np.array([_group(d) for d in distance])
    for g, name in enumerate(_group_names()):
        pick = groups == g
        if not pick.any():
            continue
        cells = [
            str(int(pick.sum())),
            str(len(set(units[pick].tolist()))),
            f"{100 * np.quantile(error[pick], 0.99):.2f} / {100 * error[pick].max():.2f}",
        ]
        if shift_median:
            cells.append(f"{100 * np.median(shift[pick]):.2f}")
        for growth, factor in terms:
            sigma = np.sqrt(
                band[pick] ** 2
                + (growth * distance[pick]) ** 2
                + (factor * shift[pick]) ** 2
                + transient[pick] ** 2
            )
            cells.append(_ratio_cells(error[pick] / sigma))
        yield name, cells


def table(rows: list[Row], growths: tuple[float, ...]) -> str:
    """Markdown, per variant: the steady blocks grouped by d_T, their count and units, the
    99th percentile and largest |relative error| [%] and, per growth, those of the ratio
    |error| / sqrt(e_rel^2 + (e_T d_T)^2 + E_dT^2 + transient^2) [-]."""
    head = "| commissioned on | d_T | blocks | units | error p99 / max [%] | " + " | ".join(
        f"ratio at e_T {g * 100:g} %/K: p99 / max" for g in growths
    )
    lines = [head + " |", "| --- " * (5 + len(growths)) + "|"]
    for variant in dict.fromkeys(r[0] for r in rows):
        picked = [r for r in rows if r[0] == variant and r[6] < STEADY_SHARE]
        if not picked:
            lines.append(f"| {variant} | no steady block |" + " |" * (3 + len(growths)))
            continue
        terms = [(g, 1.0) for g in growths]
        for name, cells in _group_cells(picked, terms, shift_median=False):
            lines.append(f"| {variant} | {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def shift_table(rows: list[Row], growth: float, scales: tuple[float, ...]) -> str:
    """Markdown, the steady blocks of every variant pooled and grouped by d_T: their count
    and units, the 99th percentile and largest |relative error| [%], the median E_dT [%] on
    the rows' scale (:data:`SHIFT_EXTRAPOLATION`) and, per scale X [K] of ``scales``, the
    99th percentile and largest ratio |error| / sigma at e_T = ``growth`` [1/K] with E_dT
    times SHIFT_EXTRAPOLATION / X (X = inf: no E_dT) [-]."""
    picked = [r for r in rows if r[6] < STEADY_SHARE]
    head = "| d_T | blocks | units | error p99 / max [%] | E_dT median [%] | " + " | ".join(
        f"ratio at X = {x:g} K: p99 / max" for x in scales
    )
    lines = [head + " |", "| --- " * (5 + len(scales)) + "|"]
    if not picked:
        return "\n".join([*lines, "| no steady block |" + " |" * (4 + len(scales))])
    terms = [(growth, SHIFT_EXTRAPOLATION / x) for x in scales]
    for name, cells in _group_cells(picked, terms, shift_median=True):
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def plot(rows: list[Row], growths: tuple[float, ...], path: Path) -> Path:
    """|relative error| of the steady blocks against d_T, each variant its colour, with the
    lines e_T d_T of the growths."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 5))
    for variant in dict.fromkeys(r[0] for r in rows):
        picked = [(r[2], r[3]) for r in rows if r[0] == variant and r[6] < STEADY_SHARE]
        if picked:
            d, e = np.array(picked).T
            ax.scatter(d, 100 * e, s=2, alpha=0.3, label=f"commissioned on its {variant}")
    top = max((r[2] for r in rows), default=1.0)
    span = np.linspace(0.0, max(top, 1.0), 50)
    for growth in growths:
        ax.plot(span, 100 * growth * span, label=f"e_T d_T, e_T = {growth * 100:g} %/K")
    ax.set_xlabel("distance outside the temperatures commissioned at the block's speed [K]")
    ax.set_ylabel("|twin error| of a steady block [% of the drag]")
    ax.legend(fontsize=8, markerscale=4)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``bench extrapolation``."""
    parser.add_argument(
        "--units",
        default=f"{TRAINING_UNITS[0]}:{TRAINING_UNITS[1]}",
        help=f"unit numbers FIRST:STOP (default the training units {TRAINING_UNITS[0]}:"
        f"{TRAINING_UNITS[1]})",
    )
    parser.add_argument("--commission", type=float, default=1200.0, help="cold start [s]")
    parser.add_argument("--healthy", type=float, default=1200.0, help="healthy run [s]")
    parser.add_argument("--first", type=float, default=200.0, help="its first part [s]")
    parser.add_argument("--last", type=float, default=600.0, help="its last part [s]")
    parser.add_argument(
        "--growths",
        default=f"{TEMPERATURE_ERROR},0.005,0.001,0",
        help="e_T to compare, comma-separated [1/K] (the first is the default's)",
    )
    parser.add_argument(
        "--shift-scales",
        default="5,10,25,inf",
        help="scales of the shift's term E_dT to compare at the first growth, comma-separated "
        "[K] (the baseline's shift_extrapolation; inf: no term)",
    )
    parser.add_argument(
        "--band-reach",
        type=float,
        default=BAND_REACH,
        help="commission each unit with this reach of the temperatures seen along the speed "
        "[decades] (the baseline's band_reach; 0: a speed band's own)",
    )
    parser.add_argument(
        "--rows",
        default=None,
        help="tabulate the rows of an earlier run's extrapolation.json instead of running "
        "the units (--units names them in the heading)",
    )
    parser.add_argument("--workers", type=int, default=2, help="processes [-]")
    parser.add_argument("--config", default=None, help="screw parameter YAML (default: paper)")
    parser.add_argument("--out", default=None, help="directory for extrapolation.md, PNG, JSON")


def _numbers(option: str, text: str, unit: str) -> tuple[float, ...]:
    """The comma-separated numbers of ``option`` (ConfigError naming it and ``unit``)."""
    try:
        return tuple(float(x) for x in text.split(","))
    except ValueError:
        raise ConfigError(f"{option} {text!r}: numbers [{unit}] separated by commas") from None


def run(args: argparse.Namespace) -> int:
    """Commission, monitor, tabulate; print the table (and write it, the rows and a plot)."""
    from tqdm import tqdm

    units = unit_range(args.units)
    growths = _numbers("--growths", args.growths, "1/K")
    if not all(math.isfinite(g) and g >= 0.0 for g in growths):
        raise ConfigError(f"--growths {args.growths!r}: every e_T must be finite and >= 0")
    scales = _numbers("--shift-scales", args.shift_scales, "K")
    if not all(x > 0.0 for x in scales):
        raise ConfigError(f"--shift-scales {args.shift_scales!r}: every scale must be > 0 K")
    if not (10.0 < args.first < args.commission and 10.0 < args.last < args.commission):
        raise ConfigError("--first and --last must lie between 10 s and --commission")
    check_number(args.band_reach, KEYWORD_LIMITS["band_reach"], "--band-reach", text=False)
    plan = Plan(commission=args.commission, healthy=args.healthy, faults=0, fault_length=60.0)
    rows: list[Row] = []
    if args.rows:
        rows = read_rows(Path(args.rows))
    else:
        config = load_config(args.config)
        for each in tqdm(
            all_rows(units, plan, args.first, args.last, config, args.workers, args.band_reach),
            total=len(units),
            desc="units",
            file=sys.stderr,
        ):
            rows.extend(each)
    rows.sort(key=lambda r: (r[1], r[0]))
    made = (
        f"the rows of {args.rows}"
        if args.rows
        else f"cold start {plan.commission:g} s, healthy run {plan.healthy:g} s, commissioned "
        f"with a reach of {args.band_reach:g} decades"
    )
    text = (
        f"Units {units.start}:{units.stop}, {made}; steady blocks (transient terms < "
        f"{STEADY_SHARE:.1%} of the drag)."
        "\n\n" + table(rows, growths) + "\n\nAll commissionings pooled, e_T = "
        f"{growths[0] * 100:g} %/K, the shift's term on the scale X:\n\n"
        + shift_table(rows, growths[0], scales)
    )
    print(text)
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        (out / "extrapolation.md").write_text(text + "\n")
        records = [
            {
                **dict(zip(ROW_KEYS, r, strict=True)),
                "shift_scale": SHIFT_EXTRAPOLATION,
                "band_reach": args.band_reach,
            }
            for r in rows
        ]
        (out / "extrapolation.json").write_text(json.dumps(records) + "\n")
        print(f"wrote {plot(rows, growths, out / 'extrapolation.png')}")
    return 0
