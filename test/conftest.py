"""Test-wide set-up: keep DDS on this machine before anything imports rclpy, and choose the
hypothesis profile.

``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` keeps discovery on loopback, and a ROS domain of
this run's own (1..100, from the PID) keeps parallel runs apart. Values the user (or the
Makefile) already set are respected. Under pytest-xdist (``make test`` runs two workers) the
first worker keeps the run's domain and every other one moves to a domain of its own in 1..100
(:func:`worker_domain`), so that the nodes of two tests running at once never discover each
other. This module is
imported by pytest in every worker before any test module, hence before rclpy is imported or
initialised.

Hypothesis: with ``CI=true`` (set by CI services and by ``.ci/run``'s callers) the ``ci`` profile
is loaded: examples derived from each test's name (derandomize) and no example database, so a
CI run is the same every time and never replays examples a previous run saved in
``.hypothesis/``. Local runs keep the default profile: fresh random examples each run, and the
failures found are saved and replayed first until fixed.

numba: under pytest-xdist the workers share the package's numba cache, and in a fresh clone each
compiles the kernels it meets first. Two workers meeting the same kernel at once would both
compile it (a minute or more of CPU each for the steady solver), so a worker compiles a cached
kernel only under an exclusive lock of that kernel (:func:`compile_one_at_a_time`): the second
waits for the first and then loads its machine code from the cache.
"""

from __future__ import annotations

import fcntl
import os
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from hypothesis import settings
from matplotlib.figure import Figure
from numba.core.caching import NullCache
from numba.core.dispatcher import Dispatcher


def worker_domain(run_domain: int, worker: str, workers: int) -> int:
    """ROS domain of xdist worker ``worker`` ("gw0", "gw1", ...) of ``workers`` in a run whose
    domain is ``run_domain`` (0..101): the first worker keeps it, worker k moves to the run's
    domain plus k x 100 // workers, wrapped into 1..100."""
    index = int(worker.removeprefix("gw"))
    if index == 0:
        return run_domain
    return (run_domain - 1 + index * (100 // max(workers, 1))) % 100 + 1


os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("ROS_DOMAIN_ID", str(os.getpid() % 100 + 1))
if "PYTEST_XDIST_WORKER" in os.environ:
    os.environ["ROS_DOMAIN_ID"] = str(
        worker_domain(
            int(os.environ["ROS_DOMAIN_ID"]),
            os.environ["PYTEST_XDIST_WORKER"],
            int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1")),
        )
    )


def compile_one_at_a_time(compile_: Callable[..., Any]) -> Callable[..., Any]:
    """``Dispatcher.compile`` that holds an exclusive file lock of the kernel (next to its
    numba cache files) while it loads or compiles, so that two processes never compile the
    same kernel at once: the later one waits and then finds the machine code in the cache.

    A kernel compiled within the compilation of another (a callee) takes its own lock; the
    callees of a kernel never call it back, so two processes never wait for each other. Locks
    this process holds already (another thread, or a recursion) are not taken again."""
    held: set[str] = set()
    guard = threading.Lock()

    def compile_locked(self: Dispatcher, sig: Any) -> Any:
        cache = self._cache
        if isinstance(cache, NullCache) or cache.cache_path is None:
            return compile_(self, sig)
        func = self.py_func
        path = str(Path(cache.cache_path) / f"{func.__module__}.{func.__qualname__}.lock")
        with guard:
            mine = path not in held
            if mine:
                held.add(path)
        if not mine:
            return compile_(self, sig)
        try:
            with open(path, "a") as lock:
                fcntl.flock(lock, fcntl.LOCK_EX)
                return compile_(self, sig)  # the lock goes with the file's closing
        finally:
            with guard:
                held.discard(path)

    return compile_locked


if "PYTEST_XDIST_WORKER" in os.environ:
    Dispatcher.compile = compile_one_at_a_time(Dispatcher.compile)  # type: ignore[method-assign]

#: Test modules that take longest (one worker, a fresh numba cache, 2026-11-27), slowest first,
#: apart from the second. The first compiles the steady solver's kernels before anything else;
#: the modules of :data:`WHILE_THE_STEADY_SOLVER_COMPILES` go after it (:func:`module_order`),
#: and then the second, test_memory.py: its first 21 s load none of the steady solver's
#: kernels, so the second worker runs them while the first still compiles, instead of waiting
#: for the kernels' lock in a module that needs them at once. test_detection.py must come well
#: after the first: its benchmark's two worker processes compile the kernels they miss each on
#: its own, outside the lock.
SLOWEST_FIRST = (
    "test/models/test_paper_claims.py",
    "test/health/test_memory.py",
    "test/ros/test_health_node_replay.py",
    "test/models/test_simulation.py",
    "test/benchmarks/test_detection.py",
    "test/benchmarks/test_node_bench.py",
    "test/health/test_commission_unit.py",
    "test/health/test_classification_window.py",
    "test/health/test_order_test.py",
    "test/health/test_detect.py",
    "test/models/test_steady_branch.py",
    "test/test_report.py",
    "test/kernels/test_steady_solver.py",
    "test/ros/test_health_node_live.py",
    "test/ros/test_tables.py",
    "test/ros/test_console_scripts.py",
)


#: Test modules that load none of the steady solver's kernels (2026-11-27: every kernel a
#: module's tests load logged, one module per process), longest first. Nearly every other
#: module needs the steady solver, whose kernels take about 95 s of CPU to compile in a fresh
#: clone: the second worker runs these while the first compiles it (for the first module of
#: :data:`SLOWEST_FIRST`) instead of waiting for its lock from the start.
WHILE_THE_STEADY_SOLVER_COMPILES = (
    "test/health/test_commission.py",
    "test/health/test_detectors.py",
    "test/ros/test_cdr.py",
    "test/health/test_correction.py",
    "test/health/test_detect_input.py",
    "test/ros/test_packaging.py",
    "test/physics/test_hertz.py",
    "test/health/test_duty_cycles.py",
    "test/ros/test_tick_thread.py",
    "test/kernels/test_map_sample_kernel.py",
    "test/ros/test_console_view.py",
    "test/models/test_registry.py",
    "test/ros/test_twin_node_adversarial.py",
    "test/physics/test_traction.py",
    "test/models/test_profile.py",
    "test/models/test_scenario.py",
    "test/health/test_tracker.py",
    "test/ros/test_twin_node_bench_inputs.py",
    "test/ros/test_scheduler.py",
    "test/physics/test_lubricant.py",
    "test/test_plot_checks.py",
    "test/kernels/test_cache_stamp.py",
    "test/ros/test_fidelity.py",
    "test/ros/test_health_diagnostics.py",
    "test/physics/test_rolling.py",
    "test/physics/test_geometry.py",
    "test/physics/test_film.py",
    "test/health/test_baseline.py",
    "test/ros/test_inputs.py",
    "test/ros/test_messages.py",
    "test/ros/test_parameters.py",
    "test/ros/test_twin_node_realtime.py",
    "test/ros/test_frame_id.py",
    "test/ros/test_parameter_tables.py",
    "test/test_module_size.py",
    "test/health/test_classify.py",
    "test/health/test_residuals.py",
    "test/health/test_sensors.py",
    "test/models/test_base.py",
    "test/models/test_catalog.py",
    "test/models/test_sphere_contact.py",
    "test/ros/test_msg_definitions.py",
    "test/ros/test_step_down.py",
    "test/ros/test_throttle.py",
    "test/ros/test_tick_counts.py",
    "test/ros/test_twin_diagnostics.py",
    "test/ros/test_twin_messages.py",
    "test/ros/test_twin_models.py",
    "test/test_conftest_order.py",
    "test/test_hypothesis_profile.py",
    "test/test_number_checks.py",
    "test/test_scene.py",
    "test/test_units.py",
    "test/test_worker_domains.py",
)


def module_order() -> tuple[str, ...]:
    """The order in which the workers get the modules named here: the slowest module (which
    compiles the steady solver), the modules that need none of it, the other slow ones."""
    return (SLOWEST_FIRST[0], *WHILE_THE_STEADY_SOLVER_COMPILES, *SLOWEST_FIRST[1:])


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Under pytest-xdist, run the modules of :func:`module_order` first, in its order (the
    others after them, in collection order; the tests of a module keep theirs). ``make test``
    runs ``--dist loadscope --no-loadscope-reorder``, which hands the modules to the workers
    in this order: the longest start first and the short ones fill the end, so that neither
    worker is left with a long module while the other has finished, and the second worker
    has work that needs no steady solver while the first compiles it."""
    if "PYTEST_XDIST_WORKER" not in os.environ:
        return
    rank = {path: index for index, path in enumerate(module_order())}
    items.sort(key=lambda item: rank.get(item.nodeid.split("::", 1)[0], len(rank)))


settings.register_profile("ci", derandomize=True, database=None, print_blob=True)
settings.load_profile("ci" if os.environ.get("CI", "").lower() == "true" else "default")


class SavedFigures:
    """Figures saved while a test runs (``Figure.savefig`` recorded), and a check of their axes.

    An axes with something drawn on it must carry a unit in brackets on its y label and on the
    x label of itself or of an axes sharing its x axis (``[-]`` for a ratio); a colour bar on
    its own label.
    """

    def __init__(self) -> None:
        self.saved: list[tuple[Figure, str]] = []

    def paths(self) -> list[str]:
        return [path for _, path in self.saved]

    def missing_units(self) -> list[str]:
        """One line per axis label without a unit: ``file: title: x|y label 'text'``."""
        problems = []
        for fig, path in self.saved:
            for ax in fig.axes:
                drawn = ax.lines or ax.collections or ax.images or ax.patches or ax.containers
                if not drawn or not ax.get_visible():
                    continue
                where = f"{path}: {ax.get_title() or fig.get_suptitle()!r}"
                colorbar = getattr(ax, "_colorbar", None)
                if colorbar is not None:
                    label = ax.get_ylabel() or ax.get_xlabel()
                    if not _has_unit(label):
                        problems.append(f"{where}: colour bar label {label!r}")
                    continue
                if not _has_unit(ax.get_ylabel()):
                    problems.append(f"{where}: y label {ax.get_ylabel()!r}")
                siblings = ax.get_shared_x_axes().get_siblings(ax)
                if not any(_has_unit(other.get_xlabel()) for other in siblings):
                    problems.append(f"{where}: x label {ax.get_xlabel()!r}")
        return problems


def _has_unit(label: str) -> bool:
    """A label names a unit: ``quantity [unit]`` with a non-empty unit."""
    opening, closing = label.rfind("["), label.rfind("]")
    return 0 <= opening < closing - 1


@pytest.fixture
def saved_figures(monkeypatch: pytest.MonkeyPatch) -> SavedFigures:
    """Record every figure saved during the test (the file is still written)."""
    record = SavedFigures()
    original = Figure.savefig

    def savefig(fig: Figure, fname: Any, *args: Any, **kwargs: Any) -> Any:
        record.saved.append((fig, str(fname)))
        return original(fig, fname, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", savefig)
    return record
