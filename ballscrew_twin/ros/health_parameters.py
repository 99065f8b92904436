"""The health-monitor node's parameter table (no rclpy here). ``config/health_node.yaml``
holds the same defaults (tested), ``docs/nodes.md`` describes them; the detection defaults
are those of :class:`~ballscrew_twin.health.monitor_settings.MonitorSettings` and
:class:`~ballscrew_twin.health.residuals.ResidualSettings`.
"""

from __future__ import annotations

from ..health.baseline import BAND_REACH, SHIFT_EXTRAPOLATION
from ..health.commission import TEMPERATURE_ERROR, UNSEEN_ERROR
from ..health.monitor_settings import DETECTORS, MonitorSettings
from ..health.residuals import ResidualSettings
from ..units import SCREW_FRAME_ID
from .parameters import ParameterSpec

NODE_NAME = "ballscrew_health"
#: Message types of the inputs that may be chosen (parameters ``*_type``).
TYPES = {
    "torque_type": ("WrenchStamped", "Float64"),
    "speed_type": ("JointState", "Float64"),
    "preload_type": ("WrenchStamped", "Float64"),
}

_MONITOR = MonitorSettings()
_RESIDUAL = ResidualSettings()

#: Every parameter of the health node, in the order of ``config/health_node.yaml``; all are
#: read at start-up only.
HEALTH_PARAMETERS: tuple[ParameterSpec, ...] = (
    ParameterSpec("config_file", "", "", "Screw parameter file (YAML); empty: shipped paper screw"),
    # --- inputs
    ParameterSpec("torque_topic", "/bench/torque", "", "Input: measured drive torque in N m"),
    ParameterSpec(
        "torque_type",
        "WrenchStamped",
        "",
        "WrenchStamped (torque.z) or Float64",
        choices=TYPES["torque_type"],
    ),
    ParameterSpec("speed_topic", "/bench/joint_states", "", "Input: screw speed in rad/s"),
    ParameterSpec(
        "speed_type",
        "JointState",
        "",
        "JointState (velocity) or Float64",
        choices=TYPES["speed_type"],
    ),
    ParameterSpec("joint_name", "screw", "", "Joint of the screw in JointState messages"),
    ParameterSpec(
        "temperature_topic",
        "/bench/temperature",
        "",
        "Input: sensor_msgs/Temperature in deg C",
    ),
    ParameterSpec("preload_topic", "/bench/preload", "", "Input: load-cell preload in N"),
    ParameterSpec(
        "preload_type",
        "WrenchStamped",
        "",
        "WrenchStamped (force.z) or Float64",
        choices=TYPES["preload_type"],
    ),
    ParameterSpec("queue_depth", 1000, "-", "Depth of the input queues (keep last)"),
    ParameterSpec(
        "reliable_inputs",
        False,
        "",
        "Subscribe reliably (a replayed bag arrives whole; the publisher must be reliable) "
        "instead of best effort (sensor data: a late sample is dropped, the bench is never "
        "slowed)",
    ),
    # --- outputs
    ParameterSpec("health_topic", "health", "", "Output: ballscrew_twin_msgs/HealthResidual"),
    ParameterSpec("frame_id", SCREW_FRAME_ID, "", "header.frame_id of HealthResidual"),
    ParameterSpec("diagnostics_rate_hz", 1.0, "Hz", "/diagnostics rate", 0.1, 10.0),
    ParameterSpec("stale_after", 2.0, "s", "No torque for this long: STALE", 0.1, 60.0),
    ParameterSpec(
        "clock_timeout",
        2.0,
        "s",
        "use_sim_time: /clock still for this long (wall time): STALE",
        0.1,
        60.0,
    ),
    ParameterSpec(
        "log_throttle",
        1.0,
        "s",
        "Least wall time between two logged verdict/class changes",
        0.0,
        60.0,
    ),
    # --- detection
    ParameterSpec(
        "false_alarm_rate",
        _MONITOR.false_alarm_rate,
        "1/h",
        "Target false alarms per hour, all detectors",
        1e-9,
        1e3,
    ),
    ParameterSpec(
        "detectors",
        tuple(_MONITOR.detectors),
        "",
        f"Detectors that may raise an alarm, some of {list(DETECTORS)}",
        choices=DETECTORS,
    ),
    ParameterSpec("warmup", _MONITOR.warmup, "s", "Healthy warm-up at the start", 0.5, 3600.0),
    ParameterSpec(
        "block_duration",
        _RESIDUAL.block_duration,
        "s",
        "Length of one comparison block",
        0.005,
        10.0,
    ),
    ParameterSpec(
        "sensor_noise",
        0.0,
        "N m",
        "Torque-sensor noise of one sample; 0: learn in warm-up",
        0.0,
        10.0,
    ),
    ParameterSpec(
        "model_error_relative",
        _RESIDUAL.model_error_relative,
        "-",
        "Model error relative to the torque, 1 sigma",
        0.0,
        1.0,
    ),
    ParameterSpec(
        "classification_window",
        _MONITOR.classification_window,
        "s",
        "Time after an alarm over which the class is refined",
        0.1,
        600.0,
    ),
    ParameterSpec(
        "classification_patience",
        _MONITOR.classification_patience,
        "s",
        "Longest time after an alarm over which an unsure class (confidence < 0.9) is refined",
        0.1,
        3600.0,
    ),
    # --- commissioning
    ParameterSpec(
        "baseline_file",
        "",
        "",
        "Baseline of the commissioned unit (YAML); empty: the nominal twin",
    ),
    ParameterSpec(
        "commission_window",
        300.0,
        "s",
        "~/commission fits the samples of the last this many seconds",
        10.0,
        3600.0,
    ),
    ParameterSpec(
        "commission_unseen_error",
        UNSEEN_ERROR,
        "-",
        "~/commission: least twin error (1 sigma, relative) where the samples did not teach it",
        0.001,
        1.0,
    ),
    ParameterSpec(
        "commission_temperature_error",
        TEMPERATURE_ERROR,
        "1/K",
        "~/commission: growth of the twin error per K outside the temperatures the samples saw",
        0.0,
        0.1,
    ),
    ParameterSpec(
        "commission_shift_extrapolation",
        SHIFT_EXTRAPOLATION,
        "K",
        "~/commission: fitted shift at which the twin's change outside the temperatures the "
        "samples saw counts as its error",
        0.1,
        1000.0,
    ),
    ParameterSpec(
        "commission_band_reach",
        BAND_REACH,
        "-",
        "~/commission: decades of speed within which the temperatures the samples saw count "
        "at a speed (0: its speed band's)",
        0.0,
        3.0,
    ),
    ParameterSpec(
        "commission_out",
        "",
        "",
        "~/commission also writes its baseline here (YAML); empty: not saved",
    ),
)
