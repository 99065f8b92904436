"""Why a recording gave no comparison at all (``detect``'s UNKNOWN verdict), in one sentence.

The reasons are found from the recording itself, in the order the monitor meets them: no time
span where torque, speed, temperature and preload were all recorded; the screw at standstill
(|speed| below the monitor's ``min_speed``) over that whole span; a span no longer than the
warm-up, or the screw turning only within the warm-up. When none of these holds, the most
frequent note of the monitor's blocks is given.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence

import numpy as np

from ..bags.recording import BenchRecording
from .monitor_settings import MonitorSettings
from .verdicts import HealthSample

#: Channels the monitor needs at the same time.
NEEDED = ("torque", "speed", "temperature", "preload")


def why_nothing_compared(
    recording: BenchRecording, samples: Sequence[HealthSample], settings: MonitorSettings
) -> str:
    """The reason no block of ``recording`` was compared with the twin (times in seconds since
    the recording's start, speeds in rad/s)."""
    spans = {
        name: (float(s.time[0]), float(s.time[-1]))
        for name in NEEDED
        if (s := recording.channels.get(name)) is not None and len(s)
    }
    missing = [name for name in NEEDED if name not in spans]
    if missing:
        return f"no {', '.join(missing)} sample in the recording"
    low = max(lo for lo, _ in spans.values())
    high = min(hi for _, hi in spans.values())
    if high < low:
        listed = ", ".join(f"{name} {lo:.3f}-{hi:.3f} s" for name, (lo, hi) in spans.items())
        return f"no overlapping channels: no time has all four ({listed})"
    speed = recording.channels["speed"]
    inside = (speed.time >= low) & (speed.time <= high)
    fastest = float(np.max(np.abs(speed.value[inside]), initial=0.0))
    min_speed = settings.residual.min_speed
    if fastest < min_speed:
        return (
            f"all blocks at standstill: |speed| at most {fastest:.3g} rad/s over "
            f"{low:.3f}-{high:.3f} s, below {min_speed:g} rad/s"
        )
    if high - low <= settings.warmup:
        return (
            f"warm-up ({settings.warmup:g} s) longer than the {high - low:.3f} s where all "
            "channels overlap"
        )
    turning = speed.time[inside & (np.abs(speed.value) >= min_speed)]
    if turning[-1] < low + settings.warmup:
        return (
            f"the screw turns only within the warm-up ({settings.warmup:g} s from "
            f"{low:.3f} s; last |speed| >= {min_speed:g} rad/s at {turning[-1]:.3f} s)"
        )
    notes = Counter(s.note for s in samples if s.note)
    if not notes:
        return f"no complete block among {len(samples)}"
    note, count = notes.most_common(1)[0]
    return f"no block compared; most frequent note: {note} ({count} of {len(samples)} blocks)"
