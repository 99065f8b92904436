"""ROS 2 node of the ball-screw twin: the simulator stepped in real time on ROS topics.

Subscribes (topic names, message types and QoS are parameters; see ``config/twin_node.yaml``):
    ``speed_command``       std_msgs/Float64 or sensor_msgs/JointState (velocity) [rad/s]
    ``temperature``         sensor_msgs/Temperature [deg C], converted to [K] on arrival
    ``preload_command``     std_msgs/Float64 or geometry_msgs/WrenchStamped (force.z) [N]
    ``axial_load_command``  std_msgs/Float64 or geometry_msgs/WrenchStamped (force.z) [N],
                            optional external axial load (default 0 N)
``input_preset: bench`` makes the input defaults those of the bench-bag schema (README):
``/bench/joint_states`` (JointState, joint ``screw``), ``/bench/temperature``, ``/bench/preload``
and ``/bench/axial_load`` (WrenchStamped), so a replayed bench bag drives the twin as it is.

Publishes:
    ``drag_torque``      ballscrew_twin_msgs/DragTorque every simulation tick (default 1 kHz),
                         stamped with the tick's time, with breakdown, fidelity, real-time factor
    ``contact_states``   ballscrew_twin_msgs/ContactStateArray at ``contact_rate_hz`` (default
                         100 Hz), every sphere the model resolves
    ``/diagnostics``     diagnostic_msgs/DiagnosticArray at ``diagnostics_rate_hz`` (1 Hz): model
                         in use and why, real time (late/skipped ticks, latency), each input
                         (stale, rejected), validity notes of the model, the real-time table
                         (which one serves, build progress, tables refused and why)

The real-time model needs a table of the screw's steady state (``ros/tables.py``). For a screw
without one (a user's ``config_file``), the node serves a small preview table built in seconds
and builds the full table in ``table_workers`` niced processes meanwhile (progress on the
console and on /diagnostics), caches it in the user cache under the parameter set's
fingerprint and switches to it when it is ready; the next start finds it there.

The simulation keeps a fixed step locked to the node's clock (wall time, or ``/clock`` with
``use_sim_time``): it catches up after a short stall, skips ticks (and counts them) when far
behind, restarts on a clock jump, and under ``fidelity: auto`` steps down to a cheaper model
when the current one does not fit into the step budget. A command that is not finite,
implausible, out of order or stale is rejected with a log line and a diagnostic, the last good
value stays in force; the node never publishes a non-finite number.

Run: ``twin_node --ros-args --params-file config/twin_node.yaml``.
"""

from __future__ import annotations

import math
import signal
import sys
import threading
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import rclpy
from ballscrew_twin_msgs.msg import ContactStateArray, DragTorque
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
from rcl_interfaces.msg import (
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    ParameterType,
    SetParametersResult,
)
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import ParameterException
from rclpy.executors import Executor, ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, qos_profile_sensor_data
from rclpy.timer import Timer
from sensor_msgs.msg import JointState, Temperature
from std_msgs.msg import Float64

from ..errors import BallscrewTwinError
from ..health.bags import BenchTopics
from ..models.base import ContactStates, OperatingPoint, TwinOutput
from ..models.validity import CELSIUS_ZERO, all_finite, celsius_to_kelvin
from ..params import load_config
from . import cdr, diagnostics, fidelity
from .executors import EXECUTORS, make_executor, spin
from .inputs import (
    NS_PER_S,
    InputChannel,
    InputLimits,
    check_axial_load,
    check_preload,
    check_screw_speed,
    check_stamp,
    check_temperature,
)
from .scheduler import TickScheduler
from .tables import RealTimeTables
from .tick_thread import TickThread, prepare_process

NODE_NAME = "ballscrew_twin"
#: ``header.frame_id`` of the screw, the one of every message and bag of the project (the
#: simulation writer, the bench-data generator and the health node use the same).
SCREW_FRAME_ID = "screw"
#: What drives the ticks on wall time (parameter ``tick_source``); under ``use_sim_time`` the
#: executor's timer always does (it follows ``/clock``).
TICK_SOURCES = ("thread", "executor")
#: A tick published within this time of its due time is on time [ns].
ON_TIME_NS = 1_000_000
#: Default share of ticks on time below which ``real time`` is WARN [-] (parameter
#: ``min_on_time_share``). A 2-core machine shared with other work keeps 99.3 % on average,
#: and a bare sleep loop 99.7 % (docs/benchmarks.md): 99.9 % warned every second there.
MIN_ON_TIME_SHARE = 0.98
#: Minimum interval between two log lines about the same input or failure [s].
LOG_THROTTLE = 1.0
#: Windows (of one simulated second) in a row in which the model's mean step time exceeds the
#: step budget before ``fidelity: auto`` steps down [-].
OVER_BUDGET_WINDOWS = 2
#: Longest start-up phase (steady clock from the node's creation) [ns]: ticks skipped before the
#: first tick on time and within this time are start-up (loading and warming the model up),
#: counted apart and not a warning.
STARTUP_GRACE_NS = 10 * NS_PER_S
#: Interval at which the node looks whether the table being built is ready [s].
TABLE_POLL = 0.5
#: Substrings of model notes that are validity warnings (outside the validated envelope).
VALIDITY_WORDS = ("validity:", "outside", "clamped", "blended", "failed", "not converged")


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


def _int_descriptor(description: str, low: int, high: int) -> ParameterDescriptor:
    """Descriptor of an integer parameter restricted to [low, high]."""
    return ParameterDescriptor(
        type=ParameterType.PARAMETER_INTEGER,
        description=description,
        integer_range=[IntegerRange(from_value=low, to_value=high, step=1)],
    )


def _string_descriptor(
    description: str, *, read_only: bool = True, choices: tuple[str, ...] = ()
) -> ParameterDescriptor:
    """Descriptor of a string parameter (read-only by default: used at start-up only)."""
    constraints = f"one of: {', '.join(choices)}" if choices else ""
    return ParameterDescriptor(
        type=ParameterType.PARAMETER_STRING,
        description=description,
        read_only=read_only,
        additional_constraints=constraints,
    )


#: Message types of a force input: std_msgs/Float64 (data) or geometry_msgs/WrenchStamped
#: (wrench.force.z, header stamp checked) [N].
FORCE_TYPES = ("float64", "wrench_stamped")
_BENCH = BenchTopics()
#: Defaults of the input parameters per ``input_preset``: the command topics the demo publishes,
#: or the bench-bag schema of the README (what ``bench-data generate`` writes and ``replay``
#: plays; the axial load is not in the generated bags, so it stays 0 N unless published).
INPUT_PRESETS: dict[str, dict[str, str]] = {
    "commands": {
        "speed_topic": "speed_command",
        "speed_type": "float64",
        "speed_joint": "",
        "temperature_topic": "temperature",
        "preload_topic": "preload_command",
        "preload_type": "float64",
        "axial_load_topic": "axial_load_command",
        "axial_load_type": "float64",
    },
    "bench": {
        "speed_topic": _BENCH.speed,
        "speed_type": "joint_state",
        "speed_joint": _BENCH.joint_name,
        "temperature_topic": _BENCH.temperature,
        "preload_topic": _BENCH.preload,
        "preload_type": "wrench_stamped",
        "axial_load_topic": "/bench/axial_load",
        "axial_load_type": "wrench_stamped",
    },
}

#: String parameters restricted to a set of values.
CHOICES: dict[str, tuple[str, ...]] = {
    "fidelity": fidelity.FIDELITY_MODES,
    "steady_mode": ("auto", "symmetric", "full"),
    "input_preset": tuple(INPUT_PRESETS),
    "speed_type": ("float64", "joint_state"),
    "preload_type": FORCE_TYPES,
    "axial_load_type": FORCE_TYPES,
    "input_qos": ("sensor_data", "reliable"),
    "executor": EXECUTORS,
    "tick_source": TICK_SOURCES,
}
#: Parameters whose change rebuilds the model.
MODEL_PARAMETERS = ("fidelity", "tolerance", "steady_mode", "mu_lit", "realtime_map")
#: Fidelity parameter values for which a missing real-time table is built.
TABLE_FIDELITIES = ("auto", "realtime")
#: Parameters whose change restarts the tick schedule.
RATE_PARAMETERS = ("sim_rate_hz", "contact_rate_hz", "max_catch_up_ticks")


@dataclass
class TickWindow:
    """Counters of the ticks since the last diagnostics message (and since start-up)."""

    ticks: int = 0
    late: int = 0
    skipped: int = 0
    failures: int = 0
    step_time_sum: float = 0.0  # s
    step_time_max: float = 0.0  # s
    latencies_ns: list[int] = field(default_factory=list)

    def add(self, step_time: float, latency_ns: int) -> None:
        """Book one published tick: model step time [s], publish latency [ns]."""
        self.ticks += 1
        self.step_time_sum += step_time
        self.step_time_max = max(self.step_time_max, step_time)
        self.latencies_ns.append(latency_ns)
        if latency_ns > ON_TIME_NS:
            self.late += 1


def torque_values(out: TwinOutput) -> tuple[float, ...]:
    """The nine torques of ``out`` in DragTorque's order (total, master, slave, then the
    breakdown: lubricant shear, dry contact, rolling resistance, hysteresis, curvature,
    spin) [N m]."""
    b = out.breakdown
    return (
        out.drag_torque,
        out.nut_torque[0],
        out.nut_torque[1],
        b.lubricant_shear,
        b.dry_contact,
        b.rolling_resistance,
        b.hysteresis,
        b.curvature,
        b.spin,
    )


def _finite_output(out: TwinOutput) -> bool:
    """Whether every number of ``out`` that goes into the torque message is finite."""
    return all(math.isfinite(v) for v in torque_values(out))


class TwinNode(Node):
    """The twin's simulator on ROS 2 topics, stepped at a fixed rate in step with the clock.

    Parameters (ranges in the descriptors; see ``config/twin_node.yaml`` for all):
        sim_rate_hz: simulation step rate and ``drag_torque`` rate [Hz], default 1000.
        contact_rate_hz: ``contact_states`` rate [Hz] (0: off), <= sim_rate_hz, default 100.
        diagnostics_rate_hz: ``/diagnostics`` rate [Hz], default 1.
        fidelity: auto, realtime, quasi_static or catalog (run-time changeable).
        tolerance, steady_mode, mu_lit: settings of the models (run-time changeable).
        step_budget: share of the step a model may take before auto steps down [-].
        max_catch_up_ticks: most overdue ticks run at once; more are skipped [-].
        stale_after [s], max_stamp_age [s]: input freshness checks.
        config_file, topics, speed_type, speed_joint, input_qos, initial_*, limits.*,
            executor: read at start-up only.

    Keyword arguments are passed to :class:`rclpy.node.Node` (``context``,
    ``parameter_overrides``, ``cli_args``, ``namespace`` ...).
    """

    def __init__(self, node_name: str = NODE_NAME, **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        self._declare_parameters()
        #: Whether the node's clock is wall time (not /clock); kept up by _start_schedule.
        self._wall_time = not self.get_parameter("use_sim_time").value
        self.config = load_config(self._str("config_file") or None)
        max_speed = self._float("limits.max_screw_speed") or self.config.screw.critical_speed
        self.limits = InputLimits(
            max_screw_speed=max_speed,
            min_temperature=self._float("limits.min_temperature"),
            max_temperature=self._float("limits.max_temperature"),
            max_preload=self._float("limits.max_preload"),
            max_axial_load=self._float("limits.max_axial_load"),
        )
        for name, check in (
            ("initial_screw_speed", check_screw_speed),
            ("initial_temperature", check_temperature),
            ("initial_preload", check_preload),
        ):
            if (reason := check(self._float(name), self.limits)) is not None:
                raise ValueError(f"parameter {name}: {reason}")
        self.speed = InputChannel("screw speed", "rad/s", self._float("initial_screw_speed"))
        self.temperature = InputChannel("temperature", "K", self._float("initial_temperature"))
        self.preload = InputChannel("preload", "N", self._float("initial_preload"))
        self.axial_load = InputChannel("axial load", "N", 0.0)
        self.channels = (self.speed, self.temperature, self.preload, self.axial_load)
        self.operating_point = self._current_op()
        self.operating_point.validate()

        self.tables = RealTimeTables(
            self.config,
            self._str("realtime_map"),
            int(self.get_parameter("table_workers").value),
            self.get_logger().info,
            wanted=self._str("fidelity") in TABLE_FIDELITIES,
        )
        settings = self._model_settings({})
        self.choice = fidelity.choose(self._str("fidelity"), settings)
        self.fallback = fidelity.build("catalog", settings)
        self._pending: tuple[fidelity.ModelChoice, Any] | None = None
        self.model_switches = 0
        self.model_failures = 0
        self.choice.model.reset(self.operating_point)
        self.fallback.reset(self.operating_point)
        self.last_output: TwinOutput | None = None

        # Totals since start-up (the window counters restart with each diagnostics message).
        self.published_count = 0
        self.contact_count = 0
        self.rejected_commands = 0
        self.clock_jumps_back = 0
        self.clock_jumps_forward = 0
        self.skipped_total = 0
        #: Ticks skipped during start-up (before the first tick on time; not a warning).
        self.startup_skipped = 0
        self._startup_ends_ns = time.monotonic_ns() + STARTUP_GRACE_NS
        self.late_total = 0
        self.window = TickWindow()
        self._window_start_ns = self._now_ns()
        self._auto_window = TickWindow()
        #: Consecutive review windows with the model over its step budget.
        self._over_budget = 0
        self._last_log: dict[str, float] = {}
        #: Rejections per input already reported on /diagnostics.
        self._rejected_seen: dict[str, int] = {}
        #: Messages per input already counted on /diagnostics.
        self._received_seen: dict[str, int] = {}
        #: If set, every tick's publish latency [ns] is appended (benchmarks).
        self.latency_log: list[int] | None = None
        self._frame_id = self._str("frame_id")
        self._torque_encoder = cdr.DragTorqueEncoder(self._frame_id)

        qos: QoSProfile | int = (
            qos_profile_sensor_data if self._str("input_qos") == "sensor_data" else 10
        )
        self._torque_pub = self.create_publisher(DragTorque, self._str("torque_topic"), 10)
        self._contact_pub = self.create_publisher(ContactStateArray, self._str("contact_topic"), 5)
        self._diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        if self._str("speed_type") == "joint_state":
            self._speed_joint = self._str("speed_joint")
            self.create_subscription(
                JointState, self._str("speed_topic"), self._on_joint_state, qos
            )
        else:
            self.create_subscription(Float64, self._str("speed_topic"), self._on_speed, qos)
        self.create_subscription(
            Temperature, self._str("temperature_topic"), self._on_temperature, qos
        )
        for name, on_float, on_wrench in (
            ("preload", self._on_preload, self._on_preload_wrench),
            ("axial_load", self._on_axial_load, self._on_axial_load_wrench),
        ):
            topic = self._str(f"{name}_topic")
            if not topic:  # the axial load may be switched off
                continue
            if self._str(f"{name}_type") == "wrench_stamped":
                self.create_subscription(WrenchStamped, topic, on_wrench, qos)
            else:
                self.create_subscription(Float64, topic, on_float, qos)

        #: Held while ticks run and while anything they read is changed (parameters,
        #: inputs, diagnostics windows): the ticks may run on a thread of their own.
        self.tick_lock = threading.Lock()
        self.tick_errors = 0
        self._timer: Timer | None = None
        self._tick_thread: TickThread | None = None
        self._start_schedule()
        # On the steady clock: diagnostics go on (and say so) while a replay's /clock pauses.
        self._diag_timer = self.create_timer(
            1.0 / self._float("diagnostics_rate_hz"),
            self._publish_diagnostics,
            clock=Clock(clock_type=ClockType.STEADY_TIME),
        )
        self._table_timer: Timer | None = None
        if self.tables.building:
            self._table_timer = self.create_timer(
                TABLE_POLL, self._take_table, clock=Clock(clock_type=ClockType.STEADY_TIME)
            )

        # Registered after the declarations: they validate and apply run-time changes only.
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)

        self.get_logger().info(
            f"model {self.choice.model.name} ({self.choice.reason}) with {self.config.source}; "
            f"publishing {self._torque_pub.topic_name} at {self.sim_rate:g} Hz, "
            f"{self._contact_pub.topic_name} at {self._float('contact_rate_hz'):g} Hz; initial "
            f"{self._describe(self.operating_point)}"
        )

    # ------------------------------------------------------------------ parameters
    def _declare_parameters(self) -> None:
        """Declare every parameter with its descriptor (ranges, read-only, choices)."""
        d = InputLimits()
        fd = _float_descriptor
        sd = _string_descriptor
        self.declare_parameter(
            "input_preset",
            "commands",
            sd(
                "Defaults of the input topics and types: commands (speed_command ...) or bench "
                "(the bench-bag schema: /bench/joint_states ...); each can be set on its own",
                choices=CHOICES["input_preset"],
            ),
        )
        preset_name = self._str("input_preset")
        if preset_name not in INPUT_PRESETS:
            raise ValueError(
                f"parameter input_preset = {preset_name!r} is not one of {', '.join(INPUT_PRESETS)}"
            )
        preset = INPUT_PRESETS[preset_name]
        params: list[tuple[str, Any, ParameterDescriptor]] = [
            (
                "sim_rate_hz",
                1000.0,
                fd("Simulation step rate and drag_torque rate [Hz]", 1.0, 2000.0),
            ),
            (
                "contact_rate_hz",
                100.0,
                fd("contact_states rate [Hz], 0 = off, <= sim_rate_hz", 0.0, 2000.0),
            ),
            ("diagnostics_rate_hz", 1.0, fd("/diagnostics rate [Hz]", 0.1, 10.0, read_only=True)),
            (
                "fidelity",
                "auto",
                sd(
                    "Model: auto, realtime, quasi_static or catalog",
                    read_only=False,
                    choices=CHOICES["fidelity"],
                ),
            ),
            ("tolerance", 1e-10, fd("Convergence limit of the steady solve [-]", 1e-14, 1e-3)),
            (
                "steady_mode",
                "auto",
                sd(
                    "Spheres the steady model solves",
                    read_only=False,
                    choices=CHOICES["steady_mode"],
                ),
            ),
            ("mu_lit", 0.002, fd("Friction coefficient of the catalogue formula [-]", 0.0, 0.5)),
            (
                "step_budget",
                0.5,
                fd("Share of the step a model may take before auto steps down [-]", 0.05, 1.0),
            ),
            (
                "min_on_time_share",
                MIN_ON_TIME_SHARE,
                fd(
                    "real time on /diagnostics is WARN when a smaller share of the ticks is "
                    "published within 1 ms of its due time [-]",
                    0.0,
                    1.0,
                ),
            ),
            (
                "max_catch_up_ticks",
                20,
                _int_descriptor("Most overdue ticks run at once; more are skipped [-]", 1, 1000),
            ),
            (
                "stale_after",
                1.0,
                fd("An input with no message for this long is stale [s]", 0.01, 3600.0),
            ),
            (
                "max_stamp_age",
                1.0,
                fd("Largest |clock - header stamp| accepted [s], 0 = off", 0.0, 3600.0),
            ),
            (
                "realtime_map",
                "",
                sd(
                    "Steady-state map of the real-time model (.npz); empty: the packaged one",
                    read_only=False,
                ),
            ),
            ("config_file", "", sd("Screw parameter file (YAML); empty: shipped paper screw")),
            (
                "table_workers",
                2,
                ParameterDescriptor(
                    type=ParameterType.PARAMETER_INTEGER,
                    description="Processes that build the real-time table of a screw without "
                    "one (niced; a preview table serves meanwhile); 0: never build",
                    read_only=True,
                    integer_range=[IntegerRange(from_value=0, to_value=64, step=1)],
                ),
            ),
            (
                "executor",
                "single_threaded",
                sd("Executor of the twin_node process", choices=EXECUTORS),
            ),
            (
                "tick_source",
                "thread",
                sd(
                    "What runs the ticks on wall time: a thread of their own or the executor's "
                    "timer (under use_sim_time always the timer)",
                    choices=TICK_SOURCES,
                ),
            ),
            (
                "thread_priority",
                0,
                ParameterDescriptor(
                    type=ParameterType.PARAMETER_INTEGER,
                    description="SCHED_FIFO priority of the tick thread, 1..99; 0: normal "
                    "scheduling (needs CAP_SYS_NICE or an rtprio limit; refused: logged)",
                    read_only=True,
                    integer_range=[IntegerRange(from_value=0, to_value=99, step=1)],
                ),
            ),
            ("speed_topic", preset["speed_topic"], sd("Input: screw speed [rad/s]")),
            (
                "speed_type",
                preset["speed_type"],
                sd("Message type of the speed input", choices=CHOICES["speed_type"]),
            ),
            (
                "speed_joint",
                preset["speed_joint"],
                sd("JointState joint whose velocity is the screw speed; empty: the first"),
            ),
            (
                "temperature_topic",
                preset["temperature_topic"],
                sd("Input: sensor_msgs/Temperature [deg C]"),
            ),
            ("preload_topic", preset["preload_topic"], sd("Input: preload [N]")),
            (
                "preload_type",
                preset["preload_type"],
                sd(
                    "Message type of the preload: float64 (data) or wrench_stamped (force.z)",
                    choices=FORCE_TYPES,
                ),
            ),
            (
                "axial_load_topic",
                preset["axial_load_topic"],
                sd("Input: external axial load along +z [N]; empty: not subscribed"),
            ),
            (
                "axial_load_type",
                preset["axial_load_type"],
                sd(
                    "Message type of the axial load: float64 (data) or wrench_stamped (force.z)",
                    choices=FORCE_TYPES,
                ),
            ),
            (
                "input_qos",
                "sensor_data",
                sd(
                    "QoS of the inputs: sensor_data (best effort) or reliable",
                    choices=CHOICES["input_qos"],
                ),
            ),
            ("torque_topic", "drag_torque", sd("Output: ballscrew_twin_msgs/DragTorque [N m]")),
            (
                "contact_topic",
                "contact_states",
                sd("Output: ballscrew_twin_msgs/ContactStateArray"),
            ),
            (
                "frame_id",
                SCREW_FRAME_ID,
                sd("header.frame_id of published messages", read_only=False),
            ),
            (
                "initial_screw_speed",
                0.0,
                fd("Screw speed until the first command [rad/s]", -1.0e4, 1.0e4, read_only=True),
            ),
            (
                "initial_temperature",
                293.15,
                fd("Temperature until the first measurement [K]", 150.0, 700.0, read_only=True),
            ),
            (
                "initial_preload",
                1500.0,
                fd("Preload until the first command [N]", 0.0, 1.0e6, read_only=True),
            ),
            (
                "limits.max_screw_speed",
                0.0,
                fd(
                    "Largest accepted |screw speed| [rad/s]; 0: the screw's critical speed",
                    0.0,
                    1.0e4,
                    read_only=True,
                ),
            ),
            (
                "limits.min_temperature",
                d.min_temperature,
                fd("Lowest accepted temperature [K]", 150.0, 400.0, read_only=True),
            ),
            (
                "limits.max_temperature",
                d.max_temperature,
                fd("Highest accepted temperature [K]", 250.0, 700.0, read_only=True),
            ),
            (
                "limits.max_preload",
                d.max_preload,
                fd("Largest accepted preload [N]", 1.0, 1.0e6, read_only=True),
            ),
            (
                "limits.max_axial_load",
                d.max_axial_load,
                fd("Largest accepted |axial load| [N]", 1.0, 1.0e6, read_only=True),
            ),
        ]
        for name, default, descriptor in params:
            self.declare_parameter(name, default, descriptor)
        for name, choices in CHOICES.items():
            if self._str(name) not in choices:
                raise ValueError(
                    f"parameter {name} = {self._str(name)!r} is not one of {', '.join(choices)}"
                )
        if self._float("contact_rate_hz") > self._float("sim_rate_hz"):
            raise ValueError(
                f"parameter contact_rate_hz = {self._float('contact_rate_hz'):g} Hz exceeds "
                f"sim_rate_hz = {self._float('sim_rate_hz'):g} Hz"
            )

    def _float(self, name: str) -> float:
        """Value of a double parameter."""
        return float(self.get_parameter(name).value)

    def _str(self, name: str) -> str:
        """Value of a string parameter."""
        return str(self.get_parameter(name).value)

    def _value(self, name: str, changes: dict[str, Any]) -> Any:
        """Value of a parameter after a batch of ``changes`` (name -> new value)."""
        return changes[name] if name in changes else self.get_parameter(name).value

    @property
    def sim_rate(self) -> float:
        """Simulation step rate [Hz]."""
        return self._float("sim_rate_hz")

    def _model_settings(self, changes: dict[str, Any]) -> fidelity.ModelSettings:
        """What the models are built from, after ``changes``."""
        return fidelity.ModelSettings(
            config=self.config,
            mu_lit=float(self._value("mu_lit", changes)),
            tolerance=float(self._value("tolerance", changes)),
            steady_mode=self._value("steady_mode", changes),
            realtime_map=str(self._value("realtime_map", changes)),
            # A new realtime_map is looked at (and refused if built for other parameters).
            table=None if "realtime_map" in changes else self.tables.table,
        )

    def _validate_parameters(self, params: list[Parameter]) -> SetParametersResult:
        """Check run-time changes beyond the descriptor ranges (which rclpy enforces)."""
        changes = {p.name: p.value for p in params}
        for name, choices in CHOICES.items():
            if name in changes and changes[name] not in choices:
                return SetParametersResult(
                    successful=False,
                    reason=f"{name} = {changes[name]!r} is not one of {', '.join(choices)}",
                )
        sim_rate = float(self._value("sim_rate_hz", changes))
        contact_rate = float(self._value("contact_rate_hz", changes))
        if contact_rate > sim_rate:
            return SetParametersResult(
                successful=False,
                reason=f"contact_rate_hz = {contact_rate:g} Hz exceeds sim_rate_hz = "
                f"{sim_rate:g} Hz (contact states are published on simulation ticks)",
            )
        if any(name in changes for name in MODEL_PARAMETERS):
            try:
                settings = self._model_settings(changes)
                choice = fidelity.choose(str(self._value("fidelity", changes)), settings)
                fallback = fidelity.build("catalog", settings)
            except (ValueError, BallscrewTwinError) as err:
                return SetParametersResult(successful=False, reason=str(err))
            self._pending = (choice, fallback)
        return SetParametersResult(successful=True)

    def _apply_parameters(self, params: list[Parameter]) -> None:
        """Apply run-time parameter changes that passed validation."""
        with self.tick_lock:
            self._apply_locked({p.name for p in params})

    def _apply_locked(self, names: set[str]) -> None:
        """:meth:`_apply_parameters` of the parameters ``names``, under the tick lock."""
        if self._pending is not None and names & set(MODEL_PARAMETERS):
            choice, fallback = self._pending
            self._pending = None
            self._switch_model(choice)
            self.fallback = fallback
            self.fallback.reset(self.operating_point)
        if names & {*RATE_PARAMETERS, "use_sim_time"}:
            self._start_schedule()
            self.get_logger().info(
                f"simulation now {self.sim_rate:g} Hz, contact states "
                f"{self._float('contact_rate_hz'):g} Hz"
            )
        if "frame_id" in names:
            self._frame_id = self._str("frame_id")
            self._torque_encoder = cdr.DragTorqueEncoder(self._frame_id)

    def _switch_model(self, choice: fidelity.ModelChoice) -> None:
        """Run ``choice`` from the next tick on, started in the steady state of the command."""
        previous = self.choice.model.name
        choice.model.reset(self.operating_point)
        self.choice = choice
        self.model_switches += 1
        self._auto_window = TickWindow()
        self._over_budget = 0
        self.get_logger().warning(f"model {previous} -> {choice.model.name}: {choice.reason}")

    def _take_table(self) -> None:
        """Table timer: once the full table is built, run the real-time model on it (the
        model is built and warmed up here, outside the tick lock; the switch is under it)."""
        built = self.tables.take_built()
        if built is None:
            if not self.tables.building and self._table_timer is not None:
                self.destroy_timer(self._table_timer)  # the build failed (on /diagnostics)
                self._table_timer = None
            return
        if self._table_timer is not None:
            self.destroy_timer(self._table_timer)
            self._table_timer = None
        requested = self._str("fidelity")
        if requested not in TABLE_FIDELITIES:
            return
        if requested == "auto" and self.choice.mode not in ("realtime", "catalog"):
            return
        try:
            choice = fidelity.choose(requested, self._model_settings({}))
        except (ValueError, BallscrewTwinError) as err:
            self.get_logger().error(f"the table built cannot serve: {err}")
            return
        reason = f"{choice.reason}; table of this screw built in {built.seconds:.0f} s"
        with self.tick_lock:
            self._switch_model(fidelity.ModelChoice(choice.model, choice.mode, reason))

    def _start_schedule(self) -> None:
        """(Re)start the tick schedule at the current rates, driven by the tick thread on wall
        time (``tick_source: thread``) or by an executor timer (also under use_sim_time)."""
        self.period_ns = max(round(NS_PER_S / self.sim_rate), 1)
        self._wall_time = not self.get_parameter("use_sim_time").value
        self.scheduler = TickScheduler(
            self.period_ns,
            int(self.get_parameter("max_catch_up_ticks").value),
            wall_clock=self._wall_time,
        )
        contact_rate = self._float("contact_rate_hz")
        self.contact_every = (
            max(round(self.sim_rate / contact_rate), 1) if contact_rate > 0.0 else 0
        )
        if self._timer is not None:
            self.destroy_timer(self._timer)
            self._timer = None
        on_thread = self._str("tick_source") == "thread" and self._wall_time
        if not on_thread:
            self._timer = self.create_timer(self.period_ns / NS_PER_S, self._on_timer)
        elif self._tick_thread is None:
            self._tick_thread = TickThread(
                self._thread_due,
                self._on_tick_error,
                priority=int(self.get_parameter("thread_priority").value),
            )
            self._tick_thread.start()

    @property
    def tick_source(self) -> str:
        """What drives the ticks now, and how it is scheduled."""
        if self._timer is not None:
            return "executor timer"
        return f"thread ({self._tick_thread.scheduling})" if self._tick_thread else "none"

    # ------------------------------------------------------------------ inputs
    def _now_ns(self) -> int:
        """The node's clock [ns] (wall time, or /clock under use_sim_time). On wall time read
        directly: the ROS clock is then the system clock, and asking rclpy costs ~5 us."""
        if self._wall_time:
            return time.time_ns()
        return int(self.get_clock().now().nanoseconds)

    def _current_op(self) -> OperatingPoint:
        """Operating point of the inputs' last good values."""
        return OperatingPoint(
            screw_speed=self.speed.value,
            temperature=self.temperature.value,
            preload=self.preload.value,
            axial_load=self.axial_load.value,
        )

    def _take(
        self, channel: InputChannel, value: float, reason: str | None, stamp: Any = None
    ) -> None:
        """Accept ``value`` into ``channel`` or reject it with ``reason`` (logged, counted)."""
        with self.tick_lock:
            self._take_locked(channel, value, reason, stamp)

    def _take_locked(
        self, channel: InputChannel, value: float, reason: str | None, stamp: Any
    ) -> None:
        """:meth:`_take` under the tick lock."""
        now = self._now_ns()
        stamp_ns = 0 if stamp is None else stamp.sec * NS_PER_S + stamp.nanosec
        if reason is None:
            reason = check_stamp(
                stamp_ns,
                last_stamp_ns=channel.last_stamp_ns,
                now_ns=now,
                max_age_ns=int(self._float("max_stamp_age") * NS_PER_S),
            )
        if reason is not None:
            channel.reject(reason)
            self.rejected_commands += 1
            self._log_throttled(
                channel.name,
                f"{channel.name} rejected, keeping {channel.value:g} {channel.unit}: {reason}",
            )
            return
        channel.accept(value, now, stamp_ns)
        self.operating_point = self._current_op()

    def _log_throttled(self, key: str, text: str) -> None:
        """Warn at most once per :data:`LOG_THROTTLE` per ``key``."""
        now = time.monotonic()
        if now - self._last_log.get(key, -math.inf) >= LOG_THROTTLE:
            self._last_log[key] = now
            self.get_logger().warning(text)

    def _on_speed(self, msg: Float64) -> None:
        """Screw speed command [rad/s]."""
        value = float(msg.data)
        self._take(self.speed, value, check_screw_speed(value, self.limits))

    def _on_joint_state(self, msg: JointState) -> None:
        """Screw speed from a joint's velocity [rad/s]."""
        names = list(msg.name)
        if self._speed_joint:
            if self._speed_joint not in names:
                self._take(
                    self.speed, math.nan, f"joint {self._speed_joint!r} not in JointState {names}"
                )
                return
            index = names.index(self._speed_joint)
        else:
            index = 0
        if index >= len(msg.velocity):
            self._take(self.speed, math.nan, f"JointState has no velocity for joint {index}")
            return
        value = float(msg.velocity[index])
        self._take(self.speed, value, check_screw_speed(value, self.limits), msg.header.stamp)

    def _on_temperature(self, msg: Temperature) -> None:
        """Temperature measurement [deg C], stored in [K]."""
        celsius = float(msg.temperature)
        value = celsius_to_kelvin(celsius)
        reason = check_temperature(value, self.limits)
        if reason is not None:
            reason += f" (received {celsius!r} deg C)"
        self._take(self.temperature, value, reason, msg.header.stamp)

    def _on_preload(self, msg: Float64) -> None:
        """Preload command [N]."""
        value = float(msg.data)
        self._take(self.preload, value, check_preload(value, self.limits))

    def _on_axial_load(self, msg: Float64) -> None:
        """External axial load command [N]."""
        value = float(msg.data)
        self._take(self.axial_load, value, check_axial_load(value, self.limits))

    def _on_preload_wrench(self, msg: WrenchStamped) -> None:
        """Preload measured by a load cell: ``wrench.force.z`` [N]."""
        value = float(msg.wrench.force.z)
        self._take(self.preload, value, check_preload(value, self.limits), msg.header.stamp)

    def _on_axial_load_wrench(self, msg: WrenchStamped) -> None:
        """External axial load along +z measured as a wrench: ``wrench.force.z`` [N]."""
        value = float(msg.wrench.force.z)
        self._take(self.axial_load, value, check_axial_load(value, self.limits), msg.header.stamp)

    # ------------------------------------------------------------------ simulation
    def _on_timer(self) -> None:
        """Run the ticks that are due on the node's clock (nothing once shutting down)."""
        try:
            with self.tick_lock:
                self._run_due_ticks()
        except Exception:
            if self.context.ok():
                raise
            # SIGINT/SIGTERM shut the context down under a running tick: publishing failed.

    def _thread_due(self) -> float | None:
        """Tick thread: run the due ticks; seconds until the next one (None: the executor's
        timer drives the ticks now, e.g. under use_sim_time)."""
        with self.tick_lock:
            if self._timer is not None:
                return None
            self._run_due_ticks()
            return (self.scheduler.next_due_ns() - self._now_ns()) / NS_PER_S

    def _on_tick_error(self, err: Exception) -> None:
        """An exception escaped a tick on the tick thread: logged; the ticks go on."""
        if not self.context.ok():
            # Shut down under a running tick (publishing failed): nothing more to publish.
            if self._tick_thread is not None:
                self._tick_thread.stop()
            return
        self.tick_errors += 1
        self._log_throttled("tick", f"tick failed ({self.tick_errors} so far): {err!r}")

    def destroy_node(self) -> None:
        """Stop the tick thread and a table build, then destroy the node."""
        if self._tick_thread is not None:
            self._tick_thread.stop()
        self.tables.stop()
        super().destroy_node()

    def _run_due_ticks(self) -> None:
        """Run the ticks that are due on the node's clock."""
        now = self._now_ns()
        if self.scheduler.origin_ns is None:
            # First wake-up (the executor may start long after the timer was created): the
            # timer wakes at now + k periods from here on, and so does the tick grid.
            if self._timer is not None:
                self._timer.reset()
            self.scheduler.start(now)
            return
        last_due = self.scheduler.time_of(self.scheduler.last_index)
        plan = self.scheduler.due(now)
        if plan.jumped_back:
            self.clock_jumps_back += 1
            for channel in self.channels:
                channel.forget_times()
            self.choice.model.reset(self.operating_point)
            self.get_logger().warning(
                f"clock jumped backwards to {now / NS_PER_S:.6f} s: simulation restarted there, "
                "model reset, input stamps forgotten"
            )
        if plan.jumped_forward:
            self.clock_jumps_forward += 1
            gap = (now - last_due) / NS_PER_S
            self.get_logger().warning(
                f"clock jumped forwards to {now / NS_PER_S:.6f} s ({gap:.3f} s after the last "
                "tick; on wall time: the node stalled or the system clock was stepped): "
                "simulation restarted there"
            )
        if plan.skipped:
            self.book_skipped(plan.skipped)
        for index in plan.ticks:
            self._tick(index)

    @property
    def starting_up(self) -> bool:
        """Whether the node is still starting: no tick on time yet, within STARTUP_GRACE_NS."""
        return time.monotonic_ns() < self._startup_ends_ns

    def book_skipped(self, count: int) -> None:
        """Count ``count`` skipped ticks: as start-up (logged as information) while
        :attr:`starting_up`, else in the diagnostics windows (a warning)."""
        if self.starting_up:
            self.startup_skipped += count
            self.get_logger().info(
                f"{count} ticks skipped at start-up (loading and warming up the model)"
            )
            return
        self.window.skipped += count
        self._auto_window.skipped += count
        self.skipped_total += count
        self._log_throttled(
            "skipped",
            f"{count} ticks skipped: the node fell "
            f"more than {self.scheduler.max_catch_up} ticks behind",
        )

    def _step(self, op: OperatingPoint, contacts: bool = True) -> TwinOutput:
        """One model step at ``op``; the catalogue model stands in if the model fails.
        ``contacts=False``: the contact states are not needed on this tick."""
        dt = self.period_ns / NS_PER_S
        reason = ""
        try:
            model: Any = self.choice.model  # optional_contacts: step takes contacts=False
            if not contacts and getattr(model, "optional_contacts", False):
                out = model.step(op, dt, contacts=False)
            else:
                out = model.step(op, dt)
            if _finite_output(out):
                return out
            reason = "returned a non-finite torque"
        except Exception as err:  # a failing model must not stop the node
            reason = f"raised {type(err).__name__}: {err}"
        self.model_failures += 1
        self.window.failures += 1
        self._log_throttled(
            "model",
            f"model {self.choice.model.name} {reason} at "
            f"{self._describe(op)}; catalogue value published instead",
        )
        if self._str("fidelity") == "auto" and self.choice.mode != "catalog":
            # A model that fails is not used again until the fidelity parameter is set anew.
            choice = fidelity.choose("auto", self._model_settings({}), below=self.choice.mode)
            why = f"{self.choice.model.name} {reason}"
            self._switch_model(
                fidelity.ModelChoice(choice.model, choice.mode, f"{choice.reason}: {why}")
            )
        return self.fallback.step(op, dt)

    def _tick(self, index: int) -> None:
        """Step the model once and publish the tick's drag torque (and contact states)."""
        op = self.operating_point
        publish_contacts = bool(self.contact_every) and index % self.contact_every == 0
        start = time.perf_counter()
        out = self._step(op, contacts=publish_contacts)
        step_time = time.perf_counter() - start
        tick_ns = self.scheduler.time_of(index)
        sec, nanosec = divmod(tick_ns, NS_PER_S)
        period = self.period_ns / NS_PER_S
        # Simulated time per compute time (>= 1 keeps up); below the clock's resolution it is
        # counted as one nanosecond.
        self._torque_pub.publish(
            self.encode_torque(out, sec, nanosec, real_time_factor=period / max(step_time, 1e-9))
        )
        self.published_count += 1
        self.last_output = out
        # Tick latency: due time to torque published (contact states follow, at a lower rate).
        latency = self._now_ns() - tick_ns
        if latency <= ON_TIME_NS:
            self._startup_ends_ns = 0  # keeping up: start-up is over
        self.window.add(step_time, latency)
        self._auto_window.add(step_time, latency)
        if latency > ON_TIME_NS:
            self.late_total += 1
        if self.latency_log is not None:
            self.latency_log.append(latency)
        if publish_contacts and out.contacts is not None:
            self._publish_contacts(out, sec, nanosec)
        if self._auto_window.ticks >= max(int(self.sim_rate), 1):
            self._review_fidelity()

    def _review_fidelity(self) -> None:
        """Under ``fidelity: auto``, step down when the model does not fit into the step budget
        for :data:`OVER_BUDGET_WINDOWS` windows of one simulated second in a row (so start-up
        and a single hiccup of a loaded machine do not count)."""
        w = self._auto_window
        self._auto_window = TickWindow()
        if self._str("fidelity") != "auto" or self.choice.mode == "catalog":
            return
        period = self.period_ns / NS_PER_S
        budget = self._float("step_budget") * period
        mean = w.step_time_sum / max(w.ticks, 1)
        self._over_budget = self._over_budget + 1 if mean > budget else 0
        if self._over_budget < OVER_BUDGET_WINDOWS:
            return
        overdue = (w.late + w.skipped) / max(w.ticks + w.skipped, 1)
        choice = fidelity.choose("auto", self._model_settings({}), below=self.choice.mode)
        why = (
            f"{self.choice.model.name} took {mean * 1e3:.3f} ms per step on average "
            f"(max {w.step_time_max * 1e3:.3f} ms; budget {budget * 1e3:.3f} ms of the "
            f"{period * 1e3:.3f} ms step), {overdue:.1%} ticks late or skipped"
        )
        self._switch_model(
            fidelity.ModelChoice(choice.model, choice.mode, f"{choice.reason}: {why}")
        )

    # ------------------------------------------------------------------ messages
    def encode_torque(
        self, out: TwinOutput, sec: int, nanosec: int, *, real_time_factor: float
    ) -> bytes:
        """The serialised DragTorque of one finite model output (published as bytes: building
        a Python message and converting it cost ~20 us a tick, this ~1 us; ros/cdr.py).

        Args:
            out: model output [N m], finite; its ``operating_point`` (SI) is the point the
                model computed at (inside the validity envelope).
            sec, nanosec: stamp of the tick [s], [ns].
            real_time_factor: step / model compute time, >= 1 keeps up [-].
        """
        op = out.operating_point
        return self._torque_encoder.encode(
            sec,
            nanosec,
            torque_values(out),
            out.fidelity,
            real_time_factor,
            op.screw_speed,
            op.temperature - CELSIUS_ZERO,
            op.preload,
            op.axial_load,
        )

    def _publish_contacts(self, out: TwinOutput, sec: int, nanosec: int) -> None:
        """Publish the contact states of ``out`` stamped ``sec``/``nanosec`` [s]/[ns], or log
        why not (a value that is not finite)."""
        data = self.encode_contacts(out, sec, nanosec)
        if data is None:
            self._log_throttled(
                "contacts",
                f"model {out.fidelity} returned non-finite contact states: not published",
            )
            return
        self._contact_pub.publish(data)
        self.contact_count += 1

    def encode_contacts(self, out: TwinOutput, sec: int, nanosec: int) -> bytes | None:
        """The serialised ContactStateArray of every resolved sphere/half-groove contact of
        ``out`` (stamp ``sec`` [s], ``nanosec`` [ns]), or None when a value is not finite.
        Serialised directly from the arrays (ros/cdr.py): ~20 us for 200 contacts, against
        ~2.4 ms as 200 Python messages."""
        cs = out.contacts
        assert cs is not None
        columns = [
            np.asarray(getattr(cs, name), dtype=np.float64) for name in cdr.CONTACT_FLOAT_FIELDS
        ]
        if not all_finite(columns):
            return None
        return cdr.encode_contact_states(
            sec,
            nanosec,
            self._frame_id,
            out.fidelity,
            sphere_index_within_nut(cs),
            cs.nut,
            cs.half_groove,
            cs.in_contact,
            columns,
        )

    # ------------------------------------------------------------------ diagnostics
    def diagnostic_checks(self) -> list[diagnostics.Check]:
        """The checks of the window since the last call (which restarts the window)."""
        with self.tick_lock:
            return self._checks_locked()

    def _checks_locked(self) -> list[diagnostics.Check]:
        """:meth:`diagnostic_checks` under the tick lock."""
        now = self._now_ns()
        w, self.window = self.window, TickWindow()
        elapsed = max((now - self._window_start_ns) / NS_PER_S, 1e-9)
        self._window_start_ns = now
        checks = [self._model_check(w), self._real_time_check(w, elapsed)]
        stale_after = self._float("stale_after")
        checks += [self._input_check(c, now, stale_after, elapsed) for c in self.channels]
        checks.append(self._validity_check())
        if self._str("fidelity") in TABLE_FIDELITIES:
            checks.append(self.tables.check())
        return checks

    def _model_check(self, w: TickWindow) -> diagnostics.Check:
        level = diagnostics.WARN if w.failures else diagnostics.OK
        message = f"{self.choice.model.name}: {self.choice.reason}"
        if w.failures:
            message += f"; {w.failures} failed steps replaced by the catalogue model"
        return diagnostics.Check(
            "model",
            level,
            message,
            (
                ("fidelity parameter", self._str("fidelity")),
                ("model", self.choice.model.name),
                ("mode", self.choice.mode),
                ("why", self.choice.reason),
                ("switches", str(self.model_switches)),
                ("failed steps (window / total)", f"{w.failures} / {self.model_failures}"),
            ),
        )

    def _real_time_check(self, w: TickWindow, elapsed: float) -> diagnostics.Check:
        period = self.period_ns / NS_PER_S
        due = w.ticks + w.skipped
        on_time = (w.ticks - w.late) / due if due else 1.0
        mean_step = w.step_time_sum / w.ticks if w.ticks else 0.0
        rtf = period / mean_step if mean_step > 0.0 else math.inf
        lat = np.asarray(w.latencies_ns, dtype=np.float64) * 1e-6
        p50, p99, pmax = (
            (float(np.percentile(lat, 50)), float(np.percentile(lat, 99)), float(lat.max()))
            if lat.size
            else (0.0, 0.0, 0.0)
        )
        level = diagnostics.OK
        message = f"{on_time:.2%} of ticks on time, real-time factor {rtf:.3g}"
        if w.skipped or on_time < self._float("min_on_time_share"):
            level = diagnostics.WARN
            message += f"; {w.late} late (> 1 ms), {w.skipped} skipped"
        if due == 0:
            level, message = diagnostics.STALE, "no tick in this window (clock not advancing?)"
        return diagnostics.Check(
            "real time",
            level,
            message,
            (
                ("simulation rate [Hz]", f"{self.sim_rate:g}"),
                ("use_sim_time", str(self.get_parameter("use_sim_time").value)),
                ("ticks run by", self.tick_source),
                ("tick errors (total)", str(self.tick_errors)),
                ("ticks published (window)", str(w.ticks)),
                ("simulated / clock time [-]", f"{w.ticks * period / elapsed:.4f}"),
                ("on time within 1 ms [-]", f"{on_time:.5f}"),
                ("late ticks (window / total)", f"{w.late} / {self.late_total}"),
                ("skipped ticks (window / total)", f"{w.skipped} / {self.skipped_total}"),
                ("skipped ticks at start-up", str(self.startup_skipped)),
                ("on time share below which WARN [-]", f"{self._float('min_on_time_share'):g}"),
                ("latency p50 / p99 / max [ms]", f"{p50:.3f} / {p99:.3f} / {pmax:.3f}"),
                (
                    "model step mean / max [ms]",
                    f"{mean_step * 1e3:.4f} / {w.step_time_max * 1e3:.4f}",
                ),
                ("real-time factor (step / compute) [-]", f"{rtf:.4g}"),
                (
                    "clock jumps back / forward",
                    f"{self.clock_jumps_back} / {self.clock_jumps_forward}",
                ),
            ),
        )

    def _input_check(
        self, c: InputChannel, now: int, stale_after: float, elapsed: float
    ) -> diagnostics.Check:
        age = c.age(now)
        level, message = diagnostics.OK, f"{c.value:g} {c.unit}"
        if age is None:
            if c is self.axial_load:
                message += " (not commanded)"
            else:
                level = diagnostics.WARN
                message = f"no message yet: using the initial {c.value:g} {c.unit}"
        elif age > stale_after:
            level = diagnostics.WARN
            message = f"stale: no message for {age:.3g} s, holding {c.value:g} {c.unit}"
        window_rejections = c.rejected - self._rejected_seen.get(c.name, 0)
        self._rejected_seen[c.name] = c.rejected
        received = c.accepted + c.rejected
        rate = (received - self._received_seen.get(c.name, 0)) / elapsed
        self._received_seen[c.name] = received
        if window_rejections:
            level = max(level, diagnostics.WARN)
            message += f"; {window_rejections} rejected, last: {c.last_rejection}"
        return diagnostics.Check(
            f"input {c.name}",
            level,
            message,
            (
                ("value", f"{c.value:g} {c.unit}"),
                ("age [s]", "never" if age is None else f"{age:.3f}"),
                ("messages per second", f"{rate:.1f}"),
                ("accepted", str(c.accepted)),
                ("rejected", str(c.rejected)),
                ("last rejection", c.last_rejection),
            ),
        )

    def _validity_check(self) -> diagnostics.Check:
        out = self.last_output
        notes = out.notes if out is not None else ()
        warnings = [n for n in notes if any(w in n.lower() for w in VALIDITY_WORDS)]
        level = diagnostics.WARN if warnings else diagnostics.OK
        message = "; ".join(warnings) if warnings else "within the model's envelope"
        return diagnostics.Check(
            "validity", level, message, tuple((f"note {i}", n) for i, n in enumerate(notes))
        )

    def _publish_diagnostics(self) -> None:
        """Publish ``/diagnostics``."""
        self._diag_pub.publish(
            diagnostics.to_message(
                self.diagnostic_checks(),
                node_name=self.get_name(),
                hardware_id=NODE_NAME,
                stamp=self.get_clock().now().to_msg(),
            )
        )

    @staticmethod
    def _describe(op: OperatingPoint) -> str:
        """Human-readable operating point."""
        return (
            f"speed {op.screw_speed:g} rad/s, temperature {op.temperature:g} K, "
            f"preload {op.preload:g} N, axial load {op.axial_load:g} N"
        )


def sphere_index_within_nut(cs: ContactStates) -> np.ndarray:
    """Index of each contact's sphere within its own nut, 0-based [-]."""
    index = np.asarray(cs.sphere, dtype=np.int64).copy()
    for nut in (0, 1):
        mask = cs.nut == nut
        if mask.any():
            index[mask] -= index[mask].min()
    return index


def main(args: list[str] | None = None) -> None:
    """Console script ``twin_node``: run :class:`TwinNode` until SIGINT/SIGTERM.

    Accepts ROS arguments, e.g. ``twin_node --ros-args --params-file config/twin_node.yaml``.
    """
    raise SystemExit(run_node(sys.argv if args is None else args))


def _ignore_signal(_signum: int, _frame: object) -> None:
    """Python-level SIGINT/SIGTERM handler behind rclpy's: the context shutdown is enough."""


def run_node(argv: list[str]) -> int:
    """Run :class:`TwinNode` with ROS arguments ``argv`` until shut down; the exit code."""
    # rclpy's SIGINT/SIGTERM handler shuts the context down, then calls the handler installed
    # before it. Python's default one would raise KeyboardInterrupt at a random point of the
    # shutdown (it killed the process with SIGINT in 1 stop of ~8): install a silent one.
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, _ignore_signal)
    try:
        rclpy.init(args=argv)
    except Exception as err:  # rclpy's RCLError: unreadable --params-file, bad --ros-args
        print(f"twin_node: cannot start: {err}", file=sys.stderr)
        return 1
    node: TwinNode | None = None
    executor: Executor | None = None
    exit_code = 0
    try:
        node = TwinNode()
        executor = make_executor(node._str("executor"), node.context)
        executor.add_node(node)
        priority = int(node.get_parameter("thread_priority").value)
        scheduling = prepare_process(priority)
        if priority:
            node.get_logger().info(f"executor thread: {scheduling}")
        spin(executor)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except (BallscrewTwinError, ParameterException, ValueError) as err:
        # Bad parameter file, screw configuration or initial operating point: say which.
        hint = ""
        if "expecting type 'DOUBLE'" in str(err):
            hint = " (write floating-point parameters with a decimal point, e.g. 1000.0)"
        print(f"twin_node: cannot start: {err}{hint}", file=sys.stderr)
        exit_code = 1
    finally:
        # The executor no longer spins here. Take the node out of it before destroying the node
        # (destroying a node under a live executor crashed with SIGSEGV in 3 of 20 stops), and
        # release the executor before the process exits: an EventsExecutor that still holds
        # the node's callbacks at exit aborts ("Destroying callback manager with callbacks
        # remaining", SIGABRT in 1 of 8 SIGTERM stops).
        if executor is not None and node is not None:
            executor.remove_node(node)
        if node is not None:
            node.destroy_node()
        if executor is not None:
            executor.shutdown()
            del executor
        rclpy.try_shutdown()
    return exit_code


if __name__ == "__main__":
    main()
