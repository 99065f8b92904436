"""The twin node's parameter table, input presets and the groups of parameters it acts on
(no rclpy here). ``config/twin_node.yaml`` holds the same defaults (tested), ``docs/nodes.md``
describes them.
"""

from __future__ import annotations

from ..bags.recording import BenchTopics
from ..units import SCREW_FRAME_ID
from .fidelity_modes import FIDELITY_MODES
from .inputs import InputLimits
from .parameters import ParameterSpec

NODE_NAME = "ballscrew_twin"
#: Executor names (parameter ``executor``); ``events`` served the ticks best
#: (docs/benchmarks.md, "Real-time node").
EXECUTORS = ("single_threaded", "events")
#: What drives the ticks on wall time (parameter ``tick_source``); under ``use_sim_time`` the
#: executor's timer always does (it follows ``/clock``).
TICK_SOURCES = ("thread", "executor")
#: Default share of ticks on time below which ``real time`` is WARN [-] (parameter
#: ``min_on_time_share``). A 2-core machine shared with other work keeps 99.3 % on average,
#: and a bare sleep loop 99.7 % (docs/benchmarks.md): 99.9 % warned every second there.
MIN_ON_TIME_SHARE = 0.98
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
#: Parameters whose change rebuilds the model.
MODEL_PARAMETERS = ("fidelity", "tolerance", "steady_mode", "mu_lit", "realtime_map")
#: Fidelity parameter values for which a missing real-time table is built.
TABLE_FIDELITIES = ("auto", "realtime")
#: Parameters whose change restarts the tick schedule.
RATE_PARAMETERS = ("sim_rate_hz", "contact_rate_hz", "max_catch_up_ticks")


def rates_refused(sim_rate: float, contact_rate: float) -> str | None:
    """Why the simulation rate ``sim_rate`` and the contact-state rate ``contact_rate`` [Hz]
    do not go together, or None."""
    if contact_rate <= sim_rate:
        return None
    return (
        f"contact_rate_hz = {contact_rate:g} Hz exceeds sim_rate_hz = {sim_rate:g} Hz "
        "(contact states are published on simulation ticks)"
    )


_LIMITS = InputLimits()
_INPUTS = INPUT_PRESETS["commands"]

#: Every parameter of the twin node, in the order of ``config/twin_node.yaml``. The input
#: topics and types default to the ``commands`` preset; ``input_preset`` changes those defaults.
TWIN_PARAMETERS: tuple[ParameterSpec, ...] = (
    # --- simulation and outputs
    ParameterSpec(
        "sim_rate_hz",
        1000.0,
        "Hz",
        "Simulation step rate and drag_torque rate",
        1.0,
        2000.0,
        run_time=True,
    ),
    ParameterSpec(
        "contact_rate_hz",
        100.0,
        "Hz",
        "contact_states rate, 0 = off, <= sim_rate_hz",
        0.0,
        2000.0,
        run_time=True,
    ),
    ParameterSpec("diagnostics_rate_hz", 1.0, "Hz", "/diagnostics rate", 0.1, 10.0),
    ParameterSpec(
        "fidelity",
        "auto",
        "",
        "Model: auto, realtime, quasi_static or catalog",
        choices=FIDELITY_MODES,
        run_time=True,
    ),
    ParameterSpec(
        "tolerance", 1e-10, "-", "Convergence limit of the steady solve", 1e-14, 1e-3, run_time=True
    ),
    ParameterSpec(
        "steady_mode",
        "auto",
        "",
        "Spheres the steady model solves",
        choices=("auto", "symmetric", "full"),
        run_time=True,
    ),
    ParameterSpec(
        "mu_lit",
        0.002,
        "-",
        "Friction coefficient of the catalogue formula",
        0.0,
        0.5,
        run_time=True,
    ),
    ParameterSpec(
        "step_budget",
        0.5,
        "-",
        "Share of the step a model may take before auto steps down",
        0.05,
        1.0,
        run_time=True,
    ),
    ParameterSpec(
        "min_on_time_share",
        MIN_ON_TIME_SHARE,
        "-",
        "real time on /diagnostics is WARN when a smaller share of the ticks is published "
        "within 1 ms of its due time",
        0.0,
        1.0,
        run_time=True,
    ),
    ParameterSpec(
        "max_catch_up_ticks",
        20,
        "-",
        "Most overdue ticks run at once; more are skipped",
        1,
        1000,
        run_time=True,
    ),
    ParameterSpec("executor", "events", "", "Executor of the twin_node process", choices=EXECUTORS),
    ParameterSpec(
        "tick_source",
        "thread",
        "",
        "What runs the ticks on wall time: a thread of their own or the executor's timer "
        "(under use_sim_time always the timer)",
        choices=TICK_SOURCES,
    ),
    ParameterSpec(
        "thread_priority",
        0,
        "-",
        "SCHED_FIFO priority of the tick thread, 1..99; 0: normal scheduling (needs "
        "CAP_SYS_NICE or an rtprio limit; refused: logged)",
        0,
        99,
    ),
    ParameterSpec(
        "realtime_map",
        "",
        "",
        "Steady-state map of the real-time model (.npz); empty: the packaged one",
        run_time=True,
    ),
    ParameterSpec("config_file", "", "", "Screw parameter file (YAML); empty: shipped paper screw"),
    ParameterSpec(
        "table_workers",
        2,
        "-",
        "Processes that build the real-time table of a screw without one (niced; a preview "
        "table serves meanwhile); 0: never build",
        0,
        64,
    ),
    ParameterSpec(
        "frame_id",
        SCREW_FRAME_ID,
        "",
        "header.frame_id of published messages",
        run_time=True,
    ),
    # --- inputs
    ParameterSpec(
        "input_preset",
        "commands",
        "",
        "Defaults of the input topics and types: commands (speed_command ...) or bench (the "
        "bench-bag schema: /bench/joint_states ...); each can be set on its own",
        choices=tuple(INPUT_PRESETS),
    ),
    ParameterSpec("speed_topic", _INPUTS["speed_topic"], "", "Input: screw speed in rad/s"),
    ParameterSpec(
        "speed_type",
        _INPUTS["speed_type"],
        "",
        "Message type of the speed input",
        choices=("float64", "joint_state"),
    ),
    ParameterSpec(
        "speed_joint",
        _INPUTS["speed_joint"],
        "",
        "JointState joint whose velocity is the screw speed; empty: the first",
    ),
    ParameterSpec(
        "temperature_topic",
        _INPUTS["temperature_topic"],
        "",
        "Input: sensor_msgs/Temperature in deg C",
    ),
    ParameterSpec("preload_topic", _INPUTS["preload_topic"], "", "Input: preload in N"),
    ParameterSpec(
        "preload_type",
        _INPUTS["preload_type"],
        "",
        "Message type of the preload: float64 (data) or wrench_stamped (force.z)",
        choices=FORCE_TYPES,
    ),
    ParameterSpec(
        "axial_load_topic",
        _INPUTS["axial_load_topic"],
        "",
        "Input: external axial load along +z in N; empty: not subscribed",
    ),
    ParameterSpec(
        "axial_load_type",
        _INPUTS["axial_load_type"],
        "",
        "Message type of the axial load: float64 (data) or wrench_stamped (force.z)",
        choices=FORCE_TYPES,
    ),
    ParameterSpec(
        "input_qos",
        "sensor_data",
        "",
        "QoS of the inputs: sensor_data (best effort) or reliable",
        choices=("sensor_data", "reliable"),
    ),
    ParameterSpec(
        "stale_after",
        1.0,
        "s",
        "An input with no message for this long is stale",
        0.01,
        3600.0,
        run_time=True,
    ),
    ParameterSpec(
        "max_stamp_age",
        1.0,
        "s",
        "Largest |clock - header stamp| accepted, 0 = off",
        0.0,
        3600.0,
        run_time=True,
    ),
    # --- outputs
    ParameterSpec(
        "torque_topic", "drag_torque", "", "Output: ballscrew_twin_msgs/DragTorque in N m"
    ),
    ParameterSpec(
        "contact_topic", "contact_states", "", "Output: ballscrew_twin_msgs/ContactStateArray"
    ),
    # --- operating point until the first command arrives
    ParameterSpec(
        "initial_screw_speed", 0.0, "rad/s", "Screw speed until the first command", -1.0e4, 1.0e4
    ),
    ParameterSpec(
        "initial_temperature", 293.15, "K", "Temperature until the first measurement", 150.0, 700.0
    ),
    ParameterSpec("initial_preload", 1500.0, "N", "Preload until the first command", 0.0, 1.0e6),
    # --- commands outside these limits are rejected
    ParameterSpec(
        "limits.max_screw_speed",
        0.0,
        "rad/s",
        "Largest accepted |screw speed|; 0: the screw's critical speed",
        0.0,
        1.0e4,
    ),
    ParameterSpec(
        "limits.min_temperature",
        _LIMITS.min_temperature,
        "K",
        "Lowest accepted temperature",
        150.0,
        400.0,
    ),
    ParameterSpec(
        "limits.max_temperature",
        _LIMITS.max_temperature,
        "K",
        "Highest accepted temperature",
        250.0,
        700.0,
    ),
    ParameterSpec(
        "limits.max_preload", _LIMITS.max_preload, "N", "Largest accepted preload", 1.0, 1.0e6
    ),
    ParameterSpec(
        "limits.max_axial_load",
        _LIMITS.max_axial_load,
        "N",
        "Largest accepted |axial load|",
        1.0,
        1.0e6,
    ),
)
