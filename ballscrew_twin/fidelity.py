"""Fidelity selection: the cheapest model whose measured error is within the scene's tolerance.

Every number used here comes from ``config/fidelity_bounds.yaml``, written by ``ballscrew-twin
bench skips`` (:mod:`ballscrew_twin.benchmarks.skips`): the error of each model and of each skip
rule at every point of a grid (preload x speed x temperature), the error of the quasi-static
steady state against the dynamic reference, the numerical error of that reference, and the cost
of one evaluation of each model on the machine that ran the benchmark.

For a scene, the bound of a model or rule is the largest error measured at the grid points that
cover the scene's range (in each axis from the largest grid value at or below the scene's lowest
value to the smallest at or above its highest; speeds below the lowest grid speed use it, since
every model gives drag 0 at standstill). A scene beyond the grid has no bound there: the model
or rule is rejected with that reason. Errors of chained approximations add (triangle
inequality): a catalogue bound measured against the steady model adds the steady model's own
bound against the dynamic one.

Candidates: the catalogue formula (Eq. 52) evaluated quasi-statically; the real-time model
(``models/realtime.py``, once its bound is in the file); the steady-state model
quasi-statically, symmetric or full; the dynamic model (the names of
:mod:`ballscrew_twin.models.registry`, with its ``scene`` spellings). The acceptable one with the
smallest estimated CPU time (measured cost per evaluation or step times the scene's distinct
operating points or steps) is chosen. The file must have been measured for the scene's
parameter set (:func:`bounds_fingerprint`). The selection reports the chosen model, every
skip rule with its bound and decision, and why each other candidate was rejected. A tolerance
tighter than every candidate's bound is refused (:class:`FidelityError`), naming the bounds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .errors import ConfigError, FidelityError
from .models.base import OperatingPoint
from .params import (
    TwinConfig,
    check_number,
    config_fingerprint,
    default_config_path,
    not_negative,
    read_yaml,
)
from .scene import QUANTITIES, Scene

FloatArray = NDArray[np.float64]
BOUNDS_NAME = "fidelity_bounds.yaml"
#: Metrics of the bounds file: scene tolerance key -> bound column suffix.
METRICS = ("drag_torque", "nut_torque", "contact_force")
AXES = ("preload_N", "speed_rad_s", "temperature_K")
#: Relative difference below which a scene value sits on a grid value (the file keeps 7 digits).
GRID_MATCH = 1e-6


def bounds_fingerprint(config: TwinConfig) -> str:
    """The first 16 hex digits of :func:`ballscrew_twin.params.config_fingerprint` of
    ``config`` in any orientation (the bounds hold both): what ties a bounds file to the
    parameter set it was measured with."""
    return config_fingerprint(config, any_orientation=True)[:16]


def default_bounds_path() -> Path:
    """The committed bounds, next to the default parameter file."""
    return default_config_path().parent / BOUNDS_NAME


@dataclass(frozen=True)
class Bounds:
    """Measured error bounds and costs (contents of ``config/fidelity_bounds.yaml``).

    Attributes:
        source: file read from.
        command: the command that produced the file.
        grid: axis name -> grid values (preload [N], speed [rad/s], temperature [K]).
        columns: names of the columns of ``rows``.
        rows: (N, C) one row per grid point, NaN where not measured (solver failure).
        reference: errors of the quasi-static steady state against the dynamic model [-].
        dynamic: numerical error of the dynamic reference [-] and its cost [s per step].
        cost: CPU time of one evaluation of each quasi-static model [s].
        realtime: bounds [-] and cost [s per step] of the real-time model, or None.
    """

    source: str
    command: str
    grid: dict[str, tuple[float, ...]]
    columns: tuple[str, ...]
    rows: FloatArray
    reference: dict[str, float]
    dynamic: dict[str, float]
    cost: dict[str, float]
    realtime: dict[str, float] | None = None
    fingerprint: str = ""

    def column(self, name: str) -> FloatArray:
        """Values of one column [-]; FidelityError when the file lacks it."""
        try:
            return np.asarray(self.rows[:, self.columns.index(name)])
        except ValueError:
            raise FidelityError(f"{self.source}: column {name!r} missing") from None

    def covering(self, scene: Scene) -> tuple[NDArray[np.bool_], str | None]:
        """Rows covering the scene's range, or (empty, reason) when it leaves the grid."""
        ranges = {
            "preload_N": scene.range("preload"),
            "speed_rad_s": scene.speed_magnitude_range(),
            "temperature_K": scene.range("temperature"),
        }
        mask = np.ones(len(self.rows), dtype=bool)
        for axis, (lo, hi) in ranges.items():
            nodes = np.asarray(self.grid[axis])
            if axis == "speed_rad_s":
                lo = max(lo, float(nodes.min()))
                hi = max(hi, float(nodes.min()))
            below = nodes[nodes <= lo + GRID_MATCH * abs(lo)]
            above = nodes[nodes >= hi - GRID_MATCH * abs(hi)]
            if len(below) == 0 or len(above) == 0:
                return np.zeros(len(self.rows), dtype=bool), (
                    f"the scene's {axis} range [{lo:.6g}, {hi:.6g}] leaves the measured grid "
                    f"[{nodes.min():.6g}, {nodes.max():.6g}]"
                )
            values = self.column(axis)
            first, last = below.max(), above.min()
            mask &= (values >= first - GRID_MATCH * abs(first)) & (
                values <= last + GRID_MATCH * abs(last)
            )
        return mask, None

    def bound(self, name: str, scene: Scene) -> tuple[float | None, str]:
        """Largest error of column ``name`` over the covering rows, or (None, reason)."""
        mask, reason = self.covering(scene)
        if reason is not None:
            return None, reason
        values = self.column(name)[mask]
        missing = int(np.isnan(values).sum())
        if missing:
            return None, f"{name} not measured at {missing} grid point(s) in range (no solution)"
        return float(values.max()), f"max over {int(mask.sum())} grid points"


#: Unit of a bounds-file number by the end of its key or column (relative errors otherwise).
_KEY_UNITS = (("_Nm", "N m"), ("_rad_s", "rad/s"), ("_s", "s"), ("_N", "N"), ("_K", "K"))


def _number(value: Any, where: str, name: str, unit: str | None = None) -> float:
    """``value`` of the bounds file's key or column ``name`` as a number >= 0 (the package's
    one number check, :func:`~ballscrew_twin.params.check_number`, its unit ``unit`` or named
    by ``name``'s end, else ``-``), its refusal a FidelityError naming ``where``; an infinite
    error (of a reference of 0, :func:`~ballscrew_twin.benchmarks.skips.relative`) is kept: it
    rules its model out."""
    if value == math.inf:
        return math.inf
    given = unit or next((u for end, u in _KEY_UNITS if name.endswith(end)), "-")
    return float(check_number(value, not_negative(given), where, error=FidelityError))


def _floats(data: Any, where: str, unit: str | None = None) -> dict[str, float]:
    """The numbers of one section of the bounds file (:func:`_number`, ``unit`` for all of
    them if given); text and null entries (descriptions) are left out."""
    if not isinstance(data, dict):
        raise FidelityError(f"{where}: expected a mapping of numbers")
    return {
        str(key): _number(value, f"{where}.{key}", str(key), unit)
        for key, value in data.items()
        if not isinstance(value, str | type(None))  # descriptive entries (scenario file, ...)
    }


def load_bounds(path: str | Path | None = None) -> Bounds:
    """Read and check ``config/fidelity_bounds.yaml`` (or ``path``)."""
    file = Path(path) if path is not None else default_bounds_path()
    try:
        data = read_yaml(file, "fidelity bounds")
    except ConfigError as err:
        raise FidelityError(f"{err}; run `ballscrew-twin bench skips` to create it") from err
    where = str(file)
    if not isinstance(data, dict):
        raise FidelityError(f"{where}: top level must be a mapping")
    for key in ("command", "grid", "columns", "rows", "reference", "dynamic", "cost"):
        if key not in data:
            raise FidelityError(f"{where}: {key}: missing")
    grid = data["grid"]
    if not isinstance(grid, dict) or set(grid) != set(AXES):
        raise FidelityError(f"{where}: grid must have exactly {list(AXES)}")
    columns = tuple(str(c) for c in data["columns"])
    listed = data["rows"]
    if not (isinstance(listed, list) and listed) or not all(
        isinstance(row, list) and len(row) == len(columns) for row in listed
    ):
        raise FidelityError(f"{where}: every row must have {len(columns)} values")
    rows = np.array(
        [
            [
                math.nan if v is None else _number(v, f"{where}: rows[{i}].{name}", name)
                for name, v in zip(columns, row, strict=True)
            ]
            for i, row in enumerate(listed)
        ],
        dtype=np.float64,
    )
    realtime = data.get("realtime")
    if realtime is not None and not {"cost_s", "step_s"} <= set(realtime):
        raise FidelityError(f"{where}: realtime needs cost_s and step_s")
    return Bounds(
        source=where,
        command=str(data["command"]),
        grid={
            axis: tuple(
                _number(v, f"{where}: grid.{axis}[{k}]", axis) for k, v in enumerate(grid[axis])
            )
            for axis in AXES
        },
        columns=columns,
        rows=rows,
        reference=_floats(data["reference"], f"{where}: reference"),
        dynamic=_floats(data["dynamic"], f"{where}: dynamic"),
        cost=_floats(data["cost"], f"{where}: cost", "s"),
        realtime=None if realtime is None else _floats(realtime, f"{where}: realtime"),
        fingerprint=str(data.get("config_fingerprint", "")),
    )


# ------------------------------------------------------------------------------ selection


@dataclass
class Candidate:
    """One model considered for a scene, with its bounds and verdict."""

    name: str  # catalog | realtime | steady-symmetric | steady-full | dynamic
    bounds: dict[str, float | None]  # metric -> total bound [-] (None: not measured)
    cost: float | None  # estimated CPU time of the scene [s] (measured costs x work)
    rejected: str | None = None  # why not usable, None when acceptable

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready."""
        return {
            "model": self.name,
            "bounds": self.bounds,
            "estimated_cpu_time_s": self.cost,
            "rejected": self.rejected,
        }


@dataclass
class Skip:
    """A skip rule's verdict for the chosen model."""

    rule: str
    applied: bool
    bound: float | None  # drag-torque error it may cause [-], 0 when exact
    reason: str

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready."""
        return {"rule": self.rule, "applied": self.applied, "bound": self.bound, "why": self.reason}


@dataclass
class Selection:
    """The chosen model, the skip rules and the rejected alternatives."""

    scene: Scene
    model: str
    settings: dict[str, Any]
    bounds: dict[str, float | None]
    skips: list[Skip] = field(default_factory=list)
    candidates: list[Candidate] = field(default_factory=list)
    bounds_file: str = ""
    bounds_command: str = ""

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready (SI, relative errors)."""
        return {
            "scene": self.scene.name,
            "scene_file": self.scene.source,
            "model": self.model,
            "settings": self.settings,
            "error_bounds": self.bounds,
            "tolerance": self.scene.tolerance,
            "skips": [s.to_dict() for s in self.skips],
            "candidates": [c.to_dict() for c in self.candidates],
            "bounds_file": self.bounds_file,
            "bounds_command": self.bounds_command,
        }

    def report(self) -> str:
        """Human-readable report: model, bounds, skips, rejected alternatives."""
        tol = ", ".join(f"{k} {v:.3g}" for k, v in self.scene.tolerance.items())
        got = ", ".join(f"{k} {_fmt(v)}" for k, v in self.bounds.items())
        lines = [
            f"scene {self.scene.name}: outputs {', '.join(self.scene.outputs)}; tolerance {tol}",
            f"model: {self.model} {self.settings} (error bound: {got})",
            "skipped / kept:",
        ]
        for s in self.skips:
            verdict = "SKIPPED" if s.applied else "kept   "
            lines.append(f"  {verdict} {s.rule:<26} bound {_fmt(s.bound):>9}  {s.reason}")
        lines.append("alternatives:")
        for c in self.candidates:
            cost = "-" if c.cost is None else f"{c.cost:.3g} s"
            verdict = "chosen" if c.name == self.model else f"rejected: {c.rejected}"
            if c.rejected is None and c.name != self.model:
                verdict = "acceptable but costlier"
            lines.append(f"  {c.name:<17} est. {cost:>10}  {verdict}")
        lines.append(f"bounds from {self.bounds_file} ({self.bounds_command})")
        return "\n".join(lines)


def _fmt(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.3g}"


def _add(*parts: float | None) -> float | None:
    """Sum of bounds; None when any part is not measured."""
    if any(p is None for p in parts):
        return None
    return float(sum(p for p in parts if p is not None))


#: Significant digits to which two operating points must agree to count as unchanged [-].
POINT_DIGITS = 12


def point_key(op: OperatingPoint) -> tuple[float, ...]:
    """Speed [rad/s], temperature [K], preload and axial load [N] to :data:`POINT_DIGITS`
    significant digits: points equal to rounding (a ramp up and down) share one solve."""
    return tuple(
        float(f"{v:.{POINT_DIGITS}g}")
        for v in (op.screw_speed, op.temperature, op.preload, op.axial_load)
    )


def distinct_points(scene: Scene) -> int:
    """Number of distinct commanded operating points at the output times [-]."""
    return len({point_key(scene.operating_point(float(t))) for t in scene.output_times()})


def _candidates(scene: Scene, bounds: Bounds, orientation: str) -> list[Candidate]:
    """Every model with its total bounds, estimated cost and (if any) why it cannot serve."""
    ref: dict[str, float | None] = dict(bounds.reference)
    transient = bounds.reference.get("transient_drag_torque")
    if transient is not None and not all(scene.profile(q).is_constant() for q in QUANTITIES):
        # Quasi-static models skip the transient: their error then includes its bound.
        for metric in ("drag_torque", "nut_torque"):
            ref[metric] = _add(ref.get(metric), transient)
    evaluations = distinct_points(scene)
    wanted = ["drag_torque"]
    if scene.wants("per_nut"):
        wanted.append("nut_torque")
    if scene.wants("per_sphere"):
        wanted.append("contact_force")
    out: list[Candidate] = []

    def measured(column: str) -> tuple[float | None, str]:
        return bounds.bound(column, scene)

    # Catalogue formula (Eq. 52), measured against the steady model of the same orientation.
    cat: dict[str, float | None] = {}
    reasons = []
    for metric in ("drag_torque", "nut_torque"):
        value, why = measured(f"catalog_{orientation}.{metric}")
        cat[metric] = _add(value, ref.get(metric))
        if value is None:
            reasons.append(why)
    cat["contact_force"] = None
    out.append(Candidate("catalog", cat, evaluations * bounds.cost.get("catalog", math.inf), None))
    if scene.wants("per_sphere"):
        out[-1].rejected = "no contact states (per_sphere wanted)"
    elif reasons:
        out[-1].rejected = reasons[0]

    # Real-time model: measured against the steady model by bench skips.
    rt = bounds.realtime
    rt_bounds: dict[str, float | None] = {}
    rt_reason = None
    for metric in METRICS:
        value, why = (None, "not measured") if rt is None else measured(f"realtime.{metric}")
        rt_bounds[metric] = _add(value, ref.get(metric))
        if value is None and metric in wanted:
            rt_reason = why
    cost = None if rt is None else scene.duration / rt["step_s"] * rt["cost_s"]
    cand = Candidate("realtime", rt_bounds, cost)
    if rt is None:
        cand.rejected = "no measured bound in the bounds file (rerun bench skips)"
    elif orientation != "vertical":
        cand.rejected = "its table and bounds are of the vertical screw"
    elif rt_reason is not None:
        cand.rejected = rt_reason
    out.append(cand)

    # Steady state, quasi-static: symmetric (one sphere per nut) and full.
    sym_name = f"symmetric_{orientation}"
    sym: dict[str, float | None] = {}
    sym_reason = None
    for metric in METRICS:
        value, why = measured(f"{sym_name}.{metric}")
        sym[metric] = _add(ref.get(metric), value)
        if value is None and metric in wanted:
            sym_reason = why
    full = {m: ref.get(m) for m in METRICS}
    sym_cost = bounds.cost.get("steady_symmetric")
    full_cost = bounds.cost.get(f"steady_full_{orientation}")
    out.append(
        Candidate(
            "steady-symmetric",
            sym,
            None if sym_cost is None else evaluations * sym_cost,
            sym_reason,
        )
    )
    _, outside = bounds.covering(scene)
    out.append(
        Candidate(
            "steady-full", full, None if full_cost is None else evaluations * full_cost, outside
        )
    )
    if scene.has_faults:
        for c in out:
            c.rejected = "cannot represent the scene's faults (the dynamic model can)"

    # Dynamic model: the reference, bounded by its own numerical error.
    dyn = {m: bounds.dynamic.get(m, bounds.dynamic.get("drag_torque")) for m in METRICS}
    step_cost = bounds.dynamic.get("step_cost_s")
    time_step = bounds.dynamic.get("time_step_s", 1e-6)
    cand = Candidate(
        "dynamic", dyn, None if step_cost is None else scene.duration / time_step * step_cost
    )
    lo_t, hi_t = scene.range("temperature")
    lo_a, hi_a = scene.range("axial_load")
    if hi_t != lo_t:
        cand.rejected = "runs at one temperature; the scene's temperature varies"
    elif lo_a != 0.0 or hi_a != 0.0:
        cand.rejected = "takes no external axial load; the scene has one"
    out.append(cand)

    for c in out:
        if c.rejected is not None:
            continue
        for metric in wanted:
            value = c.bounds.get(metric)
            limit = scene.tolerance["contact_force" if metric == "contact_force" else "drag_torque"]
            if value is None:
                c.rejected = f"{metric} error not measured"
                break
            if value > limit:
                c.rejected = f"{metric} bound {value:.3g} > tolerance {limit:.3g}"
                break
    return out


def select(scene: Scene, bounds: Bounds, config: TwinConfig) -> Selection:
    """The cheapest acceptable model for ``scene`` with its skip rules.

    Args:
        scene: the validated scene.
        bounds: measured bounds (:func:`load_bounds`).
        config: the scene's parameter set (orientation already applied).

    Raises:
        FidelityError: no model can serve the scene within its tolerance (message lists the
            bounds of every candidate).
    """
    if bounds.fingerprint and bounds.fingerprint != bounds_fingerprint(config):
        raise FidelityError(
            f"{bounds.source} was measured for another parameter set than "
            f"{config.source or config.name}: run `ballscrew-twin bench skips --config "
            "YOUR_FILE --out YOUR_BOUNDS` and pass --bounds YOUR_BOUNDS"
        )
    orientation = config.screw.orientation
    candidates = _candidates(scene, bounds, orientation)
    usable = [c for c in candidates if c.rejected is None]
    if not usable:
        detail = "; ".join(f"{c.name}: {c.rejected}" for c in candidates)
        tol = ", ".join(f"{k} = {v:.3g}" for k, v in scene.tolerance.items())
        raise FidelityError(
            f"{scene.source or scene.name}: no model meets tolerance {tol} ({detail}). "
            "Loosen the tolerance to at least the smallest bound above, or remove what "
            "forces a model the tolerance rules out."
        )
    chosen = min(usable, key=lambda c: math.inf if c.cost is None else c.cost)
    settings: dict[str, Any] = {}
    if chosen.name.startswith("steady"):
        settings["mode"] = chosen.name.split("-")[1]
    selection = Selection(
        scene=scene,
        model=chosen.name,
        settings=settings,
        bounds={m: chosen.bounds.get(m) for m in METRICS},
        candidates=candidates,
        bounds_file=bounds.source,
        bounds_command=bounds.command,
    )
    selection.skips = skip_rules(scene, bounds, config, chosen.name)
    return selection


def skip_rules(scene: Scene, bounds: Bounds, config: TwinConfig, model: str) -> list[Skip]:
    """Every skip rule's verdict for ``model`` on ``scene``, each with its bound."""
    tol = scene.tolerance["drag_torque"]
    quasi_static = model in ("catalog", "steady-symmetric", "steady-full")
    steady = model.startswith("steady")
    orientation = config.screw.orientation
    rules: list[Skip] = []

    sym, why = bounds.bound(f"symmetric_{orientation}.drag_torque", scene)
    if model == "steady-symmetric":
        rules.append(
            Skip(
                "per-sphere resolution",
                True,
                sym,
                f"one sphere per nut stands for all ({orientation} screw, {why})",
            )
        )
    elif model == "steady-full":
        rules.append(Skip("per-sphere resolution", False, sym, f"symmetric bound: {why}"))
    else:
        rules.append(Skip("per-sphere resolution", False, sym, f"not a choice of {model}"))

    inertial, why = bounds.bound("inertial.drag_torque", scene)
    if not steady:
        text = f"not a switch of {model}"
    elif inertial is None or inertial > tol:
        text = f"bound above tolerance or not measured ({why})"
    else:
        text = "within tolerance, but the contact kernel computes them at no separate cost"
    rules.append(Skip("centrifugal/gyroscopic terms", False, inertial, text))

    lo_t, hi_t = scene.range("temperature")
    if not (steady or model == "dynamic"):
        text = f"{model} has no lubricant state"
    elif lo_t == hi_t:
        text = f"temperature constant at {lo_t:.2f} K: lubricant state computed once (cache)"
    else:
        text = "recomputed only when the temperature changes (cache per temperature)"
    rules.append(Skip("lubricant property updates", steady or model == "dynamic", 0.0, text))

    evaluations = distinct_points(scene)
    samples = len(scene.output_times())
    rules.append(
        Skip(
            "re-solving unchanged points",
            quasi_static,
            0.0,
            f"{evaluations} distinct operating points among {samples} samples (cache)"
            if quasi_static
            else f"{model} steps in time",
        )
    )

    asperity, why = bounds.bound("asperity.drag_torque", scene)
    rules.append(
        Skip(
            "asperity terms in full film",
            False,
            asperity,
            "f(Lambda) = 0 exactly for Lambda >= 2.26 (full film); evaluated at no separate "
            f"cost, so kept ({why})",
        )
    )

    gap = sphere_gap(config, lo_t, hi_t)
    rules.append(
        Skip(
            "sphere-to-sphere contacts",
            gap > 0.0,
            0.0 if gap > 0.0 else None,
            f"equally spaced spheres leave {gap * 1e3:.3f} mm between neighbours over "
            f"{lo_t:.1f}-{hi_t:.1f} K (geometry)"
            if gap > 0.0
            else "spheres packed without gap: contacts between spheres are NOT resolved",
        )
    )

    qs = bounds.reference.get("drag_torque")
    if model == "dynamic":
        text = "kept: " + ("faults need it" if scene.has_faults else "no cheaper model fits")
        rules.append(Skip("fast sphere dynamics", False, qs, text))
    else:
        rules.append(
            Skip(
                "fast sphere dynamics",
                True,
                qs,
                f"{model} is quasi-static/tabulated: bound = steady vs dynamic model at "
                "steady state (bench skips)"
                + (
                    f" + transient {bounds.reference['transient_drag_torque']:.3g}"
                    if "transient_drag_torque" in bounds.reference
                    else "; transient error not measured (bench skips --transient-bound): "
                    "valid for commands slow against the sphere dynamics"
                ),
            )
        )
    return rules


def sphere_gap(config: TwinConfig, lo_temperature: float, hi_temperature: float) -> float:
    """Smallest gap between equally spaced neighbouring spheres along the loaded helix [m],
    over the temperature range (thermal expansion of screw and spheres)."""
    from .physics.geometry import thermally_expanded

    gaps = []
    for temperature in (lo_temperature, hi_temperature):
        geom = thermally_expanded(config.screw, config.materials, temperature)
        length = 2.0 * math.pi * geom.pitch_radius * geom.loaded_turns / math.cos(geom.helix_angle)
        gaps.append(length / geom.balls_per_nut - 2.0 * geom.ball_radius)
    return min(gaps)
