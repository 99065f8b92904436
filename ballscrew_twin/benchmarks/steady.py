"""``ballscrew-twin bench steady``: cost of the steady-state model, printed, never asserted.

Times, on this machine and in one run so that the numbers compare: one evaluation of all
contact laws for 2 and 50 spheres by the numpy reference and by the numba kernel, and for each
mode (symmetric: one sphere per nut; full: all 50) and each solver, the structured compiled
solver (``backend="compiled"``, the package's) beside the previous one (``backend="newton"``:
the readable Newton over the compiled contact laws):

- cold: ``solve`` with no warm start (the start-up path from 1 rpm, docs/model.md "One
  branch"; the model's kept start-up path dropped too, which a repeated cold solve of the
  same point would otherwise resume at its last step);
- warm: ``solve`` at 20 C / 100 rpm / 1500 N and 21 C / 110 rpm / 1550 N alternately, each
  warm-started from the other, with all outputs (torques, per-contact states); per solve. The
  structured solver extrapolates its warm start from its last two solutions, which here are
  the point itself and the other one: its start is then the point's own earlier solution, so
  this task measures a repeated solve, and the next one a new point each time;
- warm path: ``solve`` along a path of new points (:func:`path_point`: speed, temperature and
  preload as slow sines of incommensurate periods around the two points above, steps of up to
  1 rpm, 0.07 K and 17 N), each warm-started from the one before, with all outputs; per solve.
  The package's model returns the start-up state at every point (``branch="start-up"``), so a
  point of another temperature or preload is solved cold; the structured solver is also timed
  with ``branch="path"`` (a warm solve keeps its start's state while it moves continuously);
- warm Newton: the Newton solve alone from the other point's state (no outputs assembled).

With ``--baseline DIR``, the structured solver of another checkout of the package (DIR holds its
``ballscrew_twin`` folder, e.g. the main branch before a change) is timed beside both, in the same
run, imported under another name (:func:`baseline_model`).

With ``--agreement N``, also the drag torque of both solvers at N random points of the envelope
(symmetric mode), each solved cold and along a warm-started path through all of them: which
agree to 1e-9 relative and where they differ.

Median CPU time of this process (``time.process_time``), the solvers interleaved round by round
so that a change of the machine's load hits both alike. In each round a solver makes ``--burst``
consecutive calls of a warm task (default 5), each timed: a call made right after another
solver's finds the caches filled by that one (measured: a symmetric warm solve of 55 us takes
134 us right after a solve of the previous solver), which a caller solving point after point
does not see.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import itertools
import math
import statistics
import sys
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any, Literal

import numpy as np

from ..errors import SolverError
from ..kernels.contacts import evaluate_contacts_compiled
from ..models.base import OperatingPoint
from ..models.contact_forces import evaluate_contacts, make_scene
from ..models.steady import SteadyStateModel
from ..params import TwinConfig, default_config_path, load_config
from ..timing import cpu_time
from ..units import CELSIUS_ZERO, RPM

#: One-line help of this benchmark.
DESCRIPTION = "cost of the steady-state model (contact laws, cold and warm solves, both solvers)"

SOLVERS = (("previous", "newton"), ("structured", "compiled"))
#: Label of the structured solver with ``branch="path"`` (warm solves keep their start's state).
PATH_BRANCH = "path-branch"
Mode = Literal["symmetric", "full"]
TASKS = ("cold", "warm", "warm path", "warm Newton")


def path_point(k: int) -> OperatingPoint:
    """Point ``k`` of the warm path: 105 +- 5 rpm, 20.5 +- 0.5 C and 1500 +- 50 N as sines of
    periods 10 pi, 14 pi and 6 pi points."""
    return OperatingPoint(
        screw_speed=(105.0 + 5.0 * math.sin(k / 5.0)) * RPM,
        temperature=20.5 + 0.5 * math.sin(k / 7.0) + CELSIUS_ZERO,
        preload=1500.0 + 50.0 * math.sin(k / 3.0),
    )


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``bench steady``."""
    parser.add_argument("--config", default=None, help="parameter YAML (default: paper screw)")
    parser.add_argument("--repeat", type=int, default=20, help="repetitions of each timing")
    parser.add_argument(
        "--burst",
        type=int,
        default=5,
        help="consecutive calls of a warm task per solver and round, each timed (1: every call "
        "right after another solver's, on caches that solver has filled)",
    )
    parser.add_argument(
        "--baseline",
        default=None,
        metavar="DIR",
        help="also time the structured solver of the package in DIR/ballscrew_twin (another "
        "checkout, e.g. before a change), interleaved with the others",
    )
    parser.add_argument(
        "--agreement",
        type=int,
        default=0,
        metavar="N",
        help="also compare both solvers' drag torque at N random points (symmetric mode), cold "
        "and along a warm-started path through them (default 0: skip)",
    )


def _contact_line(config: TwinConfig, mode: Mode, point: OperatingPoint, repeat: int) -> str:
    model = SteadyStateModel(config, mode=mode)
    solution = model.solve(point)
    state, balls = solution.state, solution.balls
    scene = make_scene(config, point.temperature, point.screw_speed)
    arguments = (scene, state.ball_nb, state.kinematics, state.nut_offset[balls.nut], balls.gravity)
    reference = cpu_time(partial(evaluate_contacts, *arguments), repeat)
    compiled = cpu_time(partial(evaluate_contacts_compiled, *arguments), repeat)
    return (
        f"  {mode:<9} {len(balls.nut):3d} spheres: contact laws numpy {reference * 1e6:8.1f} us, "
        f"numba {compiled * 1e6:7.1f} us"
    )


def _tasks(
    model: SteadyStateModel, point: OperatingPoint, nearby: OperatingPoint
) -> dict[str, Callable[[], object]]:
    """The timed tasks of one solver: name -> callable (one solve each)."""
    states = []
    for op in (point, nearby):
        model.forget_warm_start()
        states.append(model.solve(op).state)
    flip = [point, nearby]

    def cold() -> None:
        model.forget_warm_start()
        model.forget_startup_path()  # else the path of the last cold solve is resumed
        model.solve(point)

    def warm() -> None:
        flip.reverse()
        model.solve(flip[0])

    path = itertools.count()

    def warm_path() -> None:
        model.solve(path_point(next(path)))

    def newton() -> None:
        flip.reverse()
        target = flip[0]
        scene = model.scene(target.temperature, target.screw_speed)
        balls = model.ball_set(model.resolved_mode())
        other = states[1] if target is point else states[0]
        start = model._rescaled(other, scene, balls, target.screw_speed)
        model._newton(scene, balls, start, model.nut_axial_loads(target), warm=True)

    return {"cold": cold, "warm": warm, "warm path": warm_path, "warm Newton": newton}


BASELINE_PACKAGE = "ballscrew_twin_baseline"


def baseline_model(directory: str, config_path: str, mode: Mode) -> Any:
    """A ``SteadyStateModel`` (default backend) of the package in ``directory``/ballscrew_twin,
    imported as :data:`BASELINE_PACKAGE` (its modules import each other relatively), with its
    own parameters read from the parameter file ``config_path``."""
    root = (Path(directory) / "ballscrew_twin").resolve()
    if not (root / "__init__.py").is_file():
        raise SystemExit(f"--baseline {directory}: no ballscrew_twin package there")
    loaded = sys.modules.get(BASELINE_PACKAGE)
    if loaded is None:
        spec = importlib.util.spec_from_file_location(
            BASELINE_PACKAGE, root / "__init__.py", submodule_search_locations=[str(root)]
        )
        assert spec is not None and spec.loader is not None  # a file location gives both
        package = importlib.util.module_from_spec(spec)
        sys.modules[BASELINE_PACKAGE] = package
        spec.loader.exec_module(package)
    elif Path(str(loaded.__file__)).parent != root:
        raise SystemExit(f"--baseline {directory}: another baseline is loaded in this process")
    params = importlib.import_module(f"{BASELINE_PACKAGE}.params")
    steady = importlib.import_module(f"{BASELINE_PACKAGE}.models.steady")
    return steady.SteadyStateModel(params.load_config(config_path), mode=mode)


def _solver_lines(
    config: TwinConfig,
    mode: Mode,
    point: OperatingPoint,
    nearby: OperatingPoint,
    repeat: int,
    burst: int,
    baseline: Any = None,
) -> list[str]:
    """Cold, warm and warm-Newton times of the solvers (and of ``baseline``, a model of another
    checkout, when given), interleaved round by round; in each round every solver makes
    ``burst`` consecutive calls of a warm task, each timed (one of a cold task)."""
    models = {name: SteadyStateModel(config, mode=mode, backend=b) for name, b in SOLVERS}  # type: ignore[arg-type]
    models[PATH_BRANCH] = SteadyStateModel(config, mode=mode, branch="path")
    if baseline is not None:
        models = {SOLVERS[0][0]: models[SOLVERS[0][0]], "baseline": baseline, **models}
    tasks = {name: _tasks(model, point, nearby) for name, model in models.items()}
    times: dict[tuple[str, str], list[float]] = {}
    for task in TASKS:
        rounds = max(repeat // 4, 3) if task == "cold" else repeat
        for name in models:  # warm-up: compilation, caches, the first warm start
            tasks[name][task]()
            tasks[name][task]()
        for _ in range(rounds):
            for name in models:
                for _ in range(1 if task == "cold" else burst):
                    start = time.process_time()
                    tasks[name][task]()
                    times.setdefault((name, task), []).append(time.process_time() - start)
    lines = []
    for name in models:
        cells = [f"{task} {statistics.median(times[(name, task)]) * 1e6:8.0f} us" for task in TASKS]
        lines.append(f"  {mode:<9} {name:<10} solver: " + ", ".join(cells))
    new_name = SOLVERS[-1][0]  # the package's model
    for task in TASKS[:3]:
        new = statistics.median(times[(new_name, task)])
        ratios = [
            f"x{statistics.median(times[(name, task)]) / new:.1f} faster than the {name}"
            for name in models
            if name != new_name
        ]
        lines.append(f"  {mode:<9} {task}: the structured solver " + ", ".join(ratios))
    return lines


def _random_points(count: int, seed: int = 0) -> list[OperatingPoint]:
    """Uniform over -6000..6000 rpm, -40..100 C and 0..5000 N preload (every third point at
    0..200 N), an axial load of -1000..1000 N on every fourth."""
    rng = np.random.default_rng(seed)
    points = []
    for k in range(count):
        preload = rng.uniform(0.0, 200.0) if k % 3 == 0 else rng.uniform(0.0, 5000.0)
        points.append(
            OperatingPoint(
                screw_speed=rng.uniform(-6000.0, 6000.0) * RPM,
                temperature=rng.uniform(-40.0, 100.0) + CELSIUS_ZERO,
                preload=preload,
                axial_load=rng.uniform(-1000.0, 1000.0) if k % 4 == 0 else 0.0,
            )
        )
    return points


def _drags(config: TwinConfig, backend: str, points: list[OperatingPoint], warm: bool) -> list:
    """Drag torque [N m] at each point (None where the solve fails), cold or warm-started."""
    model = SteadyStateModel(config, mode="symmetric", backend=backend)  # type: ignore[arg-type]
    drags: list[float | None] = []
    for point in points:
        if not warm:
            model.forget_warm_start()
        try:
            drags.append(model.solve(point).output.drag_torque)
        except SolverError:
            drags.append(None)
    return drags


def _agreement_lines(config: TwinConfig, count: int) -> list[str]:
    """Relative drag difference of the structured solver from the previous one."""
    points = _random_points(count)
    lines = []
    for warm in (False, True):
        old, new = (_drags(config, backend, points, warm) for _, backend in SOLVERS)
        differ = []
        for point, a, b in zip(points, old, new, strict=True):
            if a is not None and b is not None and abs(b - a) > 1e-9 * abs(a):
                differ.append((abs(b - a) / abs(a), point))
        agree = sum(1 for a, b in zip(old, new, strict=True) if a is not None and b is not None)
        one_only = sum(1 for a, b in zip(old, new, strict=True) if (a is None) != (b is None))
        lines.append(
            f"  {'warm path' if warm else 'cold'}: {count} points, {agree} solved by both, "
            f"{agree - len(differ)} equal to 1e-9, {one_only} solved by one solver only"
        )
        for rel, p in sorted(differ, key=lambda item: item[0]):
            lines.append(
                f"    differ {rel:.2g}: {p.screw_speed / RPM:.0f} rpm, "
                f"{p.temperature - CELSIUS_ZERO:.1f} C, preload {p.preload:.1f} N, "
                f"axial load {p.axial_load:.0f} N"
            )
    return lines


def run(args: argparse.Namespace) -> int:
    """Print the timings (median of ``--repeat`` runs)."""
    config = load_config(args.config)
    point = OperatingPoint(screw_speed=100 * RPM, temperature=20 + CELSIUS_ZERO, preload=1500.0)
    nearby = OperatingPoint(screw_speed=110 * RPM, temperature=21 + CELSIUS_ZERO, preload=1550.0)
    print(
        f"steady-state model cost, median CPU time of {args.repeat} runs, "
        "20 C / 100 rpm / 1500 N <-> 21 C / 110 rpm / 1550 N"
    )
    for mode in ("symmetric", "full"):
        print(_contact_line(config, mode, point, args.repeat))
    for mode in ("symmetric", "full"):
        baseline = None
        if args.baseline is not None:
            source = args.config if args.config is not None else str(default_config_path())
            baseline = baseline_model(args.baseline, source, mode)  # type: ignore[arg-type]
        lines = _solver_lines(config, mode, point, nearby, args.repeat, args.burst, baseline)  # type: ignore[arg-type]
        for line in lines:
            print(line)
    print(
        f"  numpy {np.__version__}; goals of issue 14: warm <= 300 us full (50 spheres), "
        "<= 30 us symmetric, cold <= 3 ms (stretch 100 us / 10 us)"
    )
    if args.agreement > 0:
        print("drag torque of the structured solver against the previous one (symmetric mode)")
        for line in _agreement_lines(config, args.agreement):
            print(line)
    return 0
