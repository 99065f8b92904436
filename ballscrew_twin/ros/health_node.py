"""ROS 2 health-monitor node: bench measurements in, residuals, verdict and /diagnostics out.

Subscribes (best-effort sensor-data QoS with a deep queue, or reliable with
``reliable_inputs``; names and types are parameters):
    ``torque_topic``       geometry_msgs/WrenchStamped (wrench.torque.z) or std_msgs/Float64 [N m]
    ``speed_topic``        sensor_msgs/JointState (velocity of ``joint_name``) or Float64 [rad/s]
    ``temperature_topic``  sensor_msgs/Temperature [deg C], converted to [K]
    ``preload_topic``      geometry_msgs/WrenchStamped (wrench.force.z) or Float64 [N]

Publishes:
    ``health_topic``  ballscrew_twin_msgs/HealthResidual, one per block of torque samples
    ``/diagnostics``  diagnostic_msgs/DiagnosticArray at ``diagnostics_rate_hz`` (wall time)

Services:
    ``~/rearm``       std_srvs/Trigger: forget the alarm and start a fresh monitor with the same
                      settings (its warm-up starts again); the answer says what was cleared

Every sample goes through the same :class:`~ballscrew_twin.health.monitor.HealthMonitor` as
``ballscrew-twin detect``, with the message's header stamp as its time (the node clock for
Float64, which has no header; the node clock follows ``/clock`` with ``use_sim_time``), so a
bag replayed into the node gives the offline verdict. Non-finite samples are dropped with a
warning; a stamp that goes back in time (bag replay restarted, clock jump) restarts the
monitor with a warning. Fields of a HealthResidual other than ``measured`` are 0 while the
verdict is UNKNOWN (nothing non-finite is published).

The verdict and the fault class are logged, and /diagnostics published, whenever they change
(a new alarm at once, other changes at most once per ``log_throttle`` seconds, the latest state
when the pause ends). With ``use_sim_time``, a watchdog on the steady (wall) clock reports
STALE on /diagnostics, and publishes one UNKNOWN HealthResidual, when ``/clock`` has not
advanced for ``clock_timeout`` seconds (replay paused or ended, bench clock lost).

Run: ``health_node --ros-args --params-file config/health_node.yaml`` or
``ballscrew-twin health-node --params-file config/health_node.yaml``.
"""

from __future__ import annotations

import argparse
import math
import sys
import threading
import time
from collections import deque
from typing import Any

import numpy as np
from ballscrew_twin_msgs.msg import HealthResidual
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import ParameterException
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState, Temperature
from std_msgs.msg import Float64
from std_srvs.srv import Trigger  # type: ignore[import-untyped]

from ..errors import BallscrewTwinError, ConfigError
from ..health.baseline import load_baseline
from ..health.commission import commission
from ..health.monitor import HealthMonitor
from ..health.monitor_settings import MonitorSettings as Settings
from ..health.monitor_settings import check_detectors
from ..health.residuals import ResidualSettings, StampOrderError
from ..health.verdicts import FAULT, UNKNOWN, VERDICT_NAMES, WARN, HealthSample
from ..models import friction_response
from ..params import load_config
from ..units import celsius_to_kelvin, seconds_to_stamp, stamp_to_seconds
from . import health_diagnostics
from .command_args import add_ros_arguments, ros_argv
from .diagnostics import Check, to_message
from .health_diagnostics import ClockWatch
from .health_parameters import HEALTH_PARAMETERS, NODE_NAME
from .inputs import check_sample
from .node_parameters import TableNode
from .node_process import run_node_process
from .throttle import Throttle

#: Minimum interval between two warnings of the same kind [s].
WARN_THROTTLE = 2.0
#: Longest period of the steady-clock watchdog (clock check, delayed log lines) [s].
WATCHDOG_PERIOD = 0.1


def _time_msg(seconds: float) -> Time:
    """Seconds [s] as a builtin_interfaces/Time."""
    sec, nanosec = seconds_to_stamp(seconds)
    return Time(sec=sec, nanosec=nanosec)


class HealthNode(TableNode):
    """Thin rclpy node around :class:`HealthMonitor` (parameters in ``config/health_node.yaml``).

    Keyword arguments are passed to :class:`rclpy.node.Node` (``context``,
    ``parameter_overrides``, ``cli_args`` ...).
    """

    def __init__(self, node_name: str = NODE_NAME, **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        self.declare_specs(HEALTH_PARAMETERS)
        noise = self._float("sensor_noise")
        self.settings = Settings(
            residual=ResidualSettings(
                block_duration=self._float("block_duration"),
                sensor_noise=noise if noise > 0.0 else None,
                model_error_relative=self._float("model_error_relative"),
            ),
            false_alarm_rate=self._float("false_alarm_rate"),
            detectors=self._detectors(),
            warmup=self._float("warmup"),
            classification_window=self._float("classification_window"),
            classification_patience=self._float("classification_patience"),
        )
        self.config = load_config(self._str("config_file") or None)
        baseline_file = self._str("baseline_file")
        self.baseline = load_baseline(baseline_file) if baseline_file else None
        self.monitor = HealthMonitor(self.config, self.settings, baseline=self.baseline)
        #: Recent samples per channel for ``~/commission``: (stamp [s], SI value).
        self._recent: dict[str, deque[tuple[float, float]]] = {
            name: deque() for name in ("torque", "speed", "temperature", "preload")
        }
        #: The running commissioning, if any, and the last one's outcome (one line).
        self._commissioning: threading.Thread | None = None
        self.commission_result = (
            "not commissioned" if self.baseline is None else (f"baseline {baseline_file}")
        )
        #: (verdict, fault class) last logged; a change waiting for the log throttle.
        self._logged: tuple[int, str] | None = None
        self._log_wall = -math.inf
        self._log_pending: HealthSample | None = None
        #: Whether the node clock (/clock under use_sim_time) still advances.
        self.clock = ClockWatch(self.get_clock().now().nanoseconds, time.monotonic())
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
        self._throttle = Throttle(WARN_THROTTLE)
        self._frame_id = self._str("frame_id")
        self._joint = self._str("joint_name")

        qos = QoSProfile(
            history=HistoryPolicy.KEEP_LAST,
            depth=int(self.get_parameter("queue_depth").value),
            reliability=ReliabilityPolicy.RELIABLE
            if self.get_parameter("reliable_inputs").value
            else ReliabilityPolicy.BEST_EFFORT,
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
        steady = Clock(clock_type=ClockType.STEADY_TIME)  # runs on when /clock stops
        self.create_timer(
            1.0 / self._float("diagnostics_rate_hz"), self._publish_diagnostics, clock=steady
        )
        self.create_timer(
            min(WATCHDOG_PERIOD, self._float("clock_timeout") / 4.0), self._watchdog, clock=steady
        )
        self.create_service(Trigger, "~/rearm", self._on_rearm)
        self.create_service(Trigger, "~/commission", self._on_commission)
        self.get_logger().info(
            f"monitoring {self._str('torque_topic')} against {self.monitor.twin_name}"
            f" ({self.config.source}); false-alarm target {self.settings.false_alarm_rate:g}/h; "
            f"publishing {self._health_pub.topic_name}"
        )
        if self.monitor.twin_note:
            self.get_logger().warning(self.monitor.twin_note)
        #: The screw's friction response table (:mod:`~ballscrew_twin.models.friction_response`):
        #: a commissioning fits the unit's mu_dry and tau_0 scales with it, and the real-time
        #: twin of a baseline with such scales needs it. Built on a thread when missing.
        self.response_state = "found"
        self._response_build: threading.Thread | None = None
        if friction_response.find_response(self.config) is None:
            self.response_state = "building"
            self._response_build = threading.Thread(
                target=self._build_response, name="friction-response", daemon=True
            )
            self._response_build.start()

    # ------------------------------------------------------------------ helpers
    def _detectors(self) -> tuple[str, ...]:
        """The ``detectors`` parameter, checked by :func:`check_detectors`."""
        try:
            return check_detectors(str(name) for name in self.get_parameter("detectors").value)
        except ConfigError as err:
            raise ParameterException(str(err), ["detectors"]) from err

    def _warn(self, kind: str, text: str) -> None:
        """Log a warning at most once per :data:`WARN_THROTTLE` seconds per kind."""
        if self._throttle.allows(kind):
            self.get_logger().warning(text)

    def _now(self) -> float:
        """Node clock [s] (sim time with use_sim_time)."""
        return self.get_clock().now().nanoseconds * 1e-9

    def _feed(self, channel: str, stamp: float, value: float) -> None:
        """Give one sample to the monitor and publish what comes out."""
        self.received[channel] += 1
        refusal = check_sample(channel, stamp, value)
        if refusal is not None:
            self.dropped += 1
            self._warn(channel, f"dropped: {refusal}")
            return
        recent = self._recent[channel]
        recent.append((stamp, value))
        while recent and recent[0][0] < stamp - self._float("commission_window"):
            recent.popleft()
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
            self._replace_monitor(self._new_monitor())
            return
        except BallscrewTwinError as err:
            self.dropped += 1
            self._warn("model", f"{channel} sample not used: {err}")
            return
        for sample in results:
            self._publish(sample)

    # ------------------------------------------------------------------ monitor (re)creation
    def _new_monitor(self) -> HealthMonitor:
        """A fresh monitor with the node's settings and the unit's baseline (sharing the
        twin's prediction cache)."""
        return HealthMonitor(
            self.config, self.settings, predictor=self.monitor.predictor, baseline=self.baseline
        )

    def _on_commission(
        self, request: Trigger.Request, response: Trigger.Response
    ) -> Trigger.Response:
        """``~/commission``: fit the unit's baseline on the recent samples (in a thread of its
        own: a fit takes seconds); the answer says what it started on."""
        response.success, response.message = self.start_commissioning()
        return response

    def start_commissioning(self) -> tuple[bool, str]:
        """Start fitting the baseline on the samples of the last ``commission_window`` [s];
        (started, one line). The result is logged, shown on /diagnostics, saved to
        ``commission_out`` if set, and the monitor restarts with it."""
        if self._commissioning is not None and self._commissioning.is_alive():
            return False, "a commissioning is already running"
        channels = {
            name: (
                np.array([t for t, _ in samples], dtype=float),
                np.array([v for _, v in samples], dtype=float),
            )
            for name, samples in self._recent.items()
        }
        empty = [name for name, (t, _) in channels.items() if len(t) == 0]
        if empty:
            return False, f"no {', '.join(empty)} samples received yet: nothing to commission on"
        span = float(channels["torque"][0][-1] - channels["torque"][0][0])
        self._commissioning = threading.Thread(
            target=self._commission, args=(channels,), name="commission", daemon=True
        )
        self._commissioning.start()
        self.commission_result = f"commissioning on {span:.1f} s of samples"
        return True, f"commissioning started on {span:.1f} s of samples"

    def _build_response(self) -> None:
        """Build the screw's friction response table into the user cache (its own thread, one
        process: the node's callbacks keep the other core); then a monitor that had to fall
        back to the steady model for want of it restarts on the real-time map."""
        self.get_logger().info(
            f"no friction response table for {self.config.source}: building it (2640 steady "
            "solves, seconds to a minute)"
        )
        start = time.monotonic()
        try:
            _, path = friction_response.ensure_response(self.config, workers=1)
        except (BallscrewTwinError, OSError) as err:  # a failed solve line, a full disk
            self.response_state = f"build failed: {err}"
            self.get_logger().error(f"friction response table: {self.response_state}")
            return
        self.response_state = f"built in {time.monotonic() - start:.0f} s into {path}"
        self.get_logger().info(f"friction response table {self.response_state}")
        if self.monitor.twin_name == "realtime_map":
            return
        fresh = self._new_monitor()
        if fresh.twin_name == "realtime_map":  # else the map itself is missing: keep on
            self._replace_monitor(fresh)
            self.get_logger().info(
                "the monitor restarts on the real-time map (it predicted with the steady "
                "model meanwhile)"
            )

    def _commission(self, channels: dict[str, tuple[np.ndarray, np.ndarray]]) -> None:
        """Fit, then restart the monitor with the baseline (runs in its own thread; waits
        for the friction response table if it is being built, so that the fit has the
        unit's friction scales)."""
        if self._response_build is not None:
            self._response_build.join()
        try:
            result = commission(
                channels,
                self.config,
                self.settings.residual,
                source="live",
                unseen_error=self._float("commission_unseen_error"),
                temperature_error=self._float("commission_temperature_error"),
                shift_extrapolation=self._float("commission_shift_extrapolation"),
                band_reach=self._float("commission_band_reach"),
            )
        except BallscrewTwinError as err:
            self.commission_result = f"commissioning failed: {err}"
            self.get_logger().error(self.commission_result)
            return
        self.baseline = result.baseline
        out = self._str("commission_out")
        saved = ""
        if out:
            try:
                saved = f", saved to {self.baseline.save(out)}"
            except BallscrewTwinError as err:
                saved = f", not saved: {err}"
        b = self.baseline
        self.commission_result = (
            f"commissioned on {b.blocks} blocks: gain {b.torque_gain:.4f}, preload scale "
            f"{b.preload_scale:.3f}, temperature shift {b.temperature_shift:.2f} K, mu_dry scale "
            f"{b.dry_friction_scale:.3f}, tau_0 scale {b.eyring_scale:.3f}, model error "
            f"{b.error_relative:.2%}{saved}"
        )
        self.get_logger().info(self.commission_result)
        self._replace_monitor(self._new_monitor())

    def _replace_monitor(self, monitor: HealthMonitor) -> None:
        """Use ``monitor`` from the next sample on; the verdict and its log start afresh."""
        self.monitor = monitor
        self.last = None
        self._logged = None
        self._log_pending = None

    def _on_rearm(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """``~/rearm``: a fresh monitor; the answer says what was cleared."""
        response.message = self.rearm()
        response.success = True
        return response

    def rearm(self) -> str:
        """Replace the monitor by a fresh one (same settings); what was cleared, one line."""
        old, last = self.monitor, self.last
        alarm = old.alarm
        if alarm is not None:
            c = alarm.classification
            cleared = (
                f"cleared FAULT {c.fault_class or 'unclassified'} (confidence {c.confidence:.2f})"
                f" raised at {alarm.time:.3f} s by {alarm.detector}"
            )
        else:
            state = VERDICT_NAMES[last.verdict] if last is not None else "no verdict yet"
            cleared = f"no alarm to clear (last verdict: {state})"
        text = (
            f"{cleared}; {len(old.samples)} block(s) forgotten; warm-up of "
            f"{self.settings.warmup:g} s restarts with the next sample"
        )
        self._replace_monitor(self._new_monitor())
        self.get_logger().warning(f"re-armed: {text}")
        return text

    # ------------------------------------------------------------------ outputs
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
        self.last = sample
        self._log_change(sample)

    def _log_change(self, sample: HealthSample) -> None:
        """Log the verdict and class when they change: a new alarm at once, anything else at
        most once per ``log_throttle`` (the latest state is logged when the pause ends)."""
        key = (sample.verdict, sample.fault_class)
        if key == self._logged:
            self._log_pending = None
            return
        new_alarm = sample.verdict == FAULT and (self._logged is None or self._logged[0] != FAULT)
        if new_alarm or time.monotonic() - self._log_wall >= self._float("log_throttle"):
            self._log_now(sample)
        else:
            self._log_pending = sample

    def _log_now(self, sample: HealthSample) -> None:
        """One log line for the state of ``sample`` (FAULT: error, WARN: warning, else info),
        and /diagnostics at once."""
        alarm = self.monitor.alarm
        if sample.verdict == FAULT and alarm is not None:
            first = self._logged is None or self._logged[0] != FAULT
            what = f"FAULT at {alarm.time:.3f} s by {alarm.detector}" if first else "FAULT"
            text = f"{what}: likely {sample.fault_class or 'unclassified'}"
            text += f" (confidence {sample.confidence:.2f}, block at {sample.time:.3f} s)"
            self.get_logger().error(text)
        else:
            text = f"{VERDICT_NAMES[sample.verdict]} at {sample.time:.3f} s"
            text += f" ({sample.note})" if sample.note else ""
            if sample.verdict == WARN:  # one call site per severity (rclpy's rule)
                self.get_logger().warning(text)
            else:
                self.get_logger().info(text)
        self._logged = (sample.verdict, sample.fault_class)
        self._log_wall = time.monotonic()
        self._log_pending = None
        self._publish_diagnostics()  # the change on /diagnostics now, not at the next tick

    def _publish_stale(self) -> None:
        """One UNKNOWN HealthResidual at the last clock time: the verdict is stale."""
        msg = HealthResidual()
        msg.header.stamp = _time_msg(self.clock.clock_ns * 1e-9)
        msg.header.frame_id = self._frame_id
        msg.signal = "drag_torque"
        msg.verdict = UNKNOWN
        alarm = self.monitor.alarm
        msg.fault_class = alarm.classification.fault_class if alarm else ""
        self._health_pub.publish(msg)
        self.published += 1

    # ------------------------------------------------------------------ watchdog
    def _sim_time(self) -> bool:
        return bool(self.get_parameter("use_sim_time").value)

    def _watchdog(self) -> None:
        """Steady-clock timer: watch /clock under use_sim_time; log a change held back."""
        now = time.monotonic()
        pending = self._log_pending
        if pending is not None and now - self._log_wall >= self._float("log_throttle"):
            self._log_now(pending)
        clock_ns = self.get_clock().now().nanoseconds
        timeout = self._float("clock_timeout")
        change = self.clock.observe(clock_ns, now, sim_time=self._sim_time(), timeout=timeout)
        if change == "resumed":
            self.get_logger().info(f"/clock advances again ({clock_ns * 1e-9:.3f} s)")
        elif change == "stale":
            self.get_logger().warning(f"{self.clock.text(now)}: STALE")
            self._publish_stale()
            self._publish_diagnostics()

    # ------------------------------------------------------------------ inputs
    def _on_torque_wrench(self, msg: WrenchStamped) -> None:
        self._last_torque_wall = time.monotonic()
        self._feed("torque", stamp_to_seconds(msg.header.stamp), float(msg.wrench.torque.z))

    def _on_torque_float(self, msg: Float64) -> None:
        self._last_torque_wall = time.monotonic()
        self._feed("torque", self._now(), float(msg.data))

    def _on_joint_state(self, msg: JointState) -> None:
        names = list(msg.name)
        if self._joint in names:
            index = names.index(self._joint)
        elif not names:  # an unnamed joint: the screw's
            index = 0
        else:
            self.dropped += 1
            self._warn("joint", f"JointState without joint {self._joint!r}; joints found: {names}")
            return
        if index >= len(msg.velocity):
            self.dropped += 1
            self._warn("joint", f"JointState without a velocity for {self._joint!r}")
            return
        self._feed("speed", stamp_to_seconds(msg.header.stamp), float(msg.velocity[index]))

    def _on_speed_float(self, msg: Float64) -> None:
        self._feed("speed", self._now(), float(msg.data))

    def _on_temperature(self, msg: Temperature) -> None:
        kelvin = celsius_to_kelvin(float(msg.temperature))
        self._feed("temperature", stamp_to_seconds(msg.header.stamp), kelvin)

    def _on_preload_wrench(self, msg: WrenchStamped) -> None:
        self._feed("preload", stamp_to_seconds(msg.header.stamp), float(msg.wrench.force.z))

    def _on_preload_float(self, msg: Float64) -> None:
        self._feed("preload", self._now(), float(msg.data))

    # ------------------------------------------------------------------ diagnostics
    def checks(self) -> list[Check]:
        """The node's diagnostic checks: the health verdict, the torque input and, with
        use_sim_time, /clock (the verdict is STALE while /clock stands still)."""
        now = time.monotonic()
        counts = (
            ("received", ", ".join(f"{k} {v}" for k, v in self.received.items())),
            ("dropped samples", str(self.dropped)),
            ("restarts", str(self.restarts)),
            ("baseline", self.commission_result),
            ("friction response table", self.response_state),
        )
        health = health_diagnostics.health_check(self.monitor, self.last, counts)
        checks = [
            health_diagnostics.stale_health(health, self.clock, now),
            health_diagnostics.torque_check(
                now - self._last_torque_wall, self._float("stale_after")
            ),
        ]
        if self._sim_time():
            checks.append(health_diagnostics.clock_check(self.clock, now))
        return checks

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
    return run_node_process("health_node", argv, HealthNode, _executor)


def _executor(node: HealthNode) -> SingleThreadedExecutor:
    """A single-threaded executor spinning ``node``."""
    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    return executor


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
