"""Wall-clock timing for benchmarks (printed, never asserted)."""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable


def median_time(func: Callable[[], object], repeat: int, warmup: int = 0) -> float:
    """Median wall time of ``func()`` over ``repeat`` calls after ``warmup`` untimed ones [s]."""
    for _ in range(warmup):
        func()
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        func()
        times.append(time.perf_counter() - start)
    return statistics.median(times)
