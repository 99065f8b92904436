"""The health node on loopback: a bench bag replayed into it gives the offline verdict."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from ballscrew_twin_msgs.msg import HealthResidual
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
from rclpy.exceptions import ParameterException
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data

from ballscrew_twin.bags.bench import read_bench_bag
from ballscrew_twin.bags.bench_writer import write_bench_bag
from ballscrew_twin.bags.reader import open_raw_bag
from ballscrew_twin.health.bench_data import START_NS, generate
from ballscrew_twin.health.bench_scene import bench_scene_from_mapping
from ballscrew_twin.health.monitor_settings import MonitorSettings
from ballscrew_twin.health.offline import CHANNELS, recording_channels, run_monitor, summary
from ballscrew_twin.health.residuals import shared_predictor
from ballscrew_twin.health.verdicts import FAULT
from ballscrew_twin.params import load_config
from ballscrew_twin.ros import diagnostics
from ballscrew_twin.ros.health_node import HealthNode
from ballscrew_twin.ros.replay import BagPlayer

from .conftest import SpinUntil

SPEED = 10.471975511965978  # rad/s (100 rpm)
SCENE = {
    "name": "node_test",
    "duration": 11.0,
    "seed": 3,
    "model_step": 0.5,
    "profile": [
        {"time": 0.0, "speed": SPEED, "temperature": 293.15, "preload": 1500.0},
        {"time": 11.0, "speed": SPEED, "temperature": 293.15, "preload": 1500.0},
    ],
    "sensors": {
        "torque": {"rate": 100.0, "noise": 2.0e-4, "bias": 2.0e-4, "resolution": 1.0e-5},
        "speed": {"rate": 50.0, "noise": 0.01, "ripple": 0.005, "ripple_order": 1.0},
        "temperature": {"rate": 5.0, "noise": 0.05, "drift": 0.0, "resolution": 0.01},
        "preload": {"rate": 10.0, "noise": 5.0, "bias": 0.0, "resolution": 0.5},
    },
    "faults": [{"class": "preload_loss", "onset": 7.0, "severity": 0.2, "growth": "step"}],
}


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A short bench bag: 100 rpm, 20 % preload loss at 7 s."""
    data = generate(bench_scene_from_mapping(SCENE, "test scene"))
    return write_bench_bag(data, tmp_path_factory.mktemp("bags") / "preload_step", START_NS)


class Listener(Node):
    """Records what the health node publishes."""

    def __init__(self, executor: SingleThreadedExecutor) -> None:
        super().__init__("listener", context=executor.context)
        self.health: list[HealthResidual] = []
        self.diagnostics: list[DiagnosticArray] = []
        self.create_subscription(HealthResidual, "health", self.health.append, 1000)
        self.create_subscription(DiagnosticArray, "/diagnostics", self.diagnostics.append, 10)
        executor.add_node(self)


def _stamp(msg: HealthResidual) -> float:
    return msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec


def test_replayed_bag_gives_the_offline_verdict(
    bag: Path, executor: SingleThreadedExecutor, spin_until: SpinUntil
) -> None:
    config = load_config(None)
    predictor = shared_predictor(config, MonitorSettings().residual)
    recording = read_bench_bag(bag, required=CHANNELS)
    offline = run_monitor(recording_channels(recording), config, start=0.0, predictor=predictor)
    expected = summary(offline, recording.truth)
    assert expected["verdict"] == "FAULT" and expected["fault_class"] == "preload_loss"

    node = HealthNode(
        context=executor.context,
        parameter_overrides=[Parameter("use_sim_time", value=True)],
    )
    node.monitor.predictor = predictor  # warm cache: the same values, no solver stall
    executor.add_node(node)
    listener = Listener(executor)
    player_node = Node("player", context=executor.context)
    player = BagPlayer(player_node, open_raw_bag(bag), rate=0.0)
    assert player.wait_for_subscribers(5.0, lambda: True)

    def spin_between_messages() -> bool:
        # as fast as the node takes them, whatever the machine's load: no queue overflow
        executor.spin_once(timeout_sec=0.0)
        executor.spin_once(timeout_sec=0.0)
        return True

    try:
        stats = player.play(spin_between_messages)
        sent = stats.published["/bench/torque"]
        assert spin_until(executor, lambda: node.received["torque"] == sent, timeout=30.0)
    finally:
        player_node.destroy_node()

    assert node.dropped == 0 and node.restarts == 0
    faults = [m for m in listener.health if m.verdict == FAULT]
    assert faults, "the live node raised no alarm"
    assert faults[-1].fault_class == expected["fault_class"]
    first_offline = next(s for s in offline.samples if s.verdict == FAULT)
    assert _stamp(faults[0]) == pytest.approx(first_offline.time, abs=1e-6)
    # nothing non-finite on the wire
    for m in listener.health:
        assert all(
            math.isfinite(v)
            for v in (
                m.measured,
                m.predicted,
                m.residual,
                m.normalized_residual,
                m.test_statistic,
                m.threshold,
                m.confidence,
            )
        )
    spin_until(executor, lambda: bool(listener.diagnostics), timeout=3.0)
    status = {s.name: s for s in listener.diagnostics[-1].status}
    health = status["ballscrew_health: health"]
    assert diagnostics.level_of(health) == diagnostics.ERROR
    assert "preload_loss" in health.message


def test_non_finite_samples_are_dropped_and_bad_types_rejected(
    executor: SingleThreadedExecutor, spin_until: SpinUntil
) -> None:
    with pytest.raises(ParameterException, match="torque_type"):
        HealthNode(
            context=executor.context,
            parameter_overrides=[Parameter("torque_type", value="Twist")],
        )
    with pytest.raises(ParameterException, match=r"detectors.*magic"):
        HealthNode(
            context=executor.context,
            parameter_overrides=[Parameter("detectors", value=["cusum", "magic"])],
        )
    local_only = HealthNode(
        context=executor.context, parameter_overrides=[Parameter("detectors", value=["local"])]
    )
    assert local_only.settings.detectors == ("local",)
    local_only.destroy_node()
    node = HealthNode(context=executor.context)
    executor.add_node(node)
    bench = Node("bench", context=executor.context)
    executor.add_node(bench)
    pub = bench.create_publisher(WrenchStamped, "/bench/torque", qos_profile_sensor_data)
    msg = WrenchStamped()
    msg.header.stamp.sec = 1
    msg.wrench.torque.z = math.nan
    assert spin_until(executor, lambda: node.dropped > 0, every=lambda: pub.publish(msg))
    assert node.published == 0


def test_float64_inputs_are_stamped_with_sim_time(
    executor: SingleThreadedExecutor, spin_until: SpinUntil
) -> None:
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import Temperature
    from std_msgs.msg import Float64

    from ballscrew_twin.models.base import OperatingPoint

    node = HealthNode(
        context=executor.context,
        parameter_overrides=[
            Parameter("use_sim_time", value=True),
            Parameter("torque_type", value="Float64"),
            Parameter("speed_type", value="Float64"),
            Parameter("preload_type", value="Float64"),
            Parameter("torque_topic", value="torque"),
            Parameter("speed_topic", value="speed"),
            Parameter("preload_topic", value="preload"),
            Parameter("warmup", value=0.5),
        ],
    )
    executor.add_node(node)
    listener = Listener(executor)
    bench = Node("bench", context=executor.context)
    executor.add_node(bench)
    reliable = 100
    clock = bench.create_publisher(Clock, "/clock", reliable)
    torque = bench.create_publisher(Float64, "torque", reliable)
    speed = bench.create_publisher(Float64, "speed", reliable)
    preload = bench.create_publisher(Float64, "preload", reliable)
    temperature = bench.create_publisher(Temperature, "/bench/temperature", reliable)
    assert spin_until(executor, lambda: torque.get_subscription_count() > 0)
    op = OperatingPoint(screw_speed=SPEED, temperature=293.15, preload=1500.0)
    expected = node.monitor.predictor.predict(op).at(op)
    rng = np.random.default_rng(13)
    for k in range(150):  # 1.5 s of bench time at 100 Hz, starting at 100 s
        t = 100.0 + 0.01 * k
        stamp = Clock()
        stamp.clock.sec, stamp.clock.nanosec = int(t), round((t % 1) * 1e9)
        clock.publish(stamp)
        executor.spin_once(timeout_sec=0.0)
        speed.publish(Float64(data=SPEED))
        if k % 5 == 0:
            preload.publish(Float64(data=1500.0))
            msg = Temperature(temperature=20.0)
            msg.header.stamp = stamp.clock
            temperature.publish(msg)
        torque.publish(Float64(data=expected + float(rng.normal(0.0, 2e-4))))
        for _ in range(4):
            executor.spin_once(timeout_sec=0.0)
    assert spin_until(executor, lambda: len(listener.health) >= 5, timeout=5.0)
    stamps = [_stamp(m) for m in listener.health]
    assert all(100.0 <= s < 101.6 for s in stamps)  # bench (sim) time, not wall time
    compared = [m for m in listener.health if m.verdict != 3]
    assert compared and all(m.verdict in (0, 1) for m in compared)


def test_a_stamp_going_back_restarts_the_monitor(
    executor: SingleThreadedExecutor, spin_until: SpinUntil
) -> None:
    node = HealthNode(context=executor.context)
    executor.add_node(node)
    bench = Node("bench", context=executor.context)
    executor.add_node(bench)
    pub = bench.create_publisher(WrenchStamped, "/bench/torque", 10)
    later, earlier = WrenchStamped(), WrenchStamped()
    later.header.stamp.sec, earlier.header.stamp.sec = 10, 5
    later.wrench.torque.z = earlier.wrench.torque.z = 0.02
    first = node.monitor
    assert spin_until(
        executor, lambda: node.received["torque"] > 0, every=lambda: pub.publish(later)
    )
    assert spin_until(executor, lambda: node.restarts == 1, every=lambda: pub.publish(earlier))
    assert node.monitor is not first
