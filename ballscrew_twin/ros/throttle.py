"""At most one log line per key and interval, on the steady clock (no rclpy here)."""

from __future__ import annotations

import math
import time
from collections.abc import Callable


class Throttle:
    """Lets one event per key through at most once per ``interval`` [s] of ``clock`` [s]
    (by default the monotonic clock)."""

    def __init__(self, interval: float, clock: Callable[[], float] = time.monotonic) -> None:
        self.interval = interval
        self._clock = clock
        self._last: dict[str, float] = {}

    def allows(self, key: str) -> bool:
        """Whether an event of ``key`` may pass now (it is then counted as passed)."""
        now = self._clock()
        if now - self._last.get(key, -math.inf) < self.interval:
            return False
        self._last[key] = now
        return True
