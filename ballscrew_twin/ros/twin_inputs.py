"""The twin node's inputs on ROS: subscriptions, checks and the last good values.

Screw speed [rad/s] (std_msgs/Float64 or sensor_msgs/JointState velocity), temperature
(sensor_msgs/Temperature in deg C, kept in K), preload and optional external axial load [N]
(Float64 or geometry_msgs/WrenchStamped ``wrench.force.z``). A message that fails a check of
``inputs.py`` (not finite, outside the limits, stamp out of order or too old) is rejected with
a throttled log line; the last good value stays in force.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from typing import Any

from geometry_msgs.msg import WrenchStamped
from rclpy.node import Node
from rclpy.qos import QoSProfile, qos_profile_sensor_data
from sensor_msgs.msg import JointState, Temperature
from std_msgs.msg import Float64

from ..errors import ConfigError
from ..models.base import OperatingPoint
from ..units import NS_PER_S, celsius_to_kelvin, stamp_to_ns
from .inputs import (
    InputChannel,
    InputLimits,
    check_axial_load,
    check_preload,
    check_screw_speed,
    check_stamp,
    check_temperature,
)


class TwinInputs:
    """The four inputs of the twin node, subscribed on ``node`` as its parameters say.

    Args:
        node: the node (parameters ``limits.*``, ``initial_*``, ``*_topic``, ``*_type``,
            ``speed_joint``, ``input_qos``, ``max_stamp_age``; declared).
        critical_speed: the screw's critical speed, the speed limit unless
            ``limits.max_screw_speed`` is set [rad/s].
        lock: held while a value is taken (the ticks read them on a thread of their own).
        now_ns: the node's clock [ns].
        warn: ``warn(key, text)`` logs a warning, throttled per key.

    Raises:
        ConfigError: an initial value outside the limits.
    """

    def __init__(
        self,
        node: Node,
        critical_speed: float,
        lock: threading.Lock,
        now_ns: Callable[[], int],
        warn: Callable[[str, str], None],
    ) -> None:
        self._node = node
        limit = {
            name: float(node.get_parameter(f"limits.{name}").value)
            for name in (
                "max_screw_speed",
                "min_temperature",
                "max_temperature",
                "max_preload",
                "max_axial_load",
            )
        }
        limit["max_screw_speed"] = limit["max_screw_speed"] or critical_speed
        self.limits = InputLimits(**limit)
        self._lock = lock
        self._now_ns = now_ns
        self._warn = warn
        initial = {
            name: float(node.get_parameter(f"initial_{name}").value)
            for name in ("screw_speed", "temperature", "preload")
        }
        for name, check in (
            ("screw_speed", check_screw_speed),
            ("temperature", check_temperature),
            ("preload", check_preload),
        ):
            if (reason := check(initial[name], self.limits)) is not None:
                raise ConfigError(f"parameter initial_{name}: {reason}")
        self.speed = InputChannel("screw speed", "rad/s", initial["screw_speed"])
        self.temperature = InputChannel("temperature", "K", initial["temperature"])
        self.preload = InputChannel("preload", "N", initial["preload"])
        self.axial_load = InputChannel("axial load", "N", 0.0)
        self.channels = (self.speed, self.temperature, self.preload, self.axial_load)
        #: Operating point of the last good values (SI).
        self.operating_point = self._current_op()
        self.operating_point.validate()
        #: Messages rejected since start-up [-].
        self.rejected = 0
        self._speed_joint = self._param("speed_joint")
        self._subscribe()

    def _param(self, name: str) -> str:
        """Value of a string parameter of the node."""
        return str(self._node.get_parameter(name).value)

    def _subscribe(self) -> None:
        """Subscribe to the inputs on the topics and message types the parameters name."""
        node = self._node
        qos: QoSProfile | int = (
            qos_profile_sensor_data if self._param("input_qos") == "sensor_data" else 10
        )
        speed_topic = self._param("speed_topic")
        if self._param("speed_type") == "joint_state":
            node.create_subscription(JointState, speed_topic, self.on_joint_state, qos)
        else:
            node.create_subscription(Float64, speed_topic, self.on_speed, qos)
        temperature_topic = self._param("temperature_topic")
        node.create_subscription(Temperature, temperature_topic, self.on_temperature, qos)
        for name, on_float, on_wrench in (
            ("preload", self.on_preload, self.on_preload_wrench),
            ("axial_load", self.on_axial_load, self.on_axial_load_wrench),
        ):
            topic = self._param(f"{name}_topic")
            if not topic:  # the axial load may be switched off
                continue
            if self._param(f"{name}_type") == "wrench_stamped":
                node.create_subscription(WrenchStamped, topic, on_wrench, qos)
            else:
                node.create_subscription(Float64, topic, on_float, qos)

    def _current_op(self) -> OperatingPoint:
        """Operating point of the inputs' last good values."""
        return OperatingPoint(
            screw_speed=self.speed.value,
            temperature=self.temperature.value,
            preload=self.preload.value,
            axial_load=self.axial_load.value,
        )

    def forget_times(self) -> None:
        """Forget every input's arrival time and stamp (the clock jumped backwards)."""
        for channel in self.channels:
            channel.forget_times()

    def take(
        self, channel: InputChannel, value: float, reason: str | None, stamp: Any = None
    ) -> None:
        """Accept ``value`` into ``channel`` or reject it with ``reason`` (logged, counted);
        a header ``stamp`` (builtin_interfaces/Time) is checked for order and age."""
        with self._lock:
            now = self._now_ns()
            stamp_ns = 0 if stamp is None else stamp_to_ns(stamp)
            if reason is None:
                max_age = float(self._node.get_parameter("max_stamp_age").value)
                reason = check_stamp(
                    stamp_ns,
                    last_stamp_ns=channel.last_stamp_ns,
                    now_ns=now,
                    max_age_ns=int(max_age * NS_PER_S),
                )
            if reason is not None:
                channel.reject(reason)
                self.rejected += 1
                self._warn(
                    channel.name,
                    f"{channel.name} rejected, keeping {channel.value:g} {channel.unit}: {reason}",
                )
                return
            channel.accept(value, now, stamp_ns)
            self.operating_point = self._current_op()

    def on_speed(self, msg: Float64) -> None:
        """Screw speed command [rad/s]."""
        value = float(msg.data)
        self.take(self.speed, value, check_screw_speed(value, self.limits))

    def on_joint_state(self, msg: JointState) -> None:
        """Screw speed from a joint's velocity [rad/s]: the ``speed_joint``'s, or the first."""
        names = list(msg.name)
        index = 0
        if self._speed_joint:
            if self._speed_joint not in names:
                why = f"joint {self._speed_joint!r} not in JointState {names}"
                self.take(self.speed, math.nan, why)
                return
            index = names.index(self._speed_joint)
        if index >= len(msg.velocity):
            self.take(self.speed, math.nan, f"JointState has no velocity for joint {index}")
            return
        value = float(msg.velocity[index])
        self.take(self.speed, value, check_screw_speed(value, self.limits), msg.header.stamp)

    def on_temperature(self, msg: Temperature) -> None:
        """Temperature measurement [deg C], stored in [K]."""
        celsius = float(msg.temperature)
        value = celsius_to_kelvin(celsius)
        reason = check_temperature(value, self.limits)
        if reason is not None:
            reason += f" (received {celsius!r} deg C)"
        self.take(self.temperature, value, reason, msg.header.stamp)

    def on_preload(self, msg: Float64) -> None:
        """Preload command [N]."""
        value = float(msg.data)
        self.take(self.preload, value, check_preload(value, self.limits))

    def on_axial_load(self, msg: Float64) -> None:
        """External axial load command [N]."""
        value = float(msg.data)
        self.take(self.axial_load, value, check_axial_load(value, self.limits))

    def on_preload_wrench(self, msg: WrenchStamped) -> None:
        """Preload measured by a load cell: ``wrench.force.z`` [N]."""
        value = float(msg.wrench.force.z)
        self.take(self.preload, value, check_preload(value, self.limits), msg.header.stamp)

    def on_axial_load_wrench(self, msg: WrenchStamped) -> None:
        """External axial load along +z measured as a wrench: ``wrench.force.z`` [N]."""
        value = float(msg.wrench.force.z)
        self.take(self.axial_load, value, check_axial_load(value, self.limits), msg.header.stamp)
