"""Demo command publisher: drives a running twin node and prints the torque it publishes.

Publishes a scripted sequence of screw speed [rad/s], temperature [deg C] and preload [N]
commands (sensor-data QoS, 10 Hz), including one invalid (NaN) preload that the node must
reject, subscribes ``drag_torque`` and prints the latest value once a second. Exits 0 after
``--duration`` seconds if torque messages arrived, 1 otherwise.

Run (with a twin node on the same ROS domain): ``twin_demo_commander --duration 10``.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import dataclass
from typing import Any

import rclpy
from ballscrew_twin_msgs.msg import DragTorque
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from rclpy.utilities import remove_ros_args
from sensor_msgs.msg import Temperature
from std_msgs.msg import Float64

#: Publish rate of the commands [Hz].
COMMAND_RATE = 10.0
#: Interval between two printed lines [s].
PRINT_PERIOD = 1.0
RPM_TO_RAD_S = 2.0 * math.pi / 60.0


@dataclass(frozen=True, kw_only=True)
class Command:
    """One commanded operating condition.

    Attributes:
        screw_speed: screw angular speed [rad/s].
        temperature_c: temperature [deg C] (sensor_msgs/Temperature convention).
        preload: preload [N]; NaN to exercise the node's input rejection.
    """

    screw_speed: float
    temperature_c: float
    preload: float


def command_at(fraction: float) -> Command:
    """Scripted command at ``fraction`` (0..1) of the demo run.

    Five phases of equal length: 100 rpm / 20 deg C / 1500 N; preload raised to 3000 N; speed
    raised to 300 rpm; temperature raised to 40 deg C; rotation reversed (-100 rpm).
    """
    base = Command(screw_speed=100.0 * RPM_TO_RAD_S, temperature_c=20.0, preload=1500.0)
    phases = [
        base,
        Command(screw_speed=base.screw_speed, temperature_c=20.0, preload=3000.0),
        Command(screw_speed=300.0 * RPM_TO_RAD_S, temperature_c=20.0, preload=3000.0),
        Command(screw_speed=300.0 * RPM_TO_RAD_S, temperature_c=40.0, preload=3000.0),
        Command(screw_speed=-100.0 * RPM_TO_RAD_S, temperature_c=40.0, preload=3000.0),
    ]
    index = min(max(int(fraction * len(phases)), 0), len(phases) - 1)
    return phases[index]


class DemoCommander(Node):
    """Publishes :func:`command_at` commands and prints the received drag torque.

    Args:
        duration: length of the run [s].
        inject_nan_at: fraction of the run at which one NaN preload is published (<0: never).
    """

    def __init__(self, duration: float, inject_nan_at: float = 0.5, **kwargs: Any) -> None:
        super().__init__("twin_demo_commander", **kwargs)
        self.duration = duration
        self.inject_nan_at = inject_nan_at
        self.start = time.monotonic()
        self.received = 0
        self.latest: DragTorque | None = None
        self._nan_sent = False
        self._received_at_last_print = 0
        self._speed_pub = self.create_publisher(Float64, "speed_command", qos_profile_sensor_data)
        self._temp_pub = self.create_publisher(
            Temperature, "temperature", qos_profile_sensor_data)
        self._preload_pub = self.create_publisher(
            Float64, "preload_command", qos_profile_sensor_data)
        self.create_subscription(DragTorque, "drag_torque", self._on_torque, 10)
        self.create_timer(1.0 / COMMAND_RATE, self._publish_commands)
        self.create_timer(PRINT_PERIOD, self._print_status)

    def elapsed(self) -> float:
        """Time since start [s]."""
        return time.monotonic() - self.start

    def _on_torque(self, msg: DragTorque) -> None:
        self.received += 1
        self.latest = msg

    def _publish_commands(self) -> None:
        fraction = self.elapsed() / self.duration
        cmd = command_at(fraction)
        preload = cmd.preload
        if not self._nan_sent and 0.0 <= self.inject_nan_at <= fraction:
            preload = math.nan
            self._nan_sent = True
            print(f"t={self.elapsed():5.1f} s  sending preload = NaN (the node must reject it)",
                  flush=True)
        self._speed_pub.publish(Float64(data=cmd.screw_speed))
        temp = Temperature(temperature=cmd.temperature_c, variance=0.0)
        temp.header.stamp = self.get_clock().now().to_msg()
        self._temp_pub.publish(temp)
        self._preload_pub.publish(Float64(data=preload))

    def _print_status(self) -> None:
        rate = (self.received - self._received_at_last_print) / PRINT_PERIOD
        self._received_at_last_print = self.received
        msg = self.latest
        if msg is None:
            print(f"t={self.elapsed():5.1f} s  waiting for drag_torque ...", flush=True)
            return
        print(
            f"t={self.elapsed():5.1f} s  speed {msg.screw_speed:7.2f} rad/s  "
            f"T {msg.temperature:6.2f} K  preload {msg.preload:6.0f} N  ->  "
            f"torque {msg.total * 1e3:8.3f} mN m (master {msg.nut_master * 1e3:.3f}, "
            f"slave {msg.nut_slave * 1e3:.3f})  [{msg.fidelity}, {rate:.0f} msg/s, "
            f"rtf {msg.real_time_factor:.4f}]",
            flush=True,
        )


def main(args: list[str] | None = None) -> None:
    """Console script ``twin_demo_commander [--duration S] [--ros-args ...]``."""
    argv = sys.argv if args is None else args
    parser = argparse.ArgumentParser(prog="twin_demo_commander", description=__doc__)
    parser.add_argument("--duration", type=float, default=10.0, help="run length [s]")
    parser.add_argument("--nan-at", type=float, default=0.5,
                        help="fraction of the run at which a NaN preload is sent (<0: never)")
    opts = parser.parse_args(remove_ros_args(argv)[1:])
    if not opts.duration > 0.0:
        parser.error("--duration must be > 0")

    rclpy.init(args=argv)
    node: DemoCommander | None = None
    received = 0
    try:
        node = DemoCommander(opts.duration, inject_nan_at=opts.nan_at)
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        while rclpy.ok() and node.elapsed() < opts.duration:
            executor.spin_once(timeout_sec=0.05)
        received = node.received
    except (KeyboardInterrupt, ExternalShutdownException):
        received = node.received if node is not None else 0
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    if received == 0:
        print("twin_demo_commander: no drag_torque message received", file=sys.stderr)
        raise SystemExit(1)
    print(f"twin_demo_commander: {received} drag_torque messages received", flush=True)


if __name__ == "__main__":
    main()
