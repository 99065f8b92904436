"""ROS 2 node of the ball-screw twin: commanded operating point in, drag torque out.

Subscribes (sensor-data QoS, topic names are parameters and can be remapped):
    ``speed_command``    std_msgs/Float64      screw angular speed [rad/s]
    ``temperature``      sensor_msgs/Temperature  bulk temperature [deg C], converted to [K]
    ``preload_command``  std_msgs/Float64      preload between the nuts [N]

Publishes (reliable, depth 10), at ``publish_rate_hz``:
    ``drag_torque``      ballscrew_twin_msgs/DragTorque  [N m], with the operating point used

A command that is not finite or outside the limits (``limits.*`` parameters) is rejected with a
warning and the last good value is kept; the node never publishes a non-finite number.

Run: ``twin_node --ros-args --params-file config/twin_node.yaml``.
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time
from typing import Any

import rclpy
from ballscrew_twin_msgs.msg import DragTorque
from rcl_interfaces.msg import (
    FloatingPointRange,
    ParameterDescriptor,
    ParameterType,
    SetParametersResult,
)
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import Temperature
from std_msgs.msg import Float64

from ..errors import BallscrewTwinError
from ..models.base import OperatingPoint, SteadyStateModel, TwinOutput
from ..models.catalog import CatalogModel
from ..params import load_config
from .inputs import (
    InputLimits,
    celsius_to_kelvin,
    check_preload,
    check_screw_speed,
    check_temperature,
)

NODE_NAME = "ballscrew_twin"

#: Minimum interval between two identical warnings of the publish loop [s].
WARN_THROTTLE = 1.0


def _float_descriptor(
    description: str, low: float, high: float, *, read_only: bool = False
) -> ParameterDescriptor:
    """Descriptor of a double parameter restricted to [low, high]."""
    return ParameterDescriptor(
        type=ParameterType.PARAMETER_DOUBLE,
        description=description,
        read_only=read_only,
        floating_point_range=[FloatingPointRange(from_value=low, to_value=high, step=0.0)],
    )


def _string_descriptor(description: str, *, read_only: bool = True) -> ParameterDescriptor:
    """Descriptor of a string parameter (read-only by default: used at start-up only)."""
    return ParameterDescriptor(
        type=ParameterType.PARAMETER_STRING, description=description, read_only=read_only
    )


class TwinNode(Node):
    """Thin rclpy node around a steady-state ball-screw model (the catalogue model for now).

    Parameters (see ``config/twin_node.yaml``):
        publish_rate_hz: rate of ``drag_torque`` [Hz], 1..1000, default 100.
        config_file: screw parameter file (YAML); '' = the shipped paper screw. Read-only.
        mu_lit: equivalent friction coefficient of the catalogue formula [-], default 0.002.
        speed_topic, temperature_topic, preload_topic, torque_topic: topic names. Read-only.
        frame_id: ``header.frame_id`` of published messages.
        initial_screw_speed [rad/s], initial_temperature [K], initial_preload [N]: operating
            point used until the first command arrives. Read-only.
        limits.max_screw_speed [rad/s], limits.min_temperature [K], limits.max_temperature [K],
            limits.max_preload [N]: commands outside these are rejected. Read-only.

    Keyword arguments are passed to :class:`rclpy.node.Node` (``context``,
    ``parameter_overrides``, ``cli_args``, ``namespace`` ...).
    """

    def __init__(self, node_name: str = NODE_NAME, **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        defaults = InputLimits()
        self.declare_parameter(
            "publish_rate_hz", 100.0,
            _float_descriptor("Publish rate of drag_torque [Hz]", 1.0, 1000.0))
        self.declare_parameter(
            "config_file", "",
            _string_descriptor("Screw parameter file (YAML); empty: shipped paper screw"))
        self.declare_parameter(
            "mu_lit", 0.002,
            _float_descriptor("Equivalent friction coefficient of the catalogue formula [-]",
                              0.0, 0.5))
        self.declare_parameter(
            "speed_topic", "speed_command",
            _string_descriptor("Input: screw speed, std_msgs/Float64 [rad/s]"))
        self.declare_parameter(
            "temperature_topic", "temperature",
            _string_descriptor("Input: temperature, sensor_msgs/Temperature [deg C]"))
        self.declare_parameter(
            "preload_topic", "preload_command",
            _string_descriptor("Input: preload, std_msgs/Float64 [N]"))
        self.declare_parameter(
            "torque_topic", "drag_torque",
            _string_descriptor("Output: ballscrew_twin_msgs/DragTorque [N m]"))
        self.declare_parameter(
            "frame_id", "ball_screw",
            _string_descriptor("header.frame_id of published messages", read_only=False))
        self.declare_parameter(
            "initial_screw_speed", 0.0,
            _float_descriptor("Screw speed until the first command [rad/s]",
                              -defaults.max_screw_speed, defaults.max_screw_speed,
                              read_only=True))
        self.declare_parameter(
            "initial_temperature", 293.15,
            _float_descriptor("Temperature until the first measurement [K]",
                              defaults.min_temperature, defaults.max_temperature,
                              read_only=True))
        self.declare_parameter(
            "initial_preload", 1500.0,
            _float_descriptor("Preload until the first command [N]",
                              0.0, defaults.max_preload, read_only=True))
        self.declare_parameter(
            "limits.max_screw_speed", defaults.max_screw_speed,
            _float_descriptor("Largest accepted |screw speed| [rad/s]", 1.0, 1.0e4,
                              read_only=True))
        self.declare_parameter(
            "limits.min_temperature", defaults.min_temperature,
            _float_descriptor("Lowest accepted temperature [K]", 150.0, 400.0, read_only=True))
        self.declare_parameter(
            "limits.max_temperature", defaults.max_temperature,
            _float_descriptor("Highest accepted temperature [K]", 250.0, 700.0, read_only=True))
        self.declare_parameter(
            "limits.max_preload", defaults.max_preload,
            _float_descriptor("Largest accepted preload [N]", 1.0, 1.0e6, read_only=True))

        self.limits = InputLimits(
            max_screw_speed=self._float("limits.max_screw_speed"),
            min_temperature=self._float("limits.min_temperature"),
            max_temperature=self._float("limits.max_temperature"),
            max_preload=self._float("limits.max_preload"),
        )
        config_file = self._str("config_file")
        self.config = load_config(config_file or None)
        self.model: SteadyStateModel = CatalogModel(self.config, mu_lit=self._float("mu_lit"))

        self.operating_point = OperatingPoint(
            screw_speed=self._float("initial_screw_speed"),
            temperature=self._float("initial_temperature"),
            preload=self._float("initial_preload"),
        )
        self.operating_point.validate()
        #: Number of commands rejected since start-up.
        self.rejected_commands = 0
        #: Number of drag_torque messages published since start-up.
        self.published_count = 0
        self._frame_id = self._str("frame_id")

        self._torque_pub = self.create_publisher(DragTorque, self._str("torque_topic"), 10)
        self.create_subscription(
            Float64, self._str("speed_topic"), self._on_speed, qos_profile_sensor_data)
        self.create_subscription(
            Temperature, self._str("temperature_topic"), self._on_temperature,
            qos_profile_sensor_data)
        self.create_subscription(
            Float64, self._str("preload_topic"), self._on_preload, qos_profile_sensor_data)
        self._period = 1.0 / self._float("publish_rate_hz")
        self._timer = self.create_timer(self._period, self._on_timer)

        # Registered after the declarations: they validate and apply run-time changes only.
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)

        self.get_logger().info(
            f"model {self.model.name} with {self.config.source}; publishing "
            f"{self._torque_pub.topic_name} at {1.0 / self._period:g} Hz; initial "
            f"{self._describe(self.operating_point)}")

    # ------------------------------------------------------------------ parameters
    def _float(self, name: str) -> float:
        """Value of a double parameter."""
        return float(self.get_parameter(name).value)

    def _str(self, name: str) -> str:
        """Value of a string parameter."""
        return str(self.get_parameter(name).value)

    def _validate_parameters(self, params: list[Parameter]) -> SetParametersResult:
        """Check run-time changes beyond the descriptor ranges (which rclpy enforces)."""
        for param in params:
            if param.name == "mu_lit":
                try:
                    CatalogModel(self.config, mu_lit=float(param.value))
                except (ValueError, BallscrewTwinError) as err:
                    return SetParametersResult(successful=False, reason=str(err))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, params: list[Parameter]) -> None:
        """Apply run-time parameter changes that passed validation."""
        for param in params:
            if param.name == "mu_lit":
                self.model = CatalogModel(self.config, mu_lit=float(param.value))
                self.get_logger().info(f"mu_lit = {param.value:g}: model rebuilt")
            elif param.name == "publish_rate_hz":
                self._period = 1.0 / float(param.value)
                self.destroy_timer(self._timer)
                self._timer = self.create_timer(self._period, self._on_timer)
                self.get_logger().info(f"publish rate now {param.value:g} Hz")
            elif param.name == "frame_id":
                self._frame_id = str(param.value)

    # ------------------------------------------------------------------ inputs
    def _reject(self, reason: str) -> None:
        """Count and log a rejected command; the last good value stays in force."""
        self.rejected_commands += 1
        self.get_logger().warning(f"command rejected, keeping last good value: {reason}")

    def _replace(self, **changes: float) -> None:
        """Replace fields of the operating point (the values are already validated)."""
        self.operating_point = dataclasses.replace(self.operating_point, **changes)

    def _on_speed(self, msg: Float64) -> None:
        """Screw speed command [rad/s]."""
        value = float(msg.data)
        reason = check_screw_speed(value, self.limits)
        if reason is not None:
            self._reject(reason)
            return
        self._replace(screw_speed=value)

    def _on_temperature(self, msg: Temperature) -> None:
        """Temperature measurement [deg C], stored in [K]."""
        value = celsius_to_kelvin(float(msg.temperature))
        reason = check_temperature(value, self.limits)
        if reason is not None:
            self._reject(f"{reason} (received {msg.temperature!r} deg C)")
            return
        self._replace(temperature=value)

    def _on_preload(self, msg: Float64) -> None:
        """Preload command [N]."""
        value = float(msg.data)
        reason = check_preload(value, self.limits)
        if reason is not None:
            self._reject(reason)
            return
        self._replace(preload=value)

    # ------------------------------------------------------------------ output
    def _on_timer(self) -> None:
        """Evaluate the model at the current operating point and publish the drag torque."""
        op = self.operating_point
        start = time.perf_counter()
        try:
            out = self.model.evaluate(op)
        except (BallscrewTwinError, ValueError, ArithmeticError) as err:
            self.get_logger().error(
                f"model {self.model.name} failed at {self._describe(op)}: {err}",
                throttle_duration_sec=WARN_THROTTLE)
            return
        elapsed = time.perf_counter() - start
        # Simulated time per wall time (>= 1 keeps up); a compute time below the clock's
        # resolution counts as one nanosecond.
        msg = self.to_message(out, op, real_time_factor=self._period / max(elapsed, 1e-9))
        if msg is None:
            self.get_logger().error(
                f"model {self.model.name} returned a non-finite torque at "
                f"{self._describe(op)}; not published", throttle_duration_sec=WARN_THROTTLE)
            return
        self._torque_pub.publish(msg)
        self.published_count += 1

    def to_message(
        self, out: TwinOutput, op: OperatingPoint, *, real_time_factor: float
    ) -> DragTorque | None:
        """Build the DragTorque message of one model output, or None if any value is not finite.

        Args:
            out: model output [N m].
            op: operating point the output was computed at (SI).
            real_time_factor: publish period / model compute time, >= 1 keeps up [-].
        """
        b = out.breakdown
        values = {
            "total": out.drag_torque,
            "nut_master": out.nut_torque[0],
            "nut_slave": out.nut_torque[1],
            "lubricant_shear": b.lubricant_shear,
            "dry_contact": b.dry_contact,
            "rolling_resistance": b.rolling_resistance,
            "hysteresis": b.hysteresis,
            "curvature": b.curvature,
            "spin": b.spin,
            "real_time_factor": real_time_factor,
            "screw_speed": op.screw_speed,
            "temperature": op.temperature,
            "preload": op.preload,
        }
        floats = {name: float(value) for name, value in values.items()}
        if not all(math.isfinite(v) for v in floats.values()):
            return None
        msg = DragTorque(fidelity=out.fidelity, **floats)
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.header.frame_id = self._frame_id
        return msg

    @staticmethod
    def _describe(op: OperatingPoint) -> str:
        """Human-readable operating point."""
        return (f"speed {op.screw_speed:g} rad/s, temperature {op.temperature:g} K, "
                f"preload {op.preload:g} N")


def main(args: list[str] | None = None) -> None:
    """Console script ``twin_node``: run :class:`TwinNode` until SIGINT/SIGTERM.

    Accepts ROS arguments, e.g. ``twin_node --ros-args --params-file config/twin_node.yaml``.
    """
    rclpy.init(args=sys.argv if args is None else args)
    node: TwinNode | None = None
    executor = SingleThreadedExecutor()
    exit_code = 0
    try:
        node = TwinNode()
        executor.add_node(node)
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except (BallscrewTwinError, ParameterException, ValueError) as err:
        # Bad parameter file, screw configuration or initial operating point: say which.
        print(f"twin_node: cannot start: {err}", file=sys.stderr)
        exit_code = 1
    finally:
        # Stop the executor before destroying the node it waits on: destroying a node under a
        # live executor crashed the process (SIGSEGV) in 3 of 20 SIGINT stops.
        executor.shutdown()
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    if exit_code:
        raise SystemExit(exit_code)


if __name__ == "__main__":
    main()
