"""Timing for benchmarks (printed, never asserted)."""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable


def median_time(
    func: Callable[[], object],
    repeat: int,
    warmup: int = 0,
    clock: Callable[[], float] = time.perf_counter,
) -> float:
    """Median time of ``func()`` over ``repeat`` calls after ``warmup`` untimed ones [s], on
    ``clock`` (default: wall time)."""
    for _ in range(warmup):
        func()
    times = []
    for _ in range(repeat):
        start = clock()
        func()
        times.append(clock() - start)
    return statistics.median(times)


def cpu_time(func: Callable[[], object], repeat: int, warmup: int = 0) -> float:
    """Median CPU time of this process per call of ``func()`` [s]: unlike the wall time it does
    not grow when other programs share the cores (the models are single-threaded)."""
    return median_time(func, repeat, warmup, clock=time.process_time)
