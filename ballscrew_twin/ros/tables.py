"""The real-time table of the twin node's screw: found, or built while a preview serves.

No rclpy here: the node reads :meth:`RealTimeTables.table` for its models,
:meth:`RealTimeTables.check` for ``/diagnostics`` and polls :meth:`RealTimeTables.take_built`.

On start-up :func:`~ballscrew_twin.models.map_store.find_map` looks for a table built for the
screw's parameter set (the ``realtime_map`` file if given, the packaged table, the user cache);
a file built for other parameters is refused (fingerprint) and the reason is kept for
``/diagnostics``. Without a table, and with ``workers`` > 0, the node

1. loads or builds (in this process, about 3 s) the small preview table of the screw
   (:data:`~ballscrew_twin.models.map_grid.PREVIEW_NODES`), so that the real-time model
   serves per-sphere states from the first ticks;
2. builds the full table on a thread of its own in ``workers`` niced processes (the node's
   ticks keep their core), reporting progress to the console and to ``/diagnostics``, saves it
   in the user cache and hands it over (:meth:`take_built`); the node then switches to it.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ..errors import BallscrewTwinError, BuildCancelledError
from ..models import map_build, map_grid, map_store
from ..models.map_store import MapSearch
from ..models.steady_map import SteadyMap, load_map
from ..params import TwinConfig, config_fingerprint
from . import diagnostics

#: Share of the lines between two progress lines on the console [-].
LOG_EVERY = 0.1


@dataclass(frozen=True)
class Built:
    """A table built for the screw: where it was saved and how long it took [s]."""

    table: SteadyMap
    path: Path
    seconds: float


class RealTimeTables:
    """The real-time table of one parameter set for the node (see the module docstring).

    Args:
        config: the screw's parameter set.
        path: the node's ``realtime_map`` parameter ("" : packaged table or cache).
        workers: processes that build a missing table (0: never build).
        log: one line of progress (the node's logger), called from the build thread too.
        wanted: whether the node's model needs a table (False: nothing is searched, loaded
            or built; e.g. ``fidelity: catalog``).
    """

    def __init__(
        self,
        config: TwinConfig,
        path: str,
        workers: int,
        log: Callable[[str], None],
        wanted: bool = True,
    ) -> None:
        self.config = config
        self.workers = workers
        self._log = log
        self._lock = threading.Lock()
        self.search = map_store.find_map(config, path) if wanted else MapSearch(None, "", ())
        self._table: SteadyMap | None = self.search.table
        self.source = self.search.path
        self.preview = False
        self._progress: tuple[int, int, float] = (0, 0, 0.0)
        self._built: Built | None = None
        self._error = ""
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        for line in self.search.refused:
            log(f"real-time table refused: {line}")
        if self._table is None and workers > 0 and wanted:
            self._start_preview()
            self._thread = threading.Thread(target=self._build, name="table-build", daemon=True)
            self._thread.start()

    @property
    def table(self) -> SteadyMap | None:
        """The table the real-time model uses now (full or preview), or None."""
        return self._table

    @property
    def building(self) -> bool:
        """Whether the full table is being built."""
        return self._thread is not None and self._thread.is_alive()

    def _start_preview(self) -> None:
        """Load or build (one process) the preview table of the screw; on failure no table."""
        grid = map_grid.grid_for(self.config, preview=True)
        path = map_store.cached_map_path(self.config, grid)
        start = time.monotonic()
        try:
            fingerprint = config_fingerprint(self.config)
            cached = path.is_file() and map_store.map_fingerprint(path) == fingerprint
            table = load_map(path) if cached else None
            if table is None:
                self._log(f"no real-time table for {self.config.source}: building a preview")
                # a stopgap: folds are not followed (docs/model.md 7a, "Past a fold")
                table = map_build.build_map(self.config, grid, workers=1, follow_folds=False)
                map_store.save_atomic(table, path)
        except (BallscrewTwinError, OSError) as err:
            self._error = f"preview table: {err}"
            self._log(self._error)
            return
        self._table, self.source, self.preview = table, str(path), True
        self._log(
            f"preview table ({table.node_count} nodes) ready in {time.monotonic() - start:.1f} s:"
            " serving it while the full table is built"
        )

    def _on_progress(self, done: int, total: int, elapsed: float) -> None:
        if self._stop.is_set():
            raise BuildCancelledError
        with self._lock:
            before = self._progress[0]
            self._progress = (done, total, elapsed)
        step = max(int(total * LOG_EVERY), 1)
        if done // step != before // step or done == total:
            left = elapsed / done * (total - done)
            self._log(
                f"building the real-time table: {done / total:.0%} ({done}/{total} lines, "
                f"{elapsed:.0f} s, ~{left:.0f} s left)"
            )

    def _build(self) -> None:
        """Build thread: the full table, saved to the cache, then offered by take_built."""
        start = time.monotonic()
        grid = map_grid.grid_for(self.config)
        path = map_store.cached_map_path(self.config, grid)
        try:
            table = map_build.build_map(
                self.config,
                grid,
                workers=self.workers,
                on_progress=self._on_progress,
                niceness=map_build.WORKER_NICENESS,
            )
            map_store.save_atomic(table, path)
        except BuildCancelledError:
            return
        except Exception as err:  # a failed build must not stop the node: reported instead
            with self._lock:
                self._error = f"building the table failed: {type(err).__name__}: {err}"
            self._log(self._error)
            return
        seconds = time.monotonic() - start
        self._log(f"real-time table built in {seconds:.1f} s: {path}")
        with self._lock:
            self._built = Built(table, path, seconds)

    def take_built(self) -> Built | None:
        """The full table once built (once; it becomes :attr:`table`), else None."""
        with self._lock:
            built, self._built = self._built, None
        if built is not None:
            self._table, self.source, self.preview = built.table, str(built.path), False
        return built

    def stop(self, timeout: float = 5.0) -> None:
        """Cancel a running build (its worker processes end) and wait up to ``timeout`` [s]."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout)

    def check(self) -> diagnostics.Check:
        """The ``real-time table`` diagnostic: which table serves, build progress, refusals."""
        with self._lock:
            done, total, elapsed = self._progress
            error = self._error
        values: list[tuple[str, str]] = [("table", self.source or "none")]
        values += [(f"refused {i + 1}", line) for i, line in enumerate(self.search.refused)]
        refused = f"; {len(self.search.refused)} refused" if self.search.refused else ""
        if self.building:
            share = done / total if total else 0.0
            left = f", ~{elapsed / done * (total - done):.0f} s left" if done else ""
            values += [("build progress", f"{share:.1%} ({done}/{total} lines)")]
            values += [("build elapsed", f"{elapsed:.1f} s")]
            what = "preview table serves" if self.preview else "no table serves"
            message = f"building the table for this screw: {share:.0%}{left}; {what}{refused}"
            return diagnostics.Check("real-time table", diagnostics.WARN, message, tuple(values))
        if error:
            return diagnostics.Check(
                "real-time table", diagnostics.ERROR, error + refused, tuple(values)
            )
        if self._table is None:
            hint = (
                f"none built for this screw (`ballscrew-twin map build --config "
                f"{self.config.source}`){refused}"
            )
            return diagnostics.Check("real-time table", diagnostics.WARN, hint, tuple(values))
        if self.preview:
            message = f"preview table of this screw serves: {self.source}{refused}"
            return diagnostics.Check("real-time table", diagnostics.WARN, message, tuple(values))
        message = f"built for this screw: {self.source}{refused}"
        return diagnostics.Check("real-time table", diagnostics.OK, message, tuple(values))
