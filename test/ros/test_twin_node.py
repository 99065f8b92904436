"""The twin node in-process: commands in, finite drag torque out, bad commands rejected."""

from __future__ import annotations

import math
from collections.abc import Callable

import pytest
from ballscrew_twin_msgs.msg import DragTorque
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import Temperature
from std_msgs.msg import Float64

from ballscrew_twin.ros.twin_node import TwinNode

from .conftest import SpinUntil

SPEED = 10.47  # rad/s (100 rpm)
TORQUE_FIELDS = (
    "total", "nut_master", "nut_slave", "lubricant_shear", "dry_contact", "rolling_resistance",
    "hysteresis", "curvature", "spin", "real_time_factor", "screw_speed", "temperature",
    "preload",
)


class Bench(Node):
    """Stands in for a test bench: publishes commands, records the twin's drag torque."""

    def __init__(self, executor: SingleThreadedExecutor) -> None:
        super().__init__("bench", context=executor.context)
        self.torques: list[DragTorque] = []
        self.speed = self.create_publisher(Float64, "speed_command", qos_profile_sensor_data)
        self.temp = self.create_publisher(Temperature, "temperature", qos_profile_sensor_data)
        self.preload = self.create_publisher(Float64, "preload_command", qos_profile_sensor_data)
        self.create_subscription(DragTorque, "drag_torque", self.torques.append, 10)
        executor.add_node(self)

    def command(self, speed: float, temp_c: float, preload: float) -> Callable[[], None]:
        """A function that publishes this command once (to call repeatedly while spinning)."""

        def publish() -> None:
            self.speed.publish(Float64(data=speed))
            self.temp.publish(Temperature(temperature=temp_c))
            self.preload.publish(Float64(data=preload))

        return publish


@pytest.fixture
def twin(executor: SingleThreadedExecutor) -> TwinNode:
    node = TwinNode(
        context=executor.context,
        parameter_overrides=[Parameter("publish_rate_hz", value=50.0)],
    )
    executor.add_node(node)
    return node


def _all_finite(msg: DragTorque) -> bool:
    return all(math.isfinite(getattr(msg, f)) for f in TORQUE_FIELDS)


def _reach(
    spin_until: SpinUntil, executor: SingleThreadedExecutor, bench: Bench,
    speed: float, temp_c: float, preload: float,
) -> DragTorque:
    """Command an operating point until a torque computed at it arrives; return that torque."""

    def arrived() -> bool:
        if not bench.torques:
            return False
        m = bench.torques[-1]
        return (math.isclose(m.screw_speed, speed) and math.isclose(m.preload, preload)
                and math.isclose(m.temperature, temp_c + 273.15))

    assert spin_until(executor, arrived, every=bench.command(speed, temp_c, preload)), (
        f"no drag_torque at speed {speed} rad/s, {temp_c} deg C, {preload} N")
    return bench.torques[-1]


def test_torque_arrives_finite_and_rises_with_preload(
    executor: SingleThreadedExecutor, twin: TwinNode, spin_until: SpinUntil
) -> None:
    bench = Bench(executor)
    low = _reach(spin_until, executor, bench, SPEED, 20.0, 1000.0)
    high = _reach(spin_until, executor, bench, SPEED, 20.0, 3000.0)

    for msg in (low, high):
        assert _all_finite(msg)
        assert msg.fidelity.startswith("catalog")
        assert msg.header.frame_id == "ball_screw"
        assert msg.real_time_factor >= 0.0
    assert low.total > 0.0
    assert high.total > low.total
    assert high.nut_master + high.nut_slave == pytest.approx(high.total)
    assert low.temperature == pytest.approx(293.15)  # deg C converted to K at the edge


def test_reverse_speed_reverses_torque(
    executor: SingleThreadedExecutor, twin: TwinNode, spin_until: SpinUntil
) -> None:
    bench = Bench(executor)
    forward = _reach(spin_until, executor, bench, SPEED, 20.0, 1500.0)
    backward = _reach(spin_until, executor, bench, -SPEED, 20.0, 1500.0)
    assert backward.total == pytest.approx(-forward.total)


@pytest.mark.parametrize(
    ("speed", "temp_c", "preload"),
    [
        (SPEED, 20.0, math.nan),
        (SPEED, 20.0, math.inf),
        (SPEED, 20.0, -10.0),
        (SPEED, 20.0, 1.0e9),
        (math.nan, 20.0, 2000.0),
        (-math.inf, 20.0, 2000.0),
        (1.0e6, 20.0, 2000.0),
        (SPEED, math.nan, 2000.0),
        (SPEED, -300.0, 2000.0),
        (SPEED, 5000.0, 2000.0),
    ],
)
def test_bad_command_rejected_and_publishing_continues(
    executor: SingleThreadedExecutor, twin: TwinNode, spin_until: SpinUntil,
    speed: float, temp_c: float, preload: float,
) -> None:
    bench = Bench(executor)
    good = _reach(spin_until, executor, bench, SPEED, 20.0, 2000.0)
    rejected_before = twin.rejected_commands

    # Send only the bad value, the other inputs stay at their good values.
    def publish_bad() -> None:
        if math.isnan(preload) or preload != 2000.0:
            bench.preload.publish(Float64(data=preload))
        if math.isnan(speed) or speed != SPEED:
            bench.speed.publish(Float64(data=speed))
        if math.isnan(temp_c) or temp_c != 20.0:
            bench.temp.publish(Temperature(temperature=temp_c))

    assert spin_until(executor, lambda: twin.rejected_commands > rejected_before,
                      every=publish_bad)
    count = len(bench.torques)
    assert spin_until(executor, lambda: len(bench.torques) >= count + 5)

    latest = bench.torques[-1]
    assert all(_all_finite(m) for m in bench.torques)
    assert latest.preload == good.preload
    assert latest.screw_speed == good.screw_speed
    assert latest.temperature == good.temperature
    assert latest.total == pytest.approx(good.total)


def test_parameters_validated_and_applied(
    executor: SingleThreadedExecutor, twin: TwinNode, spin_until: SpinUntil
) -> None:
    bench = Bench(executor)
    before = _reach(spin_until, executor, bench, SPEED, 20.0, 1500.0)

    out_of_range = twin.set_parameters([Parameter("publish_rate_hz", value=5000.0)])
    assert not out_of_range[0].successful
    read_only = twin.set_parameters([Parameter("torque_topic", value="elsewhere")])
    assert not read_only[0].successful

    assert twin.set_parameters([Parameter("mu_lit", value=0.004)])[0].successful
    count = len(bench.torques)
    assert spin_until(executor, lambda: len(bench.torques) > count + 2)
    assert bench.torques[-1].total == pytest.approx(2.0 * before.total)


def test_node_name_and_defaults(executor: SingleThreadedExecutor) -> None:
    node = TwinNode(context=executor.context)
    executor.add_node(node)
    assert node.get_name() == "ballscrew_twin"
    assert node.get_parameter("publish_rate_hz").value == 100.0
    assert node.get_parameter("config_file").value == ""
    assert node.get_parameter("mu_lit").value == 0.002
