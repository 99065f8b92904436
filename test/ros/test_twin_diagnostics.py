"""The twin node's diagnostic checks from its counters, without ROS."""

from __future__ import annotations

from ballscrew_twin.models.base import QuasiStaticModel
from ballscrew_twin.models.catalog import CatalogModel
from ballscrew_twin.params import load_config
from ballscrew_twin.ros import diagnostics
from ballscrew_twin.ros.fidelity_modes import ModelChoice
from ballscrew_twin.ros.inputs import NS_PER_S, InputChannel
from ballscrew_twin.ros.tick_counts import ON_TIME_NS, TickTotals, TickWindow
from ballscrew_twin.ros.twin_diagnostics import (
    input_check,
    model_check,
    real_time_check,
    validity_check,
)

CHOICE = ModelChoice(QuasiStaticModel(CatalogModel(load_config(None))), "catalog", "requested")


def _rt(w: TickWindow, totals: TickTotals | None = None) -> diagnostics.Check:
    return real_time_check(
        w,
        1.0,
        totals or TickTotals(),
        sim_rate=100.0,
        period=0.01,
        min_on_time_share=0.98,
        use_sim_time=False,
        tick_source="thread (normal scheduling)",
    )


def test_model_check_warns_on_failed_steps() -> None:
    w = TickWindow()
    ok = model_check(CHOICE, requested="catalog", switches=0, failures=0, w=w)
    assert ok.level == diagnostics.OK and ok.message.endswith(": requested")
    w.failures = 2
    bad = model_check(CHOICE, requested="auto", switches=1, failures=5, w=w)
    assert bad.level == diagnostics.WARN and "2 failed steps" in bad.message
    assert dict(bad.values)["failed steps (window / total)"] == "2 / 5"
    assert dict(bad.values)["fidelity parameter"] == "auto"


def test_real_time_check_levels() -> None:
    w = TickWindow()
    assert _rt(w).level == diagnostics.STALE  # no tick due: the clock stands
    for i in range(100):
        w.add(1e-4, 2 * ON_TIME_NS if i < 1 else 1000)
    ok = _rt(w, TickTotals(late=7, startup_skipped=3))
    assert ok.level == diagnostics.OK and ok.message.startswith("99.00% of ticks on time")
    values = dict(ok.values)
    assert values["late ticks (window / total)"] == "1 / 7"
    assert values["skipped ticks at start-up"] == "3"
    assert values["simulated / clock time [-]"] == "1.0000"
    assert values["real-time factor (step / compute) [-]"] == "100"
    w.skipped = 1
    assert _rt(w).level == diagnostics.WARN and "1 skipped" in _rt(w).message


def test_input_check_fresh_stale_never_and_rejected() -> None:
    c = InputChannel("preload", "N", 1500.0)
    never = input_check(c, 0, stale_after=1.0, elapsed=1.0, optional=False)
    assert never.level == diagnostics.WARN and never.message.startswith("no message yet")
    optional = input_check(c, 0, stale_after=1.0, elapsed=1.0, optional=True)
    assert optional.level == diagnostics.OK and "(not commanded)" in optional.message
    c.accept(2000.0, 0)
    c.reject("too large")
    fresh = input_check(c, NS_PER_S // 2, stale_after=1.0, elapsed=2.0, optional=False)
    assert fresh.level == diagnostics.WARN and "1 rejected, last: too large" in fresh.message
    assert dict(fresh.values)["messages per second"] == "1.0"
    stale = input_check(c, 3 * NS_PER_S, stale_after=1.0, elapsed=1.0, optional=False)
    assert stale.level == diagnostics.WARN and stale.message.startswith("stale")
    assert "rejected" not in stale.message  # reported in its own window only
    assert dict(stale.values)["messages per second"] == "0.0"


def test_validity_check_warns_on_envelope_notes() -> None:
    assert validity_check(()).level == diagnostics.OK
    check = validity_check(("steady state", "validity: preload clamped to 5000 N"))
    assert check.level == diagnostics.WARN and check.message.startswith("validity:")
    assert dict(check.values)["note 0"] == "steady state"
