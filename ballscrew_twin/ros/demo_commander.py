"""Demo command publisher: drives a running twin node through a speed/temperature/preload profile.

Publishes a scripted sequence of screw speed [rad/s], temperature [deg C] and preload [N]
commands (sensor-data QoS, 10 Hz), including one invalid (NaN) preload and one speed sent in
rpm instead of rad/s, which the node must reject. Prints each new command; the torque is shown
by :mod:`ballscrew_twin.ros.console_view`. The profile starts with the twin node's first
``drag_torque`` message and lasts ``--duration`` seconds; exit 0 then, 1 when no twin node
showed up within a minute.

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

from ..units import RPM
from .command_args import check_duration
from .executors import spin_once

#: Longest wait for the twin node to subscribe [s].
STARTUP_TIMEOUT = 60.0
#: Publish rate of the commands [Hz].
COMMAND_RATE = 10.0
#: Interval between two printed lines [s].
PRINT_PERIOD = 1.0
#: Speed sent once in rpm instead of rad/s: above the screw's critical speed (1885 rad/s)
#: when read as rad/s, so the node rejects it [rpm].
RPM_MISTAKE = 3000.0


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
    base = Command(screw_speed=100.0 * RPM, temperature_c=20.0, preload=1500.0)
    phases = [
        base,
        Command(screw_speed=base.screw_speed, temperature_c=20.0, preload=3000.0),
        Command(screw_speed=300.0 * RPM, temperature_c=20.0, preload=3000.0),
        Command(screw_speed=300.0 * RPM, temperature_c=40.0, preload=3000.0),
        Command(screw_speed=-100.0 * RPM, temperature_c=40.0, preload=3000.0),
    ]
    index = min(max(int(fraction * len(phases)), 0), len(phases) - 1)
    return phases[index]


class DemoCommander(Node):
    """Publishes :func:`command_at` commands and a few deliberately bad ones.

    Args:
        duration: length of the run [s].
        inject_nan_at: fraction of the run at which one NaN preload is published (<0: never).
        inject_rpm_at: fraction of the run at which :data:`RPM_MISTAKE` (a speed in rpm) is
            published as rad/s (<0: never); the node must reject it as implausible.
        listeners: subscribers of ``drag_torque`` (this node's own included) to wait for before
            the profile starts, so that a console view started alongside sees it all [-].
    """

    def __init__(
        self,
        duration: float,
        inject_nan_at: float = 0.5,
        inject_rpm_at: float = 0.7,
        listeners: int = 1,
        **kwargs: Any,
    ) -> None:
        super().__init__("twin_demo_commander", **kwargs)
        self.duration = duration
        self.listeners = listeners
        self.injections = {"nan": inject_nan_at, "rpm": inject_rpm_at}
        #: When the profile started: with the twin node's first torque message.
        self.start: float | None = None
        self.created = time.monotonic()
        self.sent = 0
        self._last_command: Command | None = None
        qos = qos_profile_sensor_data
        self._speed_pub = self.create_publisher(Float64, "speed_command", qos)
        self._temp_pub = self.create_publisher(Temperature, "temperature", qos)
        self._preload_pub = self.create_publisher(Float64, "preload_command", qos)
        self.create_subscription(DragTorque, "drag_torque", self._on_torque, 10)
        self.create_timer(1.0 / COMMAND_RATE, self._publish_commands)

    def elapsed(self) -> float:
        """Time since the profile started [s] (0 while waiting for the twin node)."""
        return 0.0 if self.start is None else time.monotonic() - self.start

    def waited(self) -> float:
        """Time spent waiting for the twin node so far [s] (0 once it is there)."""
        return time.monotonic() - self.created if self.start is None else 0.0

    def _on_torque(self, _msg: DragTorque) -> None:
        """The profile starts with the twin node's first torque message once ``listeners``
        subscribers of the torque are there."""
        if self.start is None and self.count_subscribers("drag_torque") >= self.listeners:
            self.start = time.monotonic()

    def _due(self, name: str, fraction: float) -> bool:
        """Whether the one-off bad command ``name`` is due now (then it is marked as sent)."""
        at = self.injections[name]
        if 0.0 <= at <= fraction:
            self.injections[name] = -1.0
            return True
        return False

    def _publish_commands(self) -> None:
        if self.start is None:
            return  # the twin node is not up yet: keep the profile for when it is
        fraction = self.elapsed() / self.duration
        cmd = command_at(fraction)
        if cmd != self._last_command:
            self._last_command = cmd
            print(
                f"t={self.elapsed():5.1f} s  command {cmd.screw_speed / RPM:6.0f} rpm, "
                f"{cmd.temperature_c:5.1f} C, {cmd.preload:6.0f} N",
                flush=True,
            )
        preload, speed = cmd.preload, cmd.screw_speed
        if self._due("nan", fraction):
            preload = math.nan
            print(f"t={self.elapsed():5.1f} s  sending preload NaN (to be rejected)", flush=True)
        if self._due("rpm", fraction):
            speed = RPM_MISTAKE
            print(
                f"t={self.elapsed():5.1f} s  sending {RPM_MISTAKE:g} rpm as {RPM_MISTAKE:g} "
                "rad/s (unit mistake, to be rejected)",
                flush=True,
            )
        self._speed_pub.publish(Float64(data=speed))
        temp = Temperature(temperature=cmd.temperature_c, variance=0.0)
        temp.header.stamp = self.get_clock().now().to_msg()
        self._temp_pub.publish(temp)
        self._preload_pub.publish(Float64(data=preload))
        self.sent += 1


def main(args: list[str] | None = None) -> None:
    """Console script ``twin_demo_commander [--duration S] [--ros-args ...]``."""
    argv = sys.argv if args is None else args
    parser = argparse.ArgumentParser(prog="twin_demo_commander", description=__doc__)
    parser.add_argument("--duration", type=float, default=10.0, help="run length [s]")
    parser.add_argument(
        "--nan-at",
        type=float,
        default=0.5,
        help="fraction of the run at which a NaN preload is sent (<0: never)",
    )
    parser.add_argument(
        "--rpm-at",
        type=float,
        default=0.7,
        help="fraction of the run at which a speed in rpm is sent as rad/s (<0: never)",
    )
    parser.add_argument(
        "--listeners",
        type=int,
        default=1,
        help="drag_torque subscribers (this one included) to wait for before starting",
    )
    opts = parser.parse_args(remove_ros_args(argv)[1:])
    check_duration(parser, opts.duration)

    rclpy.init(args=argv)
    node: DemoCommander | None = None
    try:
        node = DemoCommander(
            opts.duration,
            inject_nan_at=opts.nan_at,
            inject_rpm_at=opts.rpm_at,
            listeners=opts.listeners,
        )
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        while rclpy.ok() and node.elapsed() < opts.duration:
            spin_once(executor, 0.05)
            if node.waited() > STARTUP_TIMEOUT:
                print(
                    f"twin_demo_commander: no twin node torque with {opts.listeners} "
                    f"subscriber(s) within {STARTUP_TIMEOUT:g} s",
                    file=sys.stderr,
                )
                raise SystemExit(1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            print(f"twin_demo_commander: {node.sent} command sets sent", flush=True)
            node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
