"""One log line per key and interval."""

from __future__ import annotations

from ballscrew_twin.ros.throttle import Throttle


def test_one_event_per_key_and_interval() -> None:
    now = {"t": 100.0}
    t = Throttle(1.0, clock=lambda: now["t"])
    assert t.allows("a") and t.allows("b")
    assert not t.allows("a")
    now["t"] = 100.999
    assert not t.allows("a")
    now["t"] = 101.0
    assert t.allows("a") and not t.allows("a")
