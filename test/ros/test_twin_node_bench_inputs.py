"""The twin node driven by the bench's own messages on loopback (``input_preset: bench``):
speed from JointState, temperature from Temperature, preload and axial load from WrenchStamped
(wrench.force.z), on the topics of the bench-bag schema of the README."""

from __future__ import annotations

import math
import threading

import pytest
from geometry_msgs.msg import WrenchStamped
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import JointState, Temperature

from ballscrew_twin.bags.reader import open_raw_bag
from ballscrew_twin.bags.recording import BenchTopics
from ballscrew_twin.health.bench_data import SAMPLE_DIR
from ballscrew_twin.ros.replay import BagPlayer
from ballscrew_twin.ros.twin_node import TwinNode
from ballscrew_twin.ros.twin_parameters import INPUT_PRESETS

from .conftest import SpinUntil
from .test_twin_node import SPEED, _twin


class BenchRig(Node):
    """Publishes what a bench's sensors do, on the bench-bag schema's topics, stamped now."""

    def __init__(self, executor: SingleThreadedExecutor, preload_topic: str) -> None:
        super().__init__("bench_rig", context=executor.context)
        topics = BenchTopics()
        qos = qos_profile_sensor_data
        self.joints = self.create_publisher(JointState, topics.speed, qos)
        self.temperature = self.create_publisher(Temperature, topics.temperature, qos)
        self.preload = self.create_publisher(WrenchStamped, preload_topic, qos)
        self.axial = self.create_publisher(WrenchStamped, "/bench/axial_load", qos)
        executor.add_node(self)

    def publish(self, speed: float, celsius: float, preload: float, axial: float) -> None:
        stamp = self.get_clock().now().to_msg()
        joints = JointState(name=["motor", "screw"], velocity=[3.0 * speed, speed])
        joints.header.stamp = stamp
        self.joints.publish(joints)
        temp = Temperature(temperature=celsius, variance=0.01)
        temp.header.stamp = stamp
        self.temperature.publish(temp)
        for publisher, force in ((self.preload, preload), (self.axial, axial)):
            wrench = WrenchStamped()
            wrench.header.stamp = stamp
            wrench.wrench.force.z = force
            wrench.wrench.torque.z = 123.0  # not a force: ignored
            publisher.publish(wrench)


def test_bench_messages_drive_the_twin(
    executor: SingleThreadedExecutor, spin_until: SpinUntil
) -> None:
    twin = _twin(executor, fidelity="catalog", input_preset="bench")
    rig = BenchRig(executor, BenchTopics().preload)

    def arrived() -> bool:
        op = twin.inputs.operating_point
        return (op.screw_speed, op.preload, op.axial_load) == (SPEED, 2500.0, -300.0) and (
            math.isclose(op.temperature, 303.15)
        )

    assert spin_until(executor, arrived, every=lambda: rig.publish(SPEED, 30.0, 2500.0, -300.0))
    assert twin.inputs.rejected == 0
    for channel in twin.inputs.channels:
        assert channel.accepted > 0, channel.name


def test_preset_gives_defaults_and_a_parameter_set_wins(executor: SingleThreadedExecutor) -> None:
    twin = _twin(executor, fidelity="catalog", input_preset="bench", preload_topic="/rig/load_cell")
    subscribed = {s.topic_name: s.msg_type.__name__ for s in twin.subscriptions}
    bench = BenchTopics()
    assert subscribed[bench.speed] == "JointState"
    assert twin.get_parameter("speed_joint").value == bench.joint_name
    assert subscribed[bench.temperature] == "Temperature"
    assert subscribed["/rig/load_cell"] == "WrenchStamped"  # the topic set, the preset's type
    assert bench.preload not in subscribed
    assert subscribed["/bench/axial_load"] == "WrenchStamped"

    commands = _twin(executor, fidelity="catalog", preload_type="wrench_stamped")
    subscribed = {s.topic_name: s.msg_type.__name__ for s in commands.subscriptions}
    assert subscribed["/preload_command"] == "WrenchStamped"
    assert subscribed["/axial_load_command"] == "Float64"
    assert set(INPUT_PRESETS["bench"]) == set(INPUT_PRESETS["commands"])


def test_a_replayed_bench_bag_drives_the_twin_with_no_glue(
    executor: SingleThreadedExecutor, spin_until: SpinUntil
) -> None:
    """The healthy sample bag (100 rpm, 20 C, 1500 N) played with /clock: the twin on the bag's
    clock takes speed, temperature and preload from it, header stamps accepted."""
    twin = _twin(executor, fidelity="catalog", input_preset="bench", use_sim_time=True)
    player_node = Node("player", context=executor.context)
    stop = threading.Event()
    with open_raw_bag(SAMPLE_DIR / "healthy") as raw:
        player = BagPlayer(player_node, raw, rate=4.0)
        thread = threading.Thread(target=player.play, args=(lambda: not stop.is_set(),))
        thread.start()
        try:
            assert spin_until(
                executor,
                lambda: (
                    all(c.accepted > 0 for c in twin.inputs.channels[:3])
                    and twin.ticks.totals.published
                ),
            )
        finally:
            stop.set()
            thread.join(timeout=10.0)
            player_node.destroy_node()
    op = twin.inputs.operating_point
    assert op.screw_speed == pytest.approx(100.0 * math.pi / 30.0, rel=0.05)
    assert op.temperature == pytest.approx(293.15, abs=1.0)
    assert op.preload == pytest.approx(1500.0, rel=0.05)
    assert twin.inputs.rejected == 0


def test_unknown_preset_is_refused(executor: SingleThreadedExecutor) -> None:
    with pytest.raises(ValueError, match="input_preset = 'rig' is not one of commands, bench"):
        TwinNode(
            context=executor.context, parameter_overrides=[Parameter("input_preset", value="rig")]
        )
