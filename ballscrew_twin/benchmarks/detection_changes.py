"""Which runs a compared monitor of ``bench detection`` judges otherwise than the default.

With ``--compare-setting`` every monitor runs over the same recordings, so their runs pair up
one to one. The headline tables sum each monitor's runs up and can hide a swap (one run made
right, another made wrong: the same counts); :func:`changes_report` lists every pair whose
outcome, alarm time or class differs, so that whether a setting may become the default can be
read run by run ("no false alarm the default does not raise, no class wrong that the default
names right"). Times in s.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .detection import Run

#: Alarm times that differ by less than this count as the same alarm [s].
SAME_ALARM = 1e-6
#: Outcomes that are a false alarm: on a healthy recording, or before a fault's onset.
FALSE_ALARMS = ("false alarm", "early")


def outcome(run: Run) -> str:
    """What the monitor made of one run: for a healthy recording "quiet" or "false alarm"; for
    a fault run "missed" (no alarm), "early" (an alarm before the onset), "right" (the true
    class named), "unclassified" or "wrong"."""
    if not run.true_class:
        return "quiet" if math.isnan(run.alarm) else "false alarm"
    if math.isnan(run.alarm):
        return "missed"
    if run.alarm < run.onset:
        return "early"
    if run.fault_class == run.true_class:
        return "right"
    return "wrong" if run.fault_class else "unclassified"


def _same(a: Run, b: Run) -> bool:
    alarms_equal = (math.isnan(a.alarm) and math.isnan(b.alarm)) or abs(
        a.alarm - b.alarm
    ) < SAME_ALARM
    return alarms_equal and a.fault_class == b.fault_class


def changed_runs(default: Sequence[Run], other: Sequence[Run]) -> list[tuple[Run, Run]]:
    """The pairs (default's run, other's run) of the same recording whose alarm time or named
    class differ; ValueError when the two lists are not runs of the same recordings."""
    if len(default) != len(other):
        raise ValueError(f"{len(default)} runs against {len(other)}: not the same recordings")
    pairs = []
    for a, b in zip(default, other, strict=True):
        if (a.unit, a.seed, a.true_class, a.severity) != (b.unit, b.seed, b.true_class, b.severity):
            raise ValueError(f"unit {a.unit} seed {a.seed} paired with unit {b.unit} seed {b.seed}")
        if not _same(a, b):
            pairs.append((a, b))
    return pairs


def _alarm(run: Run) -> str:
    if math.isnan(run.alarm):
        return "none"
    if run.true_class:
        return f"{run.alarm - run.onset:+.2f}"
    return f"at {run.alarm:.1f}"


def _named(run: Run) -> str:
    if math.isnan(run.alarm):
        return "-"
    return f"{run.fault_class or 'unclassified'} ({run.confidence:.2f})"


def changes_report(default: Sequence[Run], other: Sequence[Run]) -> str:
    """Markdown: how many runs each change of outcome moved (default -> compared: "made right"
    where a fault run became right, "made wrong" where a right one did not stay right, false
    alarms new and gone: on a healthy recording or before a fault's onset, :data:`FALSE_ALARMS`),
    and a table of every changed run (alarm time after the onset, or since the
    start for a healthy recording, and the class named with its confidence)."""
    pairs = changed_runs(default, other)
    if not pairs:
        return "Runs judged otherwise than by the default: none (same alarms, same classes)."
    moves = Counter((outcome(a), outcome(b)) for a, b in pairs)
    right = sum(n for (was, now), n in moves.items() if now == "right" and was != "right")
    wrong = sum(n for (was, now), n in moves.items() if was == "right" and now != "right")
    new = sum(
        n for (was, now), n in moves.items() if now in FALSE_ALARMS and was not in FALSE_ALARMS
    )
    gone = sum(
        n for (was, now), n in moves.items() if was in FALSE_ALARMS and now not in FALSE_ALARMS
    )
    lines = [
        f"Runs judged otherwise than by the default: {len(pairs)}; made right {right}, "
        f"made wrong {wrong}, new false alarms {new} (gone {gone}; healthy recordings and "
        "alarms before a fault's onset).",
        "",
        "| unit | true class | severity | alarm, default [s] | alarm, compared [s] "
        "| named, default | named, compared | outcome |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for a, b in pairs:
        lines.append(
            f"| {a.unit} | {a.true_class or 'healthy'} | {a.severity:g} | {_alarm(a)} "
            f"| {_alarm(b)} | {_named(a)} | {_named(b)} | {outcome(a)} -> {outcome(b)} |"
        )
    return "\n".join(lines)
