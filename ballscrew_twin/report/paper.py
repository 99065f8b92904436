"""``ballscrew-twin report paper``: the paper's Figs. 9-11 recomputed with the steady model.

The steady-state model (symmetric mode: one sphere per nut stands for all of them) is solved on
a grid of temperature, screw speed and preload, and the report writes to ``--out``:

- ``fig09_drag_vs_preload.png``: drag torque vs preload at 100 rpm, -20/20/60 C, with the
  catalogue lines of Eq. 51 and Eq. 52 (mu_lit = 0.002).
- ``fig10_contacts_vs_preload.png``: one sphere of the master nut at 100 rpm, screw-side and
  nut-side contact: forces, contact angle, lubricant and dry friction, Tallian parameter, shear
  stress, Hertz area, maximum pressure.
- ``fig11_speed.png``: drag torque, friction coefficient and contact angles vs preload at
  100-4000 rpm, -20 and 20 C (the paper omits 60 C here).
- ``paper_trends.csv``: one row per (figure, temperature, speed, preload), every plotted
  quantity in SI units, and a ``status`` column: ``ok`` or the solver's error message. Points
  that do not converge are recorded, left as NaN and skipped in the plots, never invented.

Computation (:func:`paper_sweep`) and plotting (:func:`plot_paper`) are separate. Each curve is
swept in increasing preload, each point warm-started from the previous preload of its curve, or,
for a curve's first point or after a failure, from the same preload at the next lower speed.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from tqdm import tqdm

from ..errors import SolverError
from ..models.base import ContactStates, OperatingPoint
from ..models.catalog import CatalogModel
from ..models.steady import SteadySolution, SteadyState, SteadyStateModel
from ..models.validity import ValidityEnvelope, refuse_outside
from ..params import TwinConfig
from ..physics.geometry import HALF_GROOVE_NAMES
from ..units import CELSIUS_ZERO, RPM, celsius_to_kelvin

Side = Literal["screw", "nut"]
#: One CSV row: column name -> value (SI units, NaN where the solve failed).
Row = dict[str, float | str]

MU_LIT = 0.002  # equivalent friction coefficient of Eqs. 51-52 in the paper's Fig. 9 [-]
MASTER_NUT = 0
SIDES: tuple[Side, ...] = ("screw", "nut")
FIGURES = ("fig09", "fig10", "fig11")
FILE_NAMES = {
    "fig09": "fig09_drag_vs_preload.png",
    "fig10": "fig10_contacts_vs_preload.png",
    "fig11": "fig11_speed.png",
}
CSV_NAME = "paper_trends.csv"

#: Quantities of one contact side, as column suffixes with their SI unit.
CONTACT_QUANTITIES = (
    "normal_force_N",
    "friction_force_N",
    "friction_coefficient",
    "contact_angle_rad",
    "lubricant_friction_N",
    "dry_friction_N",
    "tallian_parameter",
    "shear_stress_Pa",
    "contact_area_m2",
    "max_pressure_Pa",
)
ID_COLUMNS = (
    "figure",
    "temperature_C",
    "speed_rpm",
    "preload_N",
    "temperature_K",
    "screw_speed_rad_s",
    "status",
)
TORQUE_COLUMNS = ("drag_torque_Nm", "eq51_drag_torque_Nm", "eq52_drag_torque_Nm")
COLUMNS = (
    ID_COLUMNS
    + TORQUE_COLUMNS
    + tuple(f"{side}_half_groove" for side in SIDES)
    + tuple(f"{side}_{q}" for side in SIDES for q in CONTACT_QUANTITIES)
)


@dataclass(frozen=True)
class PaperGrid:
    """Operating points of the report.

    Attributes:
        temperatures: temperatures of Figs. 9-10 at the reference speed [deg C].
        speed_temperatures: temperatures of Fig. 11 [deg C].
        reference_speed: speed of Figs. 9-10 (ISO 3408-3) [rpm].
        speeds: speeds of Fig. 11, increasing [rpm].
        preloads: preloads of every curve, increasing [N].
    """

    temperatures: tuple[float, ...]
    speed_temperatures: tuple[float, ...]
    reference_speed: float
    speeds: tuple[float, ...]
    preloads: tuple[float, ...]

    def curves(self) -> list[tuple[float, float]]:
        """Distinct (temperature [deg C], speed [rpm]) curves, speeds increasing per temperature."""
        result = []
        for temperature in self.temperatures:
            for speed in sorted({self.reference_speed, *self.speeds}):
                if speed == self.reference_speed or temperature in self.speed_temperatures:
                    result.append((temperature, speed))
        return result

    def figures_of(self, temperature: float, speed: float) -> tuple[str, ...]:
        """Figures that plot the curve at ``temperature`` [deg C] and ``speed`` [rpm]."""
        figures: list[str] = []
        if speed == self.reference_speed:
            figures += ["fig09", "fig10"]
        if temperature in self.speed_temperatures and speed in self.speeds:
            figures.append("fig11")
        return tuple(figures)


def paper_grid(quick: bool) -> PaperGrid:
    """The paper's grid (preloads 0-3000 N every 250 N) or, with ``quick``, a coarse one."""
    if quick:
        return PaperGrid(
            (-20.0, 20.0, 60.0), (-20.0, 20.0), 100.0, (100.0, 4000.0), (100.0, 1000.0, 3000.0)
        )
    preloads = tuple(float(f) for f in range(0, 3001, 250))
    return PaperGrid(
        (-20.0, 20.0, 60.0), (-20.0, 20.0), 100.0, (100.0, 1000.0, 2000.0, 4000.0), preloads
    )


def contact_side(contacts: ContactStates, nut: int, side: Side) -> dict[str, float | str]:
    """Quantities of the loaded contact of the first sphere of ``nut`` on one ``side``.

    The loaded half groove (S1 or S2 on the screw, N1 or N2 on the nut) is the one with the
    larger normal force. Keys are ``{side}_half_groove`` and ``{side}_{quantity}`` with the
    quantities of :data:`CONTACT_QUANTITIES` in SI units (N, rad, Pa, m^2; ratios in -).
    """
    sphere = contacts.sphere[contacts.nut == nut][0]
    on_side = (contacts.half_groove >= 2) if side == "nut" else (contacts.half_groove < 2)
    rows = np.flatnonzero((contacts.sphere == sphere) & on_side)
    i = int(rows[np.argmax(contacts.normal_force[rows])])
    normal = float(contacts.normal_force[i])
    friction = float(contacts.friction_force[i])
    values = {
        "normal_force_N": normal,
        "friction_force_N": friction,
        "friction_coefficient": friction / normal if normal > 0.0 else math.nan,
        "contact_angle_rad": float(contacts.contact_angle[i]),
        "lubricant_friction_N": float(contacts.lubricant_share[i]) * friction,
        "dry_friction_N": float(contacts.dry_share[i]) * friction,
        "tallian_parameter": float(contacts.tallian_parameter[i]),
        "shear_stress_Pa": float(contacts.shear_stress[i]),
        "contact_area_m2": math.pi
        * float(contacts.semi_axis_x[i])
        * float(contacts.semi_axis_y[i]),
        "max_pressure_Pa": float(contacts.max_pressure[i]),
    }
    result: dict[str, float | str] = {
        f"{side}_half_groove": HALF_GROOVE_NAMES[int(contacts.half_groove[i])]
    }
    result.update({f"{side}_{name}": value for name, value in values.items()})
    return result


def _solve(
    model: SteadyStateModel, op: OperatingPoint, warm_starts: Sequence[SteadyState]
) -> SteadySolution:
    """Solve ``op`` from each warm start in turn (cold when there is none).

    Each attempt already includes the model's own cold-start fallback; the last
    :class:`SolverError` is raised when every attempt fails.
    """
    if not warm_starts:
        model.forget_warm_start()
        return model.solve(op)
    error: SolverError | None = None
    for start in warm_starts:
        try:
            return model.solve(op, warm_start=start)
        except SolverError as err:
            error = err
    assert error is not None
    raise error


def _failed_values(error: SolverError) -> dict[str, float | str]:
    """Status (the solver's message) and NaN for every quantity of a point that failed."""
    values: dict[str, float | str] = {"status": str(error), "drag_torque_Nm": math.nan}
    for side in SIDES:
        values[f"{side}_half_groove"] = ""
        values.update({f"{side}_{q}": math.nan for q in CONTACT_QUANTITIES})
    return values


def _solved_values(solution: SteadySolution) -> dict[str, float | str]:
    """Status, drag torque [N m] and the master nut's contact quantities (SI) of a point."""
    contacts = solution.output.contacts
    assert contacts is not None, "the steady model resolves every contact"
    values: dict[str, float | str] = {"status": "ok", "drag_torque_Nm": solution.output.drag_torque}
    for side in SIDES:
        values.update(contact_side(contacts, MASTER_NUT, side))
    return values


#: (temperature [deg C], speed [rpm], preload [N]) of one operating point.
PointKey = tuple[float, float, float]


def _warm_starts(
    states: dict[PointKey, SteadyState],
    curve: tuple[float, float],
    previous_preload: float | None,
    preload: float,
) -> list[SteadyState]:
    """Solved states to start ``preload`` [N] of ``curve`` (temperature [deg C], speed [rpm])
    from: the previous preload of the curve, then the same preload at the nearest lower speed."""
    temperature, speed = curve
    starts = []
    if previous_preload is not None and (temperature, speed, previous_preload) in states:
        starts.append(states[(temperature, speed, previous_preload)])
    lower = [s for t, s, p in states if t == temperature and s < speed and p == preload]
    if lower:
        starts.append(states[(temperature, max(lower), preload)])
    return starts


def solve_curves(
    config: TwinConfig,
    curves: Mapping[tuple[float, float], Sequence[float]],
    progress: bool = False,
) -> dict[PointKey, SteadySolution | SolverError]:
    """Solve the steady state (symmetric mode) along preload curves.

    Args:
        config: parameter set of the screw.
        curves: (temperature [deg C], speed [rpm]) -> preloads [N], increasing; solved in this
            order, so put the lower speeds of a temperature first.
        progress: show a tqdm progress bar over all points (stderr).

    Returns:
        (temperature [deg C], speed [rpm], preload [N]) -> the solution, or the
        :class:`SolverError` of a point that did not converge.
    """
    model = SteadyStateModel(config, mode="symmetric")
    states: dict[PointKey, SteadyState] = {}
    result: dict[PointKey, SteadySolution | SolverError] = {}
    total = sum(len(preloads) for preloads in curves.values())
    bar = tqdm(total=total, desc="steady sweep", unit="point", disable=not progress)
    # Newton trial steps that overshoot overflow inside the contact laws before the line search
    # rejects them; such warnings say nothing about the converged points.
    with bar, np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        for (temperature, speed), preloads in curves.items():
            previous: float | None = None
            for preload in preloads:
                key = (temperature, speed, preload)
                starts = _warm_starts(states, (temperature, speed), previous, preload)
                op = OperatingPoint(
                    screw_speed=speed * RPM,
                    temperature=temperature + CELSIUS_ZERO,
                    preload=preload,
                )
                try:
                    solution = _solve(model, op, starts)
                except SolverError as err:
                    result[key] = err
                else:
                    result[key] = solution
                    states[key] = solution.state
                previous = preload
                bar.update()
    return result


def paper_sweep(config: TwinConfig, quick: bool) -> list[Row]:
    """Solve every point of the report's grid; one row per (figure, temperature, speed, preload).

    Args:
        config: parameter set of the screw.
        quick: coarse grid (tests) instead of the paper's.

    Returns:
        Rows keyed by :data:`COLUMNS`, SI units, ordered by figure, temperature, speed, preload.
        ``status`` is ``"ok"`` or the :class:`SolverError` message; failed points hold NaN.
    """
    grid = paper_grid(quick)
    corners = [
        OperatingPoint(
            screw_speed=speed * RPM, temperature=celsius_to_kelvin(temperature), preload=preload
        )
        for temperature, speed in grid.curves()
        for preload in (min(grid.preloads), max(grid.preloads))
    ]
    refuse_outside(corners, ValidityEnvelope.for_config(config), f"report grid of {config.source}")
    eq51 = CatalogModel(config, mu_lit=MU_LIT, formula="literature")
    eq52 = CatalogModel(config, mu_lit=MU_LIT, formula="zhou")
    curves = grid.curves()
    solved = solve_curves(config, {curve: grid.preloads for curve in curves}, progress=True)
    rows: list[Row] = []
    for figure in FIGURES:
        for temperature, speed in curves:
            if figure not in grid.figures_of(temperature, speed):
                continue
            for preload in grid.preloads:
                row: Row = {
                    "figure": figure,
                    "temperature_C": temperature,
                    "speed_rpm": speed,
                    "preload_N": preload,
                    "temperature_K": temperature + CELSIUS_ZERO,
                    "screw_speed_rad_s": speed * RPM,
                    "eq51_drag_torque_Nm": eq51.torque_at_preload(preload),
                    "eq52_drag_torque_Nm": eq52.torque_at_preload(preload),
                }
                point = solved[(temperature, speed, preload)]
                if isinstance(point, SolverError):
                    row.update(_failed_values(point))
                else:
                    row.update(_solved_values(point))
                rows.append({name: row[name] for name in COLUMNS})
    return rows


def write_csv(rows: Iterable[Row], path: Path) -> Path:
    """Write ``rows`` with the header :data:`COLUMNS` to ``path`` (NaN written as ``nan``)."""
    with path.open("w", newline="", encoding="utf-8") as stream:
        writer = csv.DictWriter(stream, fieldnames=COLUMNS)
        writer.writeheader()
        writer.writerows(rows)
    return path


# ---------------------------------------------------------------------------------- plotting

TEMPERATURE_COLOURS = {-20.0: "tab:blue", 20.0: "tab:green", 60.0: "tab:red"}
SIDE_STYLES: dict[Side, Literal["-", "--"]] = {"screw": "-", "nut": "--"}


def _curve(
    rows: Sequence[Row], figure: str, temperature: float, speed: float, column: str
) -> tuple[list[float], list[float]]:
    """Preloads [N] and ``column`` of one curve of ``figure``; NaN where the solve failed."""
    selected = [
        r
        for r in rows
        if r["figure"] == figure and r["temperature_C"] == temperature and r["speed_rpm"] == speed
    ]
    preloads = [float(r["preload_N"]) for r in selected]
    values = [float(r[column]) if r["status"] == "ok" else math.nan for r in selected]
    return preloads, values


def _distinct(rows: Sequence[Row], figure: str, column: str) -> list[float]:
    """Distinct values of ``column`` among the rows of ``figure``, increasing."""
    return sorted({float(r[column]) for r in rows if r["figure"] == figure})


def _save(fig: Figure, path: Path) -> Path:
    """Render ``fig`` with the Agg canvas to ``path`` (PNG)."""
    FigureCanvasAgg(fig)
    fig.savefig(path, dpi=120)
    return path


def _plot_fig09(rows: Sequence[Row], path: Path) -> Path:
    """Drag torque [mN m] vs preload at 100 rpm per temperature, with Eqs. 51 and 52."""
    fig = Figure(figsize=(8, 5.5), layout="constrained")
    ax = fig.add_subplot()
    speed = _distinct(rows, "fig09", "speed_rpm")[0]
    for temperature in _distinct(rows, "fig09", "temperature_C"):
        x, y = _curve(rows, "fig09", temperature, speed, "drag_torque_Nm")
        ax.plot(
            x,
            np.array(y) * 1e3,
            "o-",
            color=TEMPERATURE_COLOURS.get(temperature),
            label=f"steady model, {temperature:g} °C",
        )
    # The catalogue formulas know neither temperature nor speed: one curve's rows carry them.
    first = _distinct(rows, "fig09", "temperature_C")[0]
    catalogue = [r for r in rows if r["figure"] == "fig09" and r["temperature_C"] == first]
    preloads = [float(r["preload_N"]) for r in catalogue]
    for column, style, width, label in (
        ("eq51_drag_torque_Nm", "k-", 2.5, "Eq. 51 (catalogue)"),
        ("eq52_drag_torque_Nm", "k--", 1.8, "Eq. 52 (Zhou et al.)"),
    ):
        torque = [float(r[column]) * 1e3 for r in catalogue]
        ax.plot(preloads, torque, style, linewidth=width, label=f"{label}, μ_lit = {MU_LIT:g}")
    ax.set_title(f"Fig. 9: no-load drag torque at {speed:g} rpm")
    ax.set_xlabel("preload F_pr [N]")
    ax.set_ylabel("drag torque [mN m]")
    ax.grid(True, alpha=0.3)
    ax.legend()
    return _save(fig, path)


#: Fig. 10 panels: (title, column suffix, factor to the plotted unit, axis label).
FIG10_PANELS = (
    ("(b) contact angle", "contact_angle_rad", 180.0 / math.pi, "contact angle [deg]"),
    ("(c) lubricant friction force", "lubricant_friction_N", 1.0, "F_t lubricant [N]"),
    ("(d) dry-contact friction force", "dry_friction_N", 1.0, "F_t dry [N]"),
    ("(e) Tallian parameter", "tallian_parameter", 1.0, "Λ [-]"),
    ("(f) lubricant shear stress", "shear_stress_Pa", 1e-6, "τ [MPa]"),
    ("(g) Hertz contact area π a_x a_y", "contact_area_m2", 1e6, "area [mm²]"),
    ("(h) maximum Hertz pressure", "max_pressure_Pa", 1e-9, "p_max [GPa]"),
)


def _plot_fig10(rows: Sequence[Row], path: Path) -> Path:
    """Master-nut sphere contacts at 100 rpm vs preload, screw side and nut side (2 x 4)."""
    fig = Figure(figsize=(18, 9), layout="constrained")
    axes: list[Axes] = list(fig.subplots(2, 4).flat)
    speed = _distinct(rows, "fig10", "speed_rpm")[0]
    temperatures = _distinct(rows, "fig10", "temperature_C")
    force_ax = axes[0]
    for temperature in temperatures:
        colour = TEMPERATURE_COLOURS.get(temperature)
        for side in SIDES:
            for quantity, marker in (("normal_force_N", "o"), ("friction_force_N", "s")):
                x, y = _curve(rows, "fig10", temperature, speed, f"{side}_{quantity}")
                force_ax.plot(
                    x, y, marker=marker, linestyle=SIDE_STYLES[side], color=colour, markersize=4
                )
            for ax, (_, suffix, factor, _) in zip(axes[1:], FIG10_PANELS, strict=True):
                x, y = _curve(rows, "fig10", temperature, speed, f"{side}_{suffix}")
                ax.plot(
                    x,
                    np.array(y) * factor,
                    marker="o",
                    markersize=4,
                    linestyle=SIDE_STYLES[side],
                    color=colour,
                )
    force_ax.set_yscale("log")
    axes[4].set_yscale("log")  # zero preload leaves the -20 C film far thicker
    force_ax.set_title("(a) normal (○) and friction (□) force")
    force_ax.set_ylabel("force [N]")
    for ax, (title, _, _, label) in zip(axes[1:], FIG10_PANELS, strict=True):
        ax.set_title(title)
        ax.set_ylabel(label)
    axes[4].axhline(3.0, color="grey", linestyle=":", linewidth=1)
    axes[4].text(
        0.02,
        3.0,
        " Λ = 3: full film above",
        color="grey",
        va="bottom",
        transform=axes[4].get_yaxis_transform(),
    )
    for ax in axes:
        ax.set_xlabel("preload [N]")
        ax.grid(True, alpha=0.3)
    handles = [
        Line2D([], [], color=TEMPERATURE_COLOURS.get(t), label=f"{t:g} °C") for t in temperatures
    ]
    handles += [
        Line2D([], [], color="k", linestyle=SIDE_STYLES[s], label=f"{s} side") for s in SIDES
    ]
    fig.legend(handles=handles, loc="outside lower center", ncols=len(handles))
    fig.suptitle(f"Fig. 10: one sphere of the master nut at {speed:g} rpm")
    return _save(fig, path)


def _plot_fig11(rows: Sequence[Row], path: Path) -> Path:
    """Per temperature (rows): drag torque, friction coefficients, contact angles vs preload."""
    temperatures = _distinct(rows, "fig11", "temperature_C")
    speeds = _distinct(rows, "fig11", "speed_rpm")
    fig = Figure(figsize=(16, 4.5 * len(temperatures)), layout="constrained")
    grid = fig.subplots(len(temperatures), 3, squeeze=False, sharex=True)
    for j in range(3):  # the same scale in a column makes the temperatures comparable
        for ax in grid[1:, j]:
            ax.sharey(grid[0, j])
    colours = {s: f"C{i}" for i, s in enumerate(speeds)}
    for i, temperature in enumerate(temperatures):
        drag_ax, mu_ax, angle_ax = grid[i]
        for speed in speeds:
            x, y = _curve(rows, "fig11", temperature, speed, "drag_torque_Nm")
            drag_ax.plot(x, np.array(y) * 1e3, "o-", color=colours[speed], markersize=4)
            for side in SIDES:
                x, mu = _curve(rows, "fig11", temperature, speed, f"{side}_friction_coefficient")
                x, angle = _curve(rows, "fig11", temperature, speed, f"{side}_contact_angle_rad")
                mu_ax.plot(
                    x,
                    mu,
                    marker="o",
                    markersize=4,
                    linestyle=SIDE_STYLES[side],
                    color=colours[speed],
                )
                angle_ax.plot(
                    x,
                    np.degrees(angle),
                    marker="o",
                    markersize=4,
                    linestyle=SIDE_STYLES[side],
                    color=colours[speed],
                )
        drag_ax.set_title(f"(a) drag torque, {temperature:g} °C")
        drag_ax.set_ylabel("drag torque [mN m]")
        mu_ax.set_title(f"(b) friction coefficient F_t/F_n, master nut, {temperature:g} °C")
        mu_ax.set_ylabel("F_t / F_n [-]")
        angle_ax.set_title(f"(c) contact angle, master nut, {temperature:g} °C")
        angle_ax.set_ylabel("contact angle [deg]")
    for ax in grid.flat:
        ax.grid(True, alpha=0.3)
    for ax in grid[-1]:
        ax.set_xlabel("preload [N]")
    handles = [Line2D([], [], color=colours[s], marker="o", label=f"{s:g} rpm") for s in speeds]
    handles += [
        Line2D([], [], color="k", linestyle=SIDE_STYLES[s], label=f"{s} side") for s in SIDES
    ]
    fig.legend(handles=handles, loc="outside lower center", ncols=len(handles))
    fig.suptitle("Fig. 11: influence of the screw speed")
    return _save(fig, path)


def plot_paper(rows: Sequence[Row], out_dir: Path) -> list[Path]:
    """Draw Figs. 9, 10 and 11 from :func:`paper_sweep`'s rows into ``out_dir`` (created).

    Failed points (status not ``ok``) are left out: their curves show a gap.

    Returns:
        Paths of the PNG files written.
    """
    out_dir.mkdir(parents=True, exist_ok=True)
    return [
        _plot_fig09(rows, out_dir / FILE_NAMES["fig09"]),
        _plot_fig10(rows, out_dir / FILE_NAMES["fig10"]),
        _plot_fig11(rows, out_dir / FILE_NAMES["fig11"]),
    ]
