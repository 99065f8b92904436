"""The health node's live behaviour: verdict/class log lines, ``~/rearm``, the /clock watchdog
under use_sim_time, and JointStates that do not name the screw's joint."""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, cast

import pytest
from ballscrew_twin_msgs.msg import HealthResidual
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger

from ballscrew_twin.bags.bench import read_bench_bag
from ballscrew_twin.errors import ConfigError
from ballscrew_twin.health import monitor as monitor_module
from ballscrew_twin.health.baseline import Baseline
from ballscrew_twin.health.classify import Classification
from ballscrew_twin.health.offline import CHANNELS, recording_channels
from ballscrew_twin.health.verdicts import FAULT, OK, UNKNOWN, WARN, Alarm, HealthSample
from ballscrew_twin.models import friction_response
from ballscrew_twin.params import load_config
from ballscrew_twin.ros import diagnostics, health_node
from ballscrew_twin.ros.health_node import HealthNode

from .conftest import SpinUntil

SAMPLES = Path(__file__).resolve().parents[2] / "data" / "samples"


# ---------------------------------------------------------------------------------------------
# Log lines


class FakeTime:
    """Stands in for the ``time`` module of health_node: a steady clock the test sets [s]."""

    def __init__(self) -> None:
        self.now = 100.0

    def monotonic(self) -> float:
        return self.now


class FakeLogger:
    """Records (severity, text) instead of logging."""

    def __init__(self) -> None:
        self.lines: list[tuple[str, str]] = []

    def info(self, text: str) -> None:
        self.lines.append(("info", text))

    def warning(self, text: str) -> None:
        self.lines.append(("warning", text))

    def error(self, text: str) -> None:
        self.lines.append(("error", text))


@dataclass(frozen=True)
class State:
    """What the node's log reads of a block result."""

    verdict: int
    fault_class: str = ""
    time: float = 0.0
    confidence: float = 0.0
    note: str = ""


def test_verdict_and_class_are_logged_when_they_change_throttled(
    executor: SingleThreadedExecutor, monkeypatch: pytest.MonkeyPatch
) -> None:
    clock = FakeTime()
    monkeypatch.setattr(health_node, "time", clock)
    node = HealthNode(
        context=executor.context, parameter_overrides=[Parameter("log_throttle", value=1.0)]
    )
    logger = FakeLogger()
    monkeypatch.setattr(node, "get_logger", lambda: logger)

    def step(at: float, state: State) -> list[tuple[str, str]]:
        clock.now = at
        before = len(logger.lines)
        node._log_change(cast(HealthSample, state))
        return logger.lines[before:]

    def tick(at: float) -> list[tuple[str, str]]:
        clock.now = at
        before = len(logger.lines)
        node._watchdog()
        return logger.lines[before:]

    assert step(100.0, State(UNKNOWN, note="warm-up")) == [("info", "UNKNOWN at 0.000 s (warm-up)")]
    assert step(100.1, State(UNKNOWN, note="warm-up")) == []  # no change
    assert step(100.2, State(OK, time=5.0)) == []  # a change within the throttle: held
    assert step(100.3, State(WARN, time=5.1, note="cusum at 60% of its threshold")) == []
    assert tick(100.9) == []
    assert tick(101.1) == [("warning", "WARN at 5.100 s (cusum at 60% of its threshold)")]
    assert step(101.2, State(OK, time=6.0)) == []
    assert step(101.3, State(WARN, time=6.1)) == []  # back to what was logged: nothing to add
    assert tick(102.5) == []
    alarm = Alarm(7.25, "cusum", 7.0, Classification("jam_onset", 0.6, {}, {}))
    node.monitor.alarm = alarm
    # a new alarm is logged at once, throttle or not
    assert step(102.6, State(FAULT, "jam_onset", 7.3, 0.6)) == [
        ("error", "FAULT at 7.250 s by cusum: likely jam_onset (confidence 0.60, block at 7.300 s)")
    ]
    assert step(102.7, State(FAULT, "preload_loss", 7.4, 0.8)) == []
    assert step(102.8, State(FAULT, "jam_onset", 7.5, 0.7)) == []  # flapped back: nothing new
    assert step(102.9, State(FAULT, "preload_loss", 7.6, 0.9)) == []
    assert tick(103.7) == [
        ("error", "FAULT: likely preload_loss (confidence 0.90, block at 7.600 s)")
    ]
    assert tick(105.0) == []


# ---------------------------------------------------------------------------------------------
# ~/rearm


def _first_alarm_time(monitor: monitor_module.HealthMonitor, channels: Any) -> float:
    monitor_module.feed(monitor, channels)
    assert monitor.alarm is not None
    return monitor.alarm.time


def test_rearm_clears_the_alarm_and_starts_a_fresh_monitor(
    executor: SingleThreadedExecutor, spin_until: SpinUntil
) -> None:
    node = HealthNode(context=executor.context)
    executor.add_node(node)
    channels = recording_channels(read_bench_bag(SAMPLES / "preload_loss", required=CHANNELS))
    first = _first_alarm_time(node.monitor, channels)
    alarm = node.monitor.alarm
    assert alarm is not None
    blocks = len(node.monitor.samples)
    old = node.monitor

    client_node = Node("operator", context=executor.context)
    executor.add_node(client_node)
    client = client_node.create_client(Trigger, "/ballscrew_health/rearm")
    assert spin_until(executor, client.service_is_ready)
    future = client.call_async(Trigger.Request())
    assert spin_until(executor, future.done)
    answer = future.result()
    assert answer is not None and answer.success
    c = alarm.classification
    assert answer.message.startswith(
        f"cleared FAULT {c.fault_class} (confidence {c.confidence:.2f}) raised at "
        f"{alarm.time:.3f} s by {alarm.detector}; {blocks} block(s) forgotten"
    )
    fresh = node.monitor
    assert fresh is not old and fresh.alarm is None and not fresh.samples
    assert fresh.settings == old.settings and fresh.predictor is old.predictor
    # the fresh monitor is a new start: the same data raise the same alarm again
    assert _first_alarm_time(fresh, channels) == first
    assert node.rearm().startswith("cleared FAULT")
    assert node.rearm().startswith("no alarm to clear (last verdict: no verdict yet); 0 block(s)")


# ---------------------------------------------------------------------------------------------
# /clock watchdog


def test_stopped_clock_is_stale_on_diagnostics_and_the_health_topic(
    executor: SingleThreadedExecutor, spin_until: SpinUntil
) -> None:
    node = HealthNode(
        context=executor.context,
        parameter_overrides=[
            Parameter("use_sim_time", value=True),
            Parameter("clock_timeout", value=0.5),
            Parameter("diagnostics_rate_hz", value=10.0),
        ],
    )
    executor.add_node(node)
    listener = Node("listener", context=executor.context)
    health: list[HealthResidual] = []
    diags: list[DiagnosticArray] = []
    listener.create_subscription(HealthResidual, "health", health.append, 10)
    listener.create_subscription(DiagnosticArray, "/diagnostics", diags.append, 10)
    pub = listener.create_publisher(Clock, "/clock", 10)
    executor.add_node(listener)
    sim = [50.0]

    def advance() -> None:
        sim[0] += 0.01
        msg = Clock()
        msg.clock.sec, msg.clock.nanosec = int(sim[0]), round(sim[0] % 1 * 1e9)
        pub.publish(msg)

    def status(name: str) -> Any:
        return {s.name: s for s in diags[-1].status}.get(f"ballscrew_health: {name}")

    # never a /clock: stale
    assert spin_until(executor, lambda: node.clock.stale)
    assert "no /clock received" in node.checks()[2].message
    # a running /clock: not stale, the clock check reads the sim time
    assert spin_until(
        executor, lambda: node.clock.clock_ns > 50e9 and not node.clock.stale, every=advance
    )
    diags.clear()
    assert spin_until(
        executor,
        lambda: bool(diags) and diagnostics.level_of(status("clock")) == diagnostics.OK,
        every=advance,
    )
    shown = float(status("clock").message.removeprefix("/clock at ").removesuffix(" s"))
    assert 50.0 < shown <= sim[0]  # the sim time, not the wall time
    assert diagnostics.level_of(status("health")) == diagnostics.STALE  # no block yet
    # the clock stops: STALE on /diagnostics and one UNKNOWN on the health topic
    health.clear()
    stopped_at = sim[0]
    assert spin_until(executor, lambda: node.clock.stale)
    assert spin_until(
        executor, lambda: bool(health) and bool(diags) and status("clock") is not None
    )
    assert spin_until(executor, lambda: diagnostics.level_of(status("clock")) == diagnostics.STALE)
    assert f"/clock stopped at {stopped_at:.3f} s" in status("clock").message
    assert status("health").message.startswith("STALE: /clock stopped")
    (stale,) = health
    assert stale.verdict == UNKNOWN
    assert stale.header.stamp.sec + 1e-9 * stale.header.stamp.nanosec == pytest.approx(stopped_at)
    # it runs again
    assert spin_until(executor, lambda: not node.clock.stale, every=advance)


def test_without_sim_time_there_is_no_clock_watch(
    executor: SingleThreadedExecutor, spin_until: SpinUntil
) -> None:
    node = HealthNode(
        context=executor.context, parameter_overrides=[Parameter("clock_timeout", value=0.1)]
    )
    executor.add_node(node)
    spin_until(executor, lambda: False, timeout=0.5)  # five times the timeout
    assert not node.clock.stale
    assert [c.name for c in node.checks()] == ["health", "torque input"]


# ---------------------------------------------------------------------------------------------
# JointState without the screw's joint


def test_joint_states_must_name_the_screw_or_no_joint(
    executor: SingleThreadedExecutor, spin_until: SpinUntil
) -> None:
    node = HealthNode(context=executor.context)
    executor.add_node(node)
    bench = Node("bench", context=executor.context)
    pub = bench.create_publisher(JointState, "/bench/joint_states", 10)
    executor.add_node(bench)
    other = JointState(name=["motor"], velocity=[3.0])
    other.header.stamp.sec = 1
    assert spin_until(executor, lambda: node.dropped > 0, every=lambda: pub.publish(other))
    assert not node.monitor.aligner.speed.stamps
    unnamed = JointState(name=[], velocity=[3.0])
    unnamed.header.stamp.sec = 2
    assert spin_until(
        executor,
        lambda: bool(node.monitor.aligner.speed.stamps),
        every=lambda: pub.publish(unnamed),
    )
    assert list(node.monitor.aligner.speed.values) == [3.0]


# ---------------------------------------------------------------------------------------------
# ~/commission and baseline_file


def _feed_recording(node: HealthNode, channels: dict[str, Any]) -> None:
    """Give the node a recording's samples in stamp order, as its subscriptions would."""
    merged = sorted(
        (float(t), name, float(v))
        for name, (stamps, values) in channels.items()
        for t, v in zip(stamps, values, strict=True)
    )
    for stamp, name, value in merged:
        node._feed(name, stamp, value)


def test_commission_service_fits_the_recent_samples_and_restarts_with_the_baseline(
    executor: SingleThreadedExecutor, spin_until: SpinUntil, tmp_path: Path
) -> None:
    out = tmp_path / "live.yaml"
    node = HealthNode(
        context=executor.context,
        parameter_overrides=[
            Parameter("commission_out", value=str(out)),
            Parameter("commission_unseen_error", value=0.5),
            Parameter("commission_temperature_error", value=0.004),
            Parameter("commission_shift_extrapolation", value=12.5),
            Parameter("commission_band_reach", value=0.4),
        ],
    )
    executor.add_node(node)
    client_node = Node("operator", context=executor.context)
    executor.add_node(client_node)
    client = client_node.create_client(Trigger, "/ballscrew_health/commission")
    assert spin_until(executor, client.service_is_ready)

    future = client.call_async(Trigger.Request())
    assert spin_until(executor, future.done)
    empty = future.result()
    assert empty is not None and not empty.success and "nothing to commission" in empty.message

    channels = recording_channels(read_bench_bag(SAMPLES / "healthy", required=CHANNELS))
    _feed_recording(node, channels)
    span = float(channels["torque"][0][-1] - channels["torque"][0][0])
    before = node.monitor
    future = client.call_async(Trigger.Request())
    assert spin_until(executor, future.done)
    answer = future.result()
    assert answer is not None and answer.success, answer
    assert answer.message == f"commissioning started on {span:.1f} s of samples"
    assert node._commissioning is not None
    node._commissioning.join(timeout=120.0)
    assert node.baseline is not None and node.baseline.source == "live"
    # the node's floor of the untaught error, far above this recording's own misfit
    assert node.baseline.unseen_error == 0.5 and node.baseline.temperature_error == 0.004
    assert node.baseline.shift_extrapolation == 12.5 and node.baseline.band_reach == 0.4
    assert node.monitor is not before and node.monitor.baseline is node.baseline
    assert out.exists() and "commissioned on" in node.commission_result
    # the saved file is the node's baseline, and a node started with it uses it
    restarted = HealthNode(
        context=executor.context,
        node_name="ballscrew_health_restarted",
        parameter_overrides=[Parameter("baseline_file", value=str(out))],
    )
    try:
        assert restarted.monitor.baseline == node.baseline
    finally:
        restarted.destroy_node()


def test_a_baseline_file_that_is_not_one_stops_the_node_with_its_name(
    executor: SingleThreadedExecutor, tmp_path: Path
) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("format: 1\nconfig: x\n", encoding="utf-8")
    with pytest.raises(ConfigError, match=r"bad\.yaml"):
        HealthNode(
            context=executor.context,
            parameter_overrides=[Parameter("baseline_file", value=str(bad))],
        )


def test_a_missing_friction_response_table_is_built_and_the_monitor_moves_onto_the_map(
    executor: SingleThreadedExecutor,
    spin_until: SpinUntil,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # the paper screw without its packaged response table, and a baseline with the unit's
    # own mu_dry scale: until the table is built the map cannot take that scale, so the
    # monitor predicts with the steady model; once built, it restarts on the map
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.setattr(friction_response, "DEFAULT_RESPONSE_PATH", tmp_path / "none.npz")
    config = load_config(None)
    baseline = replace(Baseline.nominal(config), dry_friction_scale=1.2, source="bench")
    path = baseline.save(tmp_path / "baseline.yaml")
    node = HealthNode(
        context=executor.context,
        parameter_overrides=[Parameter("baseline_file", value=str(path))],
    )
    executor.add_node(node)
    assert node.monitor.twin_name != "realtime_map"
    assert "real-time map not used" in node.monitor.twin_note
    assert node._response_build is not None
    node._response_build.join(timeout=300.0)
    assert node.response_state.startswith("built in ")
    assert friction_response.cached_response_path(config).is_file()
    assert node.monitor.twin_name == "realtime_map" and node.monitor.twin_note == ""
    assert node.monitor.baseline.dry_friction_scale == 1.2
    values = dict(next(c for c in node.checks() if c.name == "health").values)
    assert values["friction response table"] == node.response_state
    # a node started now finds the table: nothing to build
    again = HealthNode(
        context=executor.context,
        node_name="ballscrew_health_again",
        parameter_overrides=[Parameter("baseline_file", value=str(path))],
    )
    assert again._response_build is None and again.response_state == "found"
    assert again.monitor.twin_name == "realtime_map"
    again.destroy_node()
    executor.remove_node(node)
    node.destroy_node()
