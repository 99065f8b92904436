"""ROS 2 health-monitor node: bench measurements in, residuals, verdict and /diagnostics out.

Subscribes (sensor-data QoS with a deep queue; names and types are parameters):
    ``torque_topic``       geometry_msgs/WrenchStamped (wrench.torque.z) or std_msgs/Float64 [N m]
    ``speed_topic``        sensor_msgs/JointState (velocity of ``joint_name``) or Float64 [rad/s]
    ``temperature_topic``  sensor_msgs/Temperature [deg C], converted to [K]
    ``preload_topic``      geometry_msgs/WrenchStamped (wrench.force.z) or Float64 [N]

Publishes:
    ``health_topic``  ballscrew_twin_msgs/HealthResidual, one per block of torque samples
    ``/diagnostics``  diagnostic_msgs/DiagnosticArray at ``diagnostics_rate_hz``

Every sample goes through the same :class:`~ballscrew_twin.health.monitor.HealthMonitor` as
``ballscrew-twin detect``, with the message's header stamp as its time (the node clock for
Float64, which has no header; the node clock follows ``/clock`` with ``use_sim_time``), so a
bag replayed into the node gives the offline verdict. Non-finite samples are dropped with a
warning; a stamp that goes back in time (bag replay restarted, clock jump) restarts the
monitor with a warning. Fields of a HealthResidual other than ``measured`` are 0 while the
verdict is UNKNOWN (nothing non-finite is published).

Run: ``health_node --ros-args --params-file config/health_node.yaml`` or
``ballscrew-twin health-node --params-file config/health_node.yaml``.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from typing import Any

import rclpy
from ballscrew_twin_msgs.msg import HealthResidual
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor, ParameterType
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState, Temperature
from std_msgs.msg import Float64

from ..errors import BallscrewTwinError
from ..health.monitor import FAULT, OK, UNKNOWN, VERDICT_NAMES, WARN, HealthMonitor, HealthSample
from ..health.monitor import MonitorSettings as Settings
from ..health.residuals import ResidualSettings, StampOrderError
from ..params import load_config
from .command_args import add_ros_arguments, ros_argv
from .diagnostics import ERROR, STALE, Check, to_message
from .diagnostics import OK as DIAG_OK
from .diagnostics import WARN as DIAG_WARN
from .inputs import celsius_to_kelvin

NODE_NAME = "ballscrew_health"
#: Minimum interval between two warnings of the same kind [s].
WARN_THROTTLE = 2.0
#: Diagnostic level of each verdict.
DIAG_LEVEL = {OK: DIAG_OK, WARN: DIAG_WARN, FAULT: ERROR, UNKNOWN: STALE}
TYPES = {
    "torque_type": ("WrenchStamped", "Float64"),
    "speed_type": ("JointState", "Float64"),
    "preload_type": ("WrenchStamped", "Float64"),
}


def _float(description: str, low: float, high: float) -> ParameterDescriptor:
    """Read-only double parameter restricted to [low, high]."""
    return ParameterDescriptor(
        type=ParameterType.PARAMETER_DOUBLE,
        description=description,
        read_only=True,
        floating_point_range=[FloatingPointRange(from_value=low, to_value=high, step=0.0)],
    )


def _string(description: str) -> ParameterDescriptor:
    """Read-only string parameter."""
    return ParameterDescriptor(
        type=ParameterType.PARAMETER_STRING, description=description, read_only=True
    )


def _seconds(stamp: Any) -> float:
    """A builtin_interfaces/Time as seconds [s]."""
    return float(stamp.sec) + 1e-9 * float(stamp.nanosec)


def _time_msg(seconds: float) -> Time:
    """Seconds [s] as a builtin_interfaces/Time."""
    sec = math.floor(seconds)
    return Time(sec=int(sec), nanosec=min(round((seconds - sec) * 1e9), 999_999_999))


class HealthNode(Node):
    """Thin rclpy node around :class:`HealthMonitor` (parameters in ``config/health_node.yaml``).

    Keyword arguments are passed to :class:`rclpy.node.Node` (``context``,
    ``parameter_overrides``, ``cli_args`` ...).
    """

    def __init__(self, node_name: str = NODE_NAME, **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        defaults = Settings()
        res = ResidualSettings()
        declared: list[tuple[str, Any, ParameterDescriptor]] = [
            ("config_file", "", _string("Screw parameter file (YAML); empty: shipped paper screw")),
            ("torque_topic", "/bench/torque", _string("Input: measured drive torque [N m]")),
            ("torque_type", "WrenchStamped", _string("WrenchStamped (torque.z) or Float64")),
            ("speed_topic", "/bench/joint_states", _string("Input: screw speed [rad/s]")),
            ("speed_type", "JointState", _string("JointState (velocity) or Float64")),
            ("joint_name", "screw", _string("Joint of the screw in JointState messages")),
            (
                "temperature_topic",
                "/bench/temperature",
                _string("Input: sensor_msgs/Temperature [deg C]"),
            ),
            ("preload_topic", "/bench/preload", _string("Input: load-cell preload [N]")),
            ("preload_type", "WrenchStamped", _string("WrenchStamped (force.z) or Float64")),
            ("health_topic", "health", _string("Output: ballscrew_twin_msgs/HealthResidual")),
            ("frame_id", "screw", _string("header.frame_id of HealthResidual")),
            (
                "queue_depth",
                1000,
                ParameterDescriptor(
                    type=ParameterType.PARAMETER_INTEGER,
                    read_only=True,
                    description="Depth of the input queues (best effort, keep last) [-]",
                ),
            ),
            ("diagnostics_rate_hz", 1.0, _float("/diagnostics rate [Hz]", 0.1, 10.0)),
            ("stale_after", 2.0, _float("No torque for this long: STALE [s]", 0.1, 60.0)),
            (
                "false_alarm_rate",
                defaults.false_alarm_rate,
                _float("Target false alarms per hour, all detectors [1/h]", 1e-9, 1e3),
            ),
            ("warmup", defaults.warmup, _float("Healthy warm-up at the start [s]", 0.5, 3600.0)),
            (
                "block_duration",
                res.block_duration,
                _float("Length of one comparison block [s]", 0.005, 10.0),
            ),
            (
                "sensor_noise",
                0.0,
                _float("Torque-sensor noise of one sample [N m]; 0: learn in warm-up", 0.0, 10.0),
            ),
            (
                "model_error_relative",
                res.model_error_relative,
                _float("Model error relative to the torque, 1 sigma [-]", 0.0, 1.0),
            ),
            (
                "classification_window",
                defaults.classification_window,
                _float("Time after an alarm over which the class is refined [s]", 0.1, 600.0),
            ),
        ]
        for name, value, descriptor in declared:
            self.declare_parameter(name, value, descriptor)
        for name, allowed in TYPES.items():
            if self._str(name) not in allowed:
                raise ParameterException(
                    f"{name} = {self._str(name)!r}: use one of {allowed}", [name]
                )
        noise = self._float("sensor_noise")
        self.settings = Settings(
            residual=ResidualSettings(
                block_duration=self._float("block_duration"),
                sensor_noise=noise if noise > 0.0 else None,
                model_error_relative=self._float("model_error_relative"),
            ),
            false_alarm_rate=self._float("false_alarm_rate"),
            warmup=self._float("warmup"),
            classification_window=self._float("classification_window"),
        )
        self.config = load_config(self._str("config_file") or None)
        self.monitor = HealthMonitor(self.config, self.settings)
        #: Samples received per channel (torque, speed, temperature, preload).
        self.received = dict.fromkeys(("torque", "speed", "temperature", "preload"), 0)
        #: Samples dropped (non-finite, malformed) since start-up.
        self.dropped = 0
        #: Times the monitor was restarted after a stamp went back.
        self.restarts = 0
        #: HealthResidual messages published.
        self.published = 0
        self.last: HealthSample | None = None
        self._last_torque_wall = -math.inf
        self._warned: dict[str, float] = {}
        self._frame_id = self._str("frame_id")
        self._joint = self._str("joint_name")

        qos = QoSProfile(
            history=HistoryPolicy.KEEP_LAST,
            depth=int(self.get_parameter("queue_depth").value),
            reliability=ReliabilityPolicy.BEST_EFFORT,
        )
        self._health_pub = self.create_publisher(HealthResidual, self._str("health_topic"), 100)
        self._diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        if self._str("torque_type") == "WrenchStamped":
            self.create_subscription(
                WrenchStamped, self._str("torque_topic"), self._on_torque_wrench, qos
            )
        else:
            self.create_subscription(Float64, self._str("torque_topic"), self._on_torque_float, qos)
        if self._str("speed_type") == "JointState":
            self.create_subscription(
                JointState, self._str("speed_topic"), self._on_joint_state, qos
            )
        else:
            self.create_subscription(Float64, self._str("speed_topic"), self._on_speed_float, qos)
        self.create_subscription(
            Temperature, self._str("temperature_topic"), self._on_temperature, qos
        )
        if self._str("preload_type") == "WrenchStamped":
            self.create_subscription(
                WrenchStamped, self._str("preload_topic"), self._on_preload_wrench, qos
            )
        else:
            self.create_subscription(
                Float64, self._str("preload_topic"), self._on_preload_float, qos
            )
        self.create_timer(1.0 / self._float("diagnostics_rate_hz"), self._publish_diagnostics)
        self.get_logger().info(
            f"monitoring {self._str('torque_topic')} against {self.monitor.predictor.model.name}"
            f" ({self.config.source}); false-alarm target {self.settings.false_alarm_rate:g}/h; "
            f"publishing {self._health_pub.topic_name}"
        )

    # ------------------------------------------------------------------ helpers
    def _float(self, name: str) -> float:
        return float(self.get_parameter(name).value)

    def _str(self, name: str) -> str:
        return str(self.get_parameter(name).value)

    def _warn(self, kind: str, text: str) -> None:
        """Log a warning at most once per :data:`WARN_THROTTLE` seconds per kind."""
        now = time.monotonic()
        if now - self._warned.get(kind, -math.inf) >= WARN_THROTTLE:
            self._warned[kind] = now
            self.get_logger().warning(text)

    def _now(self) -> float:
        """Node clock [s] (sim time with use_sim_time)."""
        return self.get_clock().now().nanoseconds * 1e-9

    def _feed(self, channel: str, stamp: float, value: float) -> None:
        """Give one sample to the monitor and publish what comes out."""
        self.received[channel] += 1
        if not (math.isfinite(stamp) and math.isfinite(value)):
            self.dropped += 1
            self._warn(channel, f"{channel}: dropped a non-finite sample ({value!r} at {stamp!r})")
            return
        adder = {
            "torque": self.monitor.add_torque,
            "speed": self.monitor.add_speed,
            "temperature": self.monitor.add_temperature,
            "preload": self.monitor.add_preload,
        }[channel]
        try:
            results = adder(stamp, value)
        except StampOrderError as err:  # replay restarted or clock jumped back
            self.restarts += 1
            self._warn("restart", f"{err}; restarting the health monitor")
            self.monitor = HealthMonitor(
                self.config, self.settings, predictor=self.monitor.predictor
            )
            self.last = None
            return
        except BallscrewTwinError as err:
            self.dropped += 1
            self._warn("model", f"{channel} sample not used: {err}")
            return
        for sample in results:
            self._publish(sample)

    def _publish(self, sample: HealthSample) -> None:
        """One HealthResidual (no non-finite numbers: zeros while UNKNOWN)."""
        known = math.isfinite(sample.predicted) and math.isfinite(sample.normalized_residual)
        msg = HealthResidual()
        msg.header.stamp = _time_msg(sample.time)
        msg.header.frame_id = self._frame_id
        msg.signal = "drag_torque"
        msg.measured = sample.measured
        msg.predicted = sample.predicted if known else 0.0
        msg.residual = sample.residual if known else 0.0
        msg.normalized_residual = sample.normalized_residual if known else 0.0
        msg.test_statistic = sample.test_statistic
        msg.threshold = sample.threshold
        msg.verdict = sample.verdict
        msg.fault_class = sample.fault_class
        msg.confidence = sample.confidence
        self._health_pub.publish(msg)
        self.published += 1
        if sample.verdict == FAULT and (self.last is None or self.last.verdict != FAULT):
            alarm = self.monitor.alarm
            detector = alarm.detector if alarm else "?"
            self.get_logger().error(
                f"FAULT at {sample.time:.3f} s by {detector}: likely {sample.fault_class or '?'}"
            )
        self.last = sample

    # ------------------------------------------------------------------ inputs
    def _on_torque_wrench(self, msg: WrenchStamped) -> None:
        self._last_torque_wall = time.monotonic()
        self._feed("torque", _seconds(msg.header.stamp), float(msg.wrench.torque.z))

    def _on_torque_float(self, msg: Float64) -> None:
        self._last_torque_wall = time.monotonic()
        self._feed("torque", self._now(), float(msg.data))

    def _on_joint_state(self, msg: JointState) -> None:
        names = list(msg.name)
        if self._joint in names:
            index = names.index(self._joint)
        elif len(names) <= 1:
            index = 0
        else:
            self.dropped += 1
            self._warn("joint", f"JointState without joint {self._joint!r} (has {names})")
            return
        if index >= len(msg.velocity):
            self.dropped += 1
            self._warn("joint", f"JointState without a velocity for {self._joint!r}")
            return
        self._feed("speed", _seconds(msg.header.stamp), float(msg.velocity[index]))

    def _on_speed_float(self, msg: Float64) -> None:
        self._feed("speed", self._now(), float(msg.data))

    def _on_temperature(self, msg: Temperature) -> None:
        kelvin = celsius_to_kelvin(float(msg.temperature))
        self._feed("temperature", _seconds(msg.header.stamp), kelvin)

    def _on_preload_wrench(self, msg: WrenchStamped) -> None:
        self._feed("preload", _seconds(msg.header.stamp), float(msg.wrench.force.z))

    def _on_preload_float(self, msg: Float64) -> None:
        self._feed("preload", self._now(), float(msg.data))

    # ------------------------------------------------------------------ diagnostics
    def checks(self) -> list[Check]:
        """The node's diagnostic checks: the health verdict and the torque input."""
        age = time.monotonic() - self._last_torque_wall
        last = self.last
        alarm = self.monitor.alarm
        values: list[tuple[str, str]] = [
            ("blocks", str(len(self.monitor.samples))),
            ("received", ", ".join(f"{k} {v}" for k, v in self.received.items())),
            ("dropped samples", str(self.dropped)),
            ("restarts", str(self.restarts)),
        ]
        noise = self.monitor.sensor_variance
        if noise is not None:
            values.append(("sensor noise [N m]", f"{math.sqrt(noise):.3g}"))
        if alarm is not None:
            values += [
                ("alarm time [s]", f"{alarm.time:.3f}"),
                ("detector", alarm.detector),
                ("estimated onset [s]", f"{alarm.onset:.3f}"),
            ]
        aligner = self.monitor.aligner
        missing = [
            s.name for s in (aligner.speed, aligner.temperature, aligner.preload) if not s.stamps
        ]
        if last is None:
            text = "no comparison yet" + (f": waiting for {', '.join(missing)}" if missing else "")
            health = Check("health", STALE, text, tuple(values))
        else:
            text = VERDICT_NAMES[last.verdict]
            if last.fault_class:
                text += f": {last.fault_class} (confidence {last.confidence:.2f})"
            elif last.note:
                text += f" ({last.note})"
            health = Check("health", DIAG_LEVEL[last.verdict], text, tuple(values))
        stale = age > self._float("stale_after")
        torque = Check(
            "torque input",
            STALE if stale else DIAG_OK,
            "no torque received" if not math.isfinite(age) else f"last sample {age:.2f} s ago",
        )
        return [health, torque]

    def _publish_diagnostics(self) -> None:
        self._diag_pub.publish(
            to_message(
                self.checks(),
                node_name=self.get_name(),
                hardware_id=self.config.name,
                stamp=self.get_clock().now().to_msg(),
            )
        )


def run_node(argv: list[str]) -> int:
    """Run :class:`HealthNode` with ROS arguments ``argv`` until shut down; the exit code."""
    rclpy.init(args=argv)
    node: HealthNode | None = None
    executor: SingleThreadedExecutor | None = None
    exit_code = 0
    try:
        node = HealthNode()
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        while executor.context.ok():
            executor.spin_once(timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except (BallscrewTwinError, ParameterException, ValueError) as err:
        print(f"health_node: cannot start: {err}", file=sys.stderr)
        exit_code = 1
    finally:
        try:
            if executor is not None:
                executor.shutdown()
            if node is not None:
                node.destroy_node()
        except KeyboardInterrupt:  # a second Ctrl-C while stopping: stop anyway
            pass
        rclpy.try_shutdown()
    return exit_code


def main(args: list[str] | None = None) -> None:
    """Console script ``health_node`` (accepts ``--ros-args ...``)."""
    raise SystemExit(run_node(sys.argv if args is None else args))


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``ballscrew-twin health-node``."""
    add_ros_arguments(parser, "config/health_node.yaml")


def run(args: argparse.Namespace) -> int:
    """Run the health node until SIGINT/SIGTERM; 0 on a clean stop, 1 if it cannot start."""
    return run_node(ros_argv("ballscrew-twin-health-node", args))


if __name__ == "__main__":
    main()
