"""The twin node's ``/diagnostics`` checks, built from its counters (no rclpy here).

One :class:`~ballscrew_twin.ros.diagnostics.Check` per concern: the model in use and why, real
time (late and skipped ticks, latency, clock jumps), each input (stale, rejected) and the
validity notes of the last model output. ``ros/diagnostics.py`` turns them into a message.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .diagnostics import OK, STALE, WARN, Check
from .fidelity_modes import ModelChoice
from .inputs import InputChannel
from .tick_counts import TickTotals, TickWindow

#: Substrings of model notes that are validity warnings (outside the validated envelope).
VALIDITY_WORDS = ("validity:", "outside", "clamped", "blended", "failed", "not converged")


def model_check(
    choice: ModelChoice, *, requested: str, switches: int, failures: int, w: TickWindow
) -> Check:
    """The model in use and why; WARN when steps of it failed in the window ``w``.

    Args:
        choice: the model in use.
        requested: value of the ``fidelity`` parameter.
        switches: model switches since start-up [-].
        failures: failed steps since start-up [-].
        w: the window's tick counters.
    """
    level = WARN if w.failures else OK
    message = f"{choice.model.name}: {choice.reason}"
    if w.failures:
        message += f"; {w.failures} failed steps replaced by the catalogue model"
    return Check(
        "model",
        level,
        message,
        (
            ("fidelity parameter", requested),
            ("model", choice.model.name),
            ("mode", choice.mode),
            ("why", choice.reason),
            ("switches", str(switches)),
            ("failed steps (window / total)", f"{w.failures} / {failures}"),
        ),
    )


def real_time_check(
    w: TickWindow,
    elapsed: float,
    totals: TickTotals,
    *,
    sim_rate: float,
    period: float,
    min_on_time_share: float,
    use_sim_time: bool,
    tick_source: str,
) -> Check:
    """Whether the ticks of the window ``w`` kept up with the clock.

    WARN when ticks were skipped or fewer than ``min_on_time_share`` were on time; STALE when
    none was due (the clock does not advance).

    Args:
        w: the window's tick counters.
        elapsed: length of the window on the node's clock [s].
        totals: counters since start-up.
        sim_rate: simulation rate [Hz].
        period: simulation step [s].
        min_on_time_share: share of ticks on time below which WARN [-].
        use_sim_time: whether the node follows ``/clock``.
        tick_source: what runs the ticks (thread or executor timer).
    """
    due = w.ticks + w.skipped
    on_time = (w.ticks - w.late) / due if due else 1.0
    mean_step = w.mean_step_time
    rtf = period / mean_step if mean_step > 0.0 else math.inf
    lat = np.asarray(w.latencies_ns, dtype=np.float64) * 1e-6
    p50, p99, pmax = (
        (float(np.percentile(lat, 50)), float(np.percentile(lat, 99)), float(lat.max()))
        if lat.size
        else (0.0, 0.0, 0.0)
    )
    level = OK
    message = f"{on_time:.2%} of ticks on time, real-time factor {rtf:.3g}"
    if w.skipped or on_time < min_on_time_share:
        level = WARN
        message += f"; {w.late} late (> 1 ms), {w.skipped} skipped"
    if due == 0:
        level, message = STALE, "no tick in this window (clock not advancing?)"
    return Check(
        "real time",
        level,
        message,
        (
            ("simulation rate [Hz]", f"{sim_rate:g}"),
            ("use_sim_time", str(use_sim_time)),
            ("ticks run by", tick_source),
            ("tick errors (total)", str(totals.tick_errors)),
            ("ticks published (window)", str(w.ticks)),
            ("simulated / clock time [-]", f"{w.ticks * period / elapsed:.4f}"),
            ("on time within 1 ms [-]", f"{on_time:.5f}"),
            ("late ticks (window / total)", f"{w.late} / {totals.late}"),
            ("skipped ticks (window / total)", f"{w.skipped} / {totals.skipped}"),
            ("skipped ticks at start-up", str(totals.startup_skipped)),
            ("on time share below which WARN [-]", f"{min_on_time_share:g}"),
            ("latency p50 / p99 / max [ms]", f"{p50:.3f} / {p99:.3f} / {pmax:.3f}"),
            ("model step mean / max [ms]", f"{mean_step * 1e3:.4f} / {w.step_time_max * 1e3:.4f}"),
            ("real-time factor (step / compute) [-]", f"{rtf:.4g}"),
            (
                "clock jumps back / forward",
                f"{totals.clock_jumps_back} / {totals.clock_jumps_forward}",
            ),
        ),
    )


def input_check(
    c: InputChannel, now_ns: int, *, stale_after: float, elapsed: float, optional: bool
) -> Check:
    """The state of one input: fresh, stale or never received, and the messages it rejected
    in the window (which this call closes, see :meth:`InputChannel.window_counts`).

    Args:
        c: the input.
        now_ns: the node's clock [ns].
        stale_after: an input silent for longer is stale [s].
        elapsed: length of the window [s].
        optional: an input that need not be commanded (no warning before its first message).
    """
    age = c.age(now_ns)
    level, message = OK, f"{c.value:g} {c.unit}"
    if age is None:
        if optional:
            message += " (not commanded)"
        else:
            level = WARN
            message = f"no message yet: using the initial {c.value:g} {c.unit}"
    elif age > stale_after:
        level = WARN
        message = f"stale: no message for {age:.3g} s, holding {c.value:g} {c.unit}"
    window_rejections, received = c.window_counts()
    if window_rejections:
        level = max(level, WARN)
        message += f"; {window_rejections} rejected, last: {c.last_rejection}"
    return Check(
        f"input {c.name}",
        level,
        message,
        (
            ("value", f"{c.value:g} {c.unit}"),
            ("age [s]", "never" if age is None else f"{age:.3f}"),
            ("messages per second", f"{received / elapsed:.1f}"),
            ("accepted", str(c.accepted)),
            ("rejected", str(c.rejected)),
            ("last rejection", c.last_rejection),
        ),
    )


def validity_check(notes: Sequence[str]) -> Check:
    """WARN when a note of the last model output says it left the validated envelope."""
    warnings = [n for n in notes if any(w in n.lower() for w in VALIDITY_WORDS)]
    level = WARN if warnings else OK
    message = "; ".join(warnings) if warnings else "within the model's envelope"
    return Check("validity", level, message, tuple((f"note {i}", n) for i, n in enumerate(notes)))
