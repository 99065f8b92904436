"""``ballscrew-twin scene FILE --out DIR``: run a scene through the cheapest adequate model.

Loads the scene (:mod:`ballscrew_twin.scene`), selects the model and the skips from the measured
bounds (:mod:`ballscrew_twin.fidelity`), prints the report and runs the command profiles:

- quasi-static models (catalogue, steady state) are evaluated at every output time, each
  distinct operating point once (cache of unchanged points; exact), the steady model
  warm-started from the previous point and reusing the lubricant state while the temperature
  does not change;
- the real-time model steps at 1 kHz (or the output period when shorter);
- the dynamic model steps at the time step of the bounds file (1 us), starting at rest in the
  static equilibrium of the initial preload, and is sampled at the output rate.

Writes into ``--out``: ``timeseries.csv`` (commands, drag torque, per-nut torque, breakdown; SI),
``result.npz`` (the same plus the per-sphere contact states when wanted), ``scene.png`` and
``selection.json`` (model, settings, error bounds, skips with bounds, rejected alternatives, run
statistics). Progress goes to stderr.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import BallscrewTwinError, SolverError
from ..fidelity import Bounds, Selection, load_bounds, point_key, select
from ..models import registry
from ..models.base import MECHANISMS, OperatingPoint, SteadyStateModel, TwinOutput
from ..models.faults import faults_from_mapping
from ..models.validity import ValidityEnvelope, refuse_outside
from ..params import TwinConfig, load_config
from ..scene import Scene, load_scene

FloatArray = NDArray[np.float64]
REALTIME_STEP = 1e-3  # s, longest step of the real-time model


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``scene``."""
    parser.add_argument("scene", help="scene YAML (SI units)")
    parser.add_argument("--out", required=True, help="output folder (created if missing)")
    parser.add_argument("--bounds", default=None, help="bounds file (default: committed one)")
    parser.add_argument("--select-only", action="store_true", help="print the selection only")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def scene_config(scene: Scene) -> TwinConfig:
    """The scene's parameter set with its orientation applied."""
    config = load_config(scene.config)
    if scene.orientation is not None and scene.orientation != config.screw.orientation:
        screw = dataclasses.replace(config.screw, orientation=scene.orientation)
        config = dataclasses.replace(config, screw=screw)
    return config


@dataclass
class SceneResult:
    """Sampled outputs of a scene run (SI units).

    Time series (N samples): ``time`` [s], commands ``speed`` [rad/s], ``temperature`` [K],
    ``preload``, ``axial_load`` [N]; ``screw_speed`` [rad/s] (the model's: the command for
    quasi-static models, the controlled speed of the dynamic one); ``drag_torque`` [N m],
    ``nut_torque`` (N, 2) [N m],
    ``breakdown`` (N, 6) [N m] in :data:`MECHANISMS` order. Contact states when per-sphere
    output is wanted (C contacts): ``contact_sphere``, ``contact_nut``, ``contact_half_groove``
    (C,), ``spheres_represented`` (C,) [-] (all spheres of the nut in symmetric mode),
    ``normal_force`` [N], ``contact_angle`` [rad], ``tallian`` [-], ``in_contact`` (N, C).
    """

    time: FloatArray
    speed: FloatArray
    temperature: FloatArray
    preload: FloatArray
    axial_load: FloatArray
    screw_speed: FloatArray
    drag_torque: FloatArray
    nut_torque: FloatArray
    breakdown: FloatArray
    contacts: dict[str, NDArray[Any]] = field(default_factory=dict)
    stats: dict[str, Any] = field(default_factory=dict)


def _commands(scene: Scene, times: FloatArray) -> dict[str, FloatArray]:
    return {
        q: np.array([scene.profile(q)(float(t)) for t in times])
        for q in ("speed", "temperature", "preload", "axial_load")
    }


def _empty(scene: Scene, times: FloatArray) -> SceneResult:
    n = len(times)
    cmd = _commands(scene, times)
    return SceneResult(
        time=times,
        speed=cmd["speed"],
        temperature=cmd["temperature"],
        preload=cmd["preload"],
        axial_load=cmd["axial_load"],
        screw_speed=cmd["speed"].copy(),
        drag_torque=np.zeros(n),
        nut_torque=np.zeros((n, 2)),
        breakdown=np.zeros((n, len(MECHANISMS))),
    )


def _store_contacts(result: SceneResult, i: int, out: TwinOutput) -> None:
    cs = out.contacts
    if cs is None:
        raise BallscrewTwinError(f"{out.fidelity} gives no contact states (per_sphere wanted)")
    c = result.contacts
    if not c:
        n, rows = len(result.time), len(cs.sphere)
        c["contact_sphere"] = cs.sphere.copy()
        c["contact_nut"] = cs.nut.copy()
        c["contact_half_groove"] = cs.half_groove.copy()
        for name in ("normal_force", "contact_angle", "tallian"):
            c[name] = np.zeros((n, rows))
        c["in_contact"] = np.zeros((n, rows), dtype=bool)
    c["normal_force"][i] = cs.normal_force
    c["contact_angle"][i] = cs.contact_angle
    c["tallian"][i] = cs.tallian_parameter
    c["in_contact"][i] = cs.in_contact


def _store(result: SceneResult, i: int, out: TwinOutput, per_sphere: bool) -> None:
    result.drag_torque[i] = out.drag_torque
    result.nut_torque[i] = out.nut_torque
    result.breakdown[i] = [getattr(out.breakdown, m) for m in MECHANISMS]
    if per_sphere:
        _store_contacts(result, i, out)


def build_quasi_static(selection: Selection, config: TwinConfig) -> SteadyStateModel:
    """The steady-state model (``evaluate``) of a quasi-static selection (registry names,
    ``catalog`` being Eq. 52 there)."""
    return registry.as_evaluating(
        registry.build(registry.model_name(selection.model, "scene"), config)
    )


def run_quasi_static(
    scene: Scene, model: Any, progress: Any, result: SceneResult
) -> dict[str, Any]:
    """Evaluate every output time; each distinct operating point once (cache keyed by
    :func:`~ballscrew_twin.fidelity.point_key`)."""
    cache: dict[tuple[float, ...], TwinOutput] = {}
    hits = 0
    per_sphere = scene.wants("per_sphere")
    for i, t in enumerate(result.time):
        op = scene.operating_point(float(t))
        key = point_key(op)
        out = cache.get(key)
        if out is None:
            try:
                out = model.evaluate(op)
            except SolverError as err:
                raise SolverError(
                    f"{scene.source or scene.name}: at t = {t:.6g} s (speed {op.screw_speed:.6g} "
                    f"rad/s, {op.temperature:.6g} K, preload {op.preload:.6g} N): {err}"
                ) from err
            cache[key] = out
        else:
            hits += 1
        _store(result, i, out, per_sphere)
        progress(1)
    return {
        "evaluations": len(cache),
        "operating_point_cache_hits": hits,
        "lubricant_cache_hits": getattr(model, "scene_cache_hits", None),
    }


def run_time_stepping(
    scene: Scene, model: Any, progress: Any, result: SceneResult
) -> dict[str, Any]:
    """Step a TimeSteppingModel at <= REALTIME_STEP and sample it at the output times."""
    per_sphere = scene.wants("per_sphere")
    model.reset(scene.operating_point(0.0))
    steps = 0
    now = 0.0
    for i, t in enumerate(result.time):
        out = None
        while out is None or now < t - 1e-12:
            dt = min(REALTIME_STEP, float(t) - now) if t > now else REALTIME_STEP
            now = now + dt if t > now else now
            out = model.step(scene.operating_point(now), dt)
            steps += 1
        _store(result, i, out, per_sphere)
        progress(1)
    return {"steps": steps}


def run_dynamic(
    scene: Scene, config: TwinConfig, bounds: Bounds, progress: Any, result: SceneResult
) -> dict[str, Any]:
    """Step the dynamic model from rest (the one time loop, :class:`TimeLoop`) and sample it at
    the output times: the state at a sample step's start and that step's report
    (:func:`~ballscrew_twin.models.dynamic_loop.dynamic_output`)."""
    from ..models.dynamic import DynamicModel
    from ..models.dynamic_loop import ModelStep, StepPlan, TimeLoop, dynamic_output
    from ..models.dynamic_state import Commands

    time_step = bounds.dynamic.get("time_step_s", 1e-6)
    options = registry.ModelOptions(
        temperature=scene.range("temperature")[0],
        time_step=time_step,
        faults=faults_from_mapping(
            scene.faults_mapping, config.screw.balls_per_nut, f"{scene.source}: faults"
        ),
    )
    model = registry.build(registry.ModelName.DYNAMIC, config, options)
    assert isinstance(model, DynamicModel)
    steps = round(scene.duration / time_step)
    sample_steps = {round(float(t) / time_step): i for i, t in enumerate(result.time)}
    per_sphere = scene.wants("per_sphere")

    def commands_at(t: float) -> Commands:
        return Commands(screw_speed=scene.speed(t), preload=scene.preload(t))

    def sample(step: ModelStep) -> None:
        i = sample_steps.get(step.k)
        if i is not None:
            result.screw_speed[i] = step.state.screw_speed
            op = scene.operating_point(step.k * time_step)
            _store(result, i, dynamic_output(model, step.state, step.report, op), per_sphere)
            progress(1)

    state = model.initial_state(scene.preload(0.0))
    TimeLoop(model, state, StepPlan(time_step), commands_at, sample).run(steps, final_report=True)
    stats: dict[str, Any] = {"steps": steps + 1, "time_step_s": time_step}
    if scene.speed(0.0) != 0.0:
        stats["note"] = (
            f"the dynamic model starts at rest: the speed command at t = 0 "
            f"({scene.speed(0.0):.6g} rad/s) is reached through its speed controller"
        )
    return stats


def run_selection(
    selection: Selection, config: TwinConfig, bounds: Bounds, quiet: bool = True
) -> SceneResult:
    """Run the scene through the selected model (progress bar on stderr unless ``quiet``)."""
    from tqdm import tqdm

    scene = selection.scene
    times = scene.output_times()
    result = _empty(scene, times)
    bar = tqdm(total=len(times), file=sys.stderr, disable=quiet, unit="sample", desc=scene.name)
    name = registry.model_name(selection.model, "scene")
    started = time.perf_counter()
    try:
        if name is registry.ModelName.DYNAMIC:
            stats = run_dynamic(scene, config, bounds, bar.update, result)
        elif name is registry.ModelName.REALTIME:
            realtime = registry.build(name, config)
            stats = run_time_stepping(scene, registry.as_stepping(realtime), bar.update, result)
        else:
            model = build_quasi_static(selection, config)
            stats = run_quasi_static(scene, model, bar.update, result)
    finally:
        bar.close()
    wall = time.perf_counter() - started
    if result.contacts:
        # Physical spheres each row stands for: a whole nut in symmetric mode, else one.
        symmetric = name is registry.ModelName.STEADY_SYMMETRIC
        count = config.screw.balls_per_nut if symmetric else 1
        result.contacts["spheres_represented"] = np.full(
            len(result.contacts["contact_sphere"]), count
        )
    stats.update(
        {
            "model": selection.model,
            "samples": len(times),
            "wall_time_s": wall,
            "real_time_factor": scene.duration / wall if wall > 0.0 else math.inf,
        }
    )
    result.stats = stats
    return result


# ------------------------------------------------------------------------------ writers

CSV_COLUMNS = (
    "time_s",
    "speed_command_rad_s",
    "temperature_K",
    "preload_N",
    "axial_load_N",
    "screw_speed_rad_s",
    "drag_torque_Nm",
    "nut_master_Nm",
    "nut_slave_Nm",
    *(f"{m}_Nm" for m in MECHANISMS),
)


def write_csv(result: SceneResult, path: Path) -> None:
    """Time series, one row per sample (SI)."""
    table = np.column_stack(
        [
            result.time,
            result.speed,
            result.temperature,
            result.preload,
            result.axial_load,
            result.screw_speed,
            result.drag_torque,
            result.nut_torque,
            result.breakdown,
        ]
    )
    with path.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle)
        writer.writerow(CSV_COLUMNS)
        writer.writerows([[f"{v:.10g}" for v in row] for row in table])


def write_npz(result: SceneResult, path: Path) -> None:
    """Every array of the result (SI)."""
    arrays: dict[str, Any] = {
        "time": result.time,
        "speed": result.speed,
        "temperature": result.temperature,
        "preload": result.preload,
        "axial_load": result.axial_load,
        "screw_speed": result.screw_speed,
        "drag_torque": result.drag_torque,
        "nut_torque": result.nut_torque,
        "breakdown": result.breakdown,
        "mechanisms": np.array(MECHANISMS),
        **result.contacts,
    }
    np.savez_compressed(path, **arrays)


def plot(result: SceneResult, selection: Selection, path: Path) -> None:
    """Commands and torques over time (PNG; torques in mN m, as on the project's other plots).

    Raises:
        BallscrewTwinError: the file cannot be written.
    """
    from matplotlib.figure import Figure

    from ..plots.save import save_png

    fig = Figure(figsize=(8, 8))
    axes = fig.subplots(3, 1, sharex=True)
    t = result.time
    axes[0].plot(t, result.speed, label="command")
    axes[0].plot(t, result.screw_speed, ":", label="screw")
    axes[0].set_ylabel("speed [rad/s]")
    axes[0].legend(loc="upper left")
    twin = axes[0].twinx()
    twin.plot(t, result.temperature, "r--", label="temperature [K]")
    twin.set_ylabel("temperature [K]")
    axes[1].plot(t, result.preload, label="preload")
    axes[1].plot(t, result.axial_load, label="axial load")
    axes[1].set_ylabel("force [N]")
    axes[1].legend()
    milli = 1e3  # N m -> mN m
    axes[2].plot(t, result.drag_torque * milli, label="drag")
    axes[2].plot(t, result.nut_torque[:, 0] * milli, label="master nut")
    axes[2].plot(t, result.nut_torque[:, 1] * milli, label="slave nut")
    axes[2].set_ylabel("torque [mN m]")
    axes[2].set_xlabel("time [s]")
    axes[2].legend()
    bound = selection.bounds.get("drag_torque")
    bound_text = "n/a" if bound is None else f"{bound:.2g}"
    fig.suptitle(f"{selection.scene.name}: {selection.model} (drag error bound {bound_text})")
    fig.tight_layout()
    save_png(fig, path, dpi=100)


def _extreme_points(scene: Scene) -> list[OperatingPoint]:
    """The scene's highest |speed|, preload and |axial load| at its lowest and highest
    temperature: inside the validity envelope if and only if the whole profile is."""
    speed = scene.speed_magnitude_range()[1]
    preload = scene.range("preload")[1]
    load = max(abs(v) for v in scene.range("axial_load"))
    return [
        OperatingPoint(screw_speed=speed, temperature=t, preload=preload, axial_load=load)
        for t in scene.range("temperature")
    ]


def run(args: argparse.Namespace) -> int:
    """``scene``: select, report, run, write; a scene leaving the validity envelope is
    refused (docs/model.md section 13)."""
    scene = load_scene(args.scene)
    config = scene_config(scene)
    refuse_outside(_extreme_points(scene), ValidityEnvelope.for_config(config), scene.source)
    # Sphere indices of the faults against this parameter set's sphere count.
    faults_from_mapping(scene.faults_mapping, config.screw.balls_per_nut, f"{scene.source}: faults")
    bounds = load_bounds(args.bounds)
    selection = select(scene, bounds, config)
    print(selection.report())
    out = Path(args.out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise BallscrewTwinError(f"{out}: cannot create output folder ({err.strerror})") from err
    document = selection.to_dict()
    if not args.select_only:
        result = run_selection(selection, config, bounds, quiet=args.quiet)
        write_csv(result, out / "timeseries.csv")
        write_npz(result, out / "result.npz")
        plot(result, selection, out / "scene.png")
        document["run"] = result.stats
        stats = result.stats
        print(
            f"ran {stats['samples']} samples in {stats['wall_time_s']:.3g} s "
            f"(real-time factor {stats['real_time_factor']:.3g}); "
            + ", ".join(
                f"{k} {v}"
                for k, v in stats.items()
                if k not in ("samples", "wall_time_s", "real_time_factor", "model")
            )
        )
    (out / "selection.json").write_text(json.dumps(document, indent=2) + "\n", encoding="utf-8")
    print(f"outputs in {out}")
    return 0
