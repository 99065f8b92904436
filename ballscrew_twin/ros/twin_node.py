"""ROS 2 node of the ball-screw twin: the simulator stepped in real time on ROS topics.

Screw speed [rad/s], temperature [deg C, kept in K], preload and axial load [N] in;
``drag_torque`` every tick, ``contact_states`` and ``/diagnostics`` out (topics, parameters,
diagnostics: ``docs/nodes.md``). The node is the glue; the work is done by the parameter table
(``twin_parameters``), the inputs (``twin_inputs``), the models and their step-down
(``twin_models``, ``step_down``), the tables (``tables``), the tick schedule (``scheduler``,
``tick_thread``), the encoding (``twin_messages``) and the checks (``twin_diagnostics``).

The simulation keeps a fixed step locked to the node's clock (wall time, or ``/clock`` with
``use_sim_time``): it catches up after a short stall, skips ticks (and counts them) when far
behind, restarts on a clock jump, and under ``fidelity: auto`` steps down to a cheaper model
when the current one does not fit into the step budget. A command that is not finite,
implausible, out of order or stale is rejected with a log line and a diagnostic, the last good
value stays in force; the node never publishes a non-finite number.

Run: ``twin_node --ros-args --params-file config/twin_node.yaml``.
"""

from __future__ import annotations

import sys
import threading
import time
from typing import Any

from ballscrew_twin_msgs.msg import ContactStateArray, DragTorque
from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.msg import SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.executors import Executor
from rclpy.parameter import Parameter
from rclpy.timer import Timer

from ..errors import BallscrewTwinError, ConfigError
from ..models.base import TwinOutput
from ..params import load_config
from ..units import NS_PER_S, ns_to_stamp
from . import cdr, diagnostics, fidelity_modes, twin_diagnostics
from .executors import make_executor
from .node_parameters import TableNode
from .node_process import run_node_process
from .scheduler import TickScheduler
from .tables import RealTimeTables
from .throttle import Throttle
from .tick_counts import TickBook, TickWindow
from .tick_thread import TickThread, prepare_process
from .twin_inputs import TwinInputs
from .twin_messages import encode_contacts, encode_torque
from .twin_models import TwinModels, describe
from .twin_parameters import (
    INPUT_PRESETS,
    MODEL_PARAMETERS,
    NODE_NAME,
    RATE_PARAMETERS,
    TABLE_FIDELITIES,
    TWIN_PARAMETERS,
    rates_refused,
)

#: Minimum interval between two log lines about the same input or failure [s].
LOG_THROTTLE = 1.0
#: Longest start-up phase (steady clock from the node's creation) [ns]: ticks skipped before the
#: first tick on time and within this time are start-up (loading and warming the model up),
#: counted apart and not a warning.
STARTUP_GRACE_NS = 10 * NS_PER_S
#: Interval at which the node looks whether the table being built is ready [s].
TABLE_POLL = 0.5


class TwinNode(TableNode):
    """The twin's simulator on ROS 2 topics, stepped at a fixed rate in step with the clock.

    Parameters: :data:`~ballscrew_twin.ros.twin_parameters.TWIN_PARAMETERS` (see
    ``docs/nodes.md`` and ``config/twin_node.yaml``). Keyword arguments are passed to
    :class:`rclpy.node.Node` (``context``, ``parameter_overrides``, ``cli_args`` ...).

    Raises:
        ParameterRefusedError: a start-up value the parameter table refuses (choices).
        ConfigError: ``contact_rate_hz`` above ``sim_rate_hz``, an initial value outside the
            limits.
    """

    def __init__(self, node_name: str = NODE_NAME, **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        # input_preset first: it gives the input topics and types their defaults.
        self.declare_specs(s for s in TWIN_PARAMETERS if s.name == "input_preset")
        preset = INPUT_PRESETS[self._str("input_preset")]
        self.declare_specs((s for s in TWIN_PARAMETERS if s.name != "input_preset"), preset)
        if reason := rates_refused(self._float("sim_rate_hz"), self._float("contact_rate_hz")):
            raise ConfigError(f"parameter {reason}")
        #: Whether the node's clock is wall time (not /clock); kept up by _start_schedule.
        self._wall_time = not self.get_parameter("use_sim_time").value
        self.config = load_config(self._str("config_file") or None)
        #: Held while ticks run and while anything they read is changed (parameters,
        #: inputs, diagnostics windows): the ticks may run on a thread of their own.
        self.tick_lock = threading.Lock()
        self._throttle = Throttle(LOG_THROTTLE)
        critical_speed = self.config.screw.critical_speed
        self.inputs = TwinInputs(
            self, critical_speed, self.tick_lock, self._now_ns, self._log_throttled
        )
        self.tables = RealTimeTables(
            self.config,
            self._str("realtime_map"),
            self._int("table_workers"),
            self.get_logger().info,
            wanted=self._str("fidelity") in TABLE_FIDELITIES,
        )
        settings = self._model_settings({})
        self.models = TwinModels(
            fidelity_modes.choose(self._str("fidelity"), settings),
            fidelity_modes.build("catalog", settings),
            self.inputs.operating_point,
            lambda: self._model_settings({}),
            self.get_logger().warning,
            self._log_throttled,
        )
        self.last_output: TwinOutput | None = None
        self.ticks = TickBook(STARTUP_GRACE_NS)
        self._window_start_ns = self._now_ns()
        self._frame_id = self._str("frame_id")
        self._torque_encoder = cdr.DragTorqueEncoder(self._frame_id)

        self._torque_pub = self.create_publisher(DragTorque, self._str("torque_topic"), 10)
        self._contact_pub = self.create_publisher(ContactStateArray, self._str("contact_topic"), 5)
        self._diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self._timer: Timer | None = None
        self._tick_thread: TickThread | None = None
        self._start_schedule()
        # On the steady clock: diagnostics go on (and say so) while a replay's /clock pauses.
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        rate = self._float("diagnostics_rate_hz")
        self._diag_timer = self.create_timer(1.0 / rate, self._publish_diagnostics, clock=steady)
        self._table_timer: Timer | None = None
        if self.tables.building:
            self._table_timer = self.create_timer(TABLE_POLL, self._take_table, clock=steady)

        # Registered after the declarations: they validate and apply run-time changes only.
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)

        choice = self.models.choice
        self.get_logger().info(
            f"model {choice.model.name} ({choice.reason}) with {self.config.source}; "
            f"publishing {self._torque_pub.topic_name} at {self.sim_rate:g} Hz, "
            f"{self._contact_pub.topic_name} at {self._float('contact_rate_hz'):g} Hz; initial "
            f"{describe(self.inputs.operating_point)}"
        )

    # ------------------------------------------------------------------ parameters
    @property
    def sim_rate(self) -> float:
        """Simulation step rate [Hz]."""
        return self._float("sim_rate_hz")

    def _model_settings(self, changes: dict[str, Any]) -> fidelity_modes.ModelSettings:
        """What the models are built from, after ``changes``."""
        return fidelity_modes.ModelSettings(
            config=self.config,
            mu_lit=float(self._value("mu_lit", changes)),
            tolerance=float(self._value("tolerance", changes)),
            steady_mode=self._value("steady_mode", changes),
            realtime_map=str(self._value("realtime_map", changes)),
            # A new realtime_map is looked at (and refused if built for other parameters).
            table=None if "realtime_map" in changes else self.tables.table,
        )

    def _validate_parameters(self, params: list[Parameter]) -> SetParametersResult:
        """Check run-time changes against the table and each other; build a new model."""
        if (refused := self.refuse_changes(TWIN_PARAMETERS, params)) is not None:
            return refused
        changes = {p.name: p.value for p in params}
        sim_rate, contact_rate = (self._value(n, changes) for n in RATE_PARAMETERS[:2])
        if (reason := rates_refused(float(sim_rate), float(contact_rate))) is not None:
            return SetParametersResult(successful=False, reason=reason)
        if any(name in changes for name in MODEL_PARAMETERS):
            try:
                settings = self._model_settings(changes)
                choice = fidelity_modes.choose(str(self._value("fidelity", changes)), settings)
                fallback = fidelity_modes.build("catalog", settings)
            except (ValueError, BallscrewTwinError) as err:
                return SetParametersResult(successful=False, reason=str(err))
            self.models.prepare(choice, fallback)
        return SetParametersResult(successful=True)

    def _apply_parameters(self, params: list[Parameter]) -> None:
        """Apply run-time parameter changes that passed validation (under the tick lock)."""
        names = {p.name for p in params}
        with self.tick_lock:
            if names & set(MODEL_PARAMETERS):
                self.models.apply(self.inputs.operating_point)
            if names & {*RATE_PARAMETERS, "use_sim_time"}:
                self._start_schedule()
                self.get_logger().info(
                    f"simulation now {self.sim_rate:g} Hz, contact states "
                    f"{self._float('contact_rate_hz'):g} Hz"
                )
            if "frame_id" in names:
                self._frame_id = self._str("frame_id")
                self._torque_encoder = cdr.DragTorqueEncoder(self._frame_id)

    # ------------------------------------------------------------------ models
    def _take_table(self) -> None:
        """Table timer: once the full table is built, run the real-time model on it (the
        model is built and warmed up here, outside the tick lock; the switch is under it)."""
        built = self.tables.take_built()
        if built is None and self.tables.building:
            return
        if self._table_timer is not None:  # built, or the build failed (on /diagnostics)
            self.destroy_timer(self._table_timer)
            self._table_timer = None
        requested = self._str("fidelity")
        if built is None or requested not in TABLE_FIDELITIES:
            return
        if requested == "auto" and self.models.choice.mode not in ("realtime", "catalog"):
            return
        try:
            choice = fidelity_modes.choose(requested, self._model_settings({}))
        except (ValueError, BallscrewTwinError) as err:
            self.get_logger().error(f"the table built cannot serve: {err}")
            return
        reason = f"{choice.reason}; table of this screw built in {built.seconds:.0f} s"
        with self.tick_lock:
            choice = fidelity_modes.ModelChoice(choice.model, choice.mode, reason)
            self.models.switch(choice, self.inputs.operating_point)

    # ------------------------------------------------------------------ schedule
    def _start_schedule(self) -> None:
        """(Re)start the tick schedule at the current rates, driven by the tick thread on wall
        time (``tick_source: thread``) or by an executor timer (also under use_sim_time)."""
        self.period_ns = max(round(NS_PER_S / self.sim_rate), 1)
        self._wall_time = not self.get_parameter("use_sim_time").value
        self.scheduler = TickScheduler(
            self.period_ns, self._int("max_catch_up_ticks"), wall_clock=self._wall_time
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
                self._thread_due, self._on_tick_error, priority=self._int("thread_priority")
            )
            self._tick_thread.start()

    @property
    def tick_source(self) -> str:
        """What drives the ticks now, and how it is scheduled."""
        if self._timer is not None:
            return "executor timer"
        return f"thread ({self._tick_thread.scheduling})" if self._tick_thread else "none"

    def _now_ns(self) -> int:
        """The node's clock [ns] (wall time, or /clock under use_sim_time). On wall time read
        directly: the ROS clock is then the system clock, and asking rclpy costs ~5 us."""
        if self._wall_time:
            return time.time_ns()
        return int(self.get_clock().now().nanoseconds)

    def _log_throttled(self, key: str, text: str) -> None:
        """Warn at most once per :data:`LOG_THROTTLE` per ``key``."""
        if self._throttle.allows(key):
            self.get_logger().warning(text)

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
        self.ticks.totals.tick_errors += 1
        self._log_throttled(
            "tick", f"tick failed ({self.ticks.totals.tick_errors} so far): {err!r}"
        )

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
            self.ticks.totals.clock_jumps_back += 1
            self.inputs.forget_times()
            self.models.choice.model.reset(self.inputs.operating_point)
            self.get_logger().warning(
                f"clock jumped backwards to {now / NS_PER_S:.6f} s: simulation restarted there, "
                "model reset, input stamps forgotten"
            )
        if plan.jumped_forward:
            self.ticks.totals.clock_jumps_forward += 1
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

    def book_skipped(self, count: int) -> None:
        """Count ``count`` skipped ticks: logged as information at start-up, else a warning."""
        if self.ticks.book_skipped(count, self.models.step_down.window):
            self.get_logger().info(
                f"{count} ticks skipped at start-up (loading and warming up the model)"
            )
            return
        behind = f"more than {self.scheduler.max_catch_up} ticks behind"
        self._log_throttled("skipped", f"{count} ticks skipped: the node fell {behind}")

    def _tick(self, index: int) -> None:
        """Step the model once and publish the tick's drag torque (and contact states)."""
        op = self.inputs.operating_point
        publish_contacts = bool(self.contact_every) and index % self.contact_every == 0
        period = self.period_ns / NS_PER_S
        requested = self._str("fidelity")
        start = time.perf_counter()
        out, failed = self.models.step(op, period, contacts=publish_contacts, requested=requested)
        step_time = time.perf_counter() - start
        self.ticks.window.failures += failed
        tick_ns = self.scheduler.time_of(index)
        sec, nanosec = ns_to_stamp(tick_ns)
        # Simulated time per compute time (>= 1 keeps up); below the clock's resolution it is
        # counted as one nanosecond.
        rtf = period / max(step_time, 1e-9)
        self._torque_pub.publish(
            encode_torque(self._torque_encoder, out, sec, nanosec, real_time_factor=rtf)
        )
        self.last_output = out
        # Tick latency: due time to torque published (contact states follow, at a lower rate).
        latency = self._now_ns() - tick_ns
        self.ticks.book_published(step_time, latency, self.models.step_down.window)
        if publish_contacts and out.contacts is not None:
            self._publish_contacts(out, sec, nanosec)
        if self.models.step_down.window_full(self.sim_rate):
            self._review_fidelity()

    def _review_fidelity(self) -> None:
        """After one simulated second: step down if the model overran its budget too long."""
        self.models.review(
            self.inputs.operating_point,
            requested=self._str("fidelity"),
            step_budget=self._float("step_budget"),
            period=self.period_ns / NS_PER_S,
        )

    def _publish_contacts(self, out: TwinOutput, sec: int, nanosec: int) -> None:
        """Publish the contact states of ``out`` stamped ``sec``/``nanosec`` [s]/[ns], or log
        why not (a value that is not finite)."""
        data = encode_contacts(out, sec, nanosec, self._frame_id)
        if data is None:
            self._log_throttled(
                "contacts",
                f"model {out.fidelity} returned non-finite contact states: not published",
            )
            return
        self._contact_pub.publish(data)
        self.ticks.totals.contacts += 1

    # ------------------------------------------------------------------ diagnostics
    def diagnostic_checks(self) -> list[diagnostics.Check]:
        """The checks of the window since the last call (which restarts the window)."""
        with self.tick_lock:
            now = self._now_ns()
            w = self.ticks.close_window()
            elapsed = max((now - self._window_start_ns) / NS_PER_S, 1e-9)
            self._window_start_ns = now
            return self._checks(w, now, elapsed)

    def _checks(self, w: TickWindow, now: int, elapsed: float) -> list[diagnostics.Check]:
        """The checks of the window ``w`` of ``elapsed`` seconds that ends at ``now`` [ns]."""
        requested = self._str("fidelity")
        checks = [
            twin_diagnostics.model_check(
                self.models.choice,
                requested=requested,
                switches=self.models.switches,
                failures=self.models.failures,
                w=w,
            ),
            self.real_time_check(w, elapsed),
        ]
        stale_after = self._float("stale_after")
        inputs = self.inputs
        checks += [
            twin_diagnostics.input_check(
                c, now, stale_after=stale_after, elapsed=elapsed, optional=c is inputs.axial_load
            )
            for c in inputs.channels
        ]
        out = self.last_output
        checks.append(twin_diagnostics.validity_check(out.notes if out is not None else ()))
        if requested in TABLE_FIDELITIES:
            checks.append(self.tables.check())
        return checks

    def real_time_check(self, w: TickWindow, elapsed: float) -> diagnostics.Check:
        """The ``real time`` check of the window ``w`` of ``elapsed`` seconds."""
        return twin_diagnostics.real_time_check(
            w,
            elapsed,
            self.ticks.totals,
            sim_rate=self.sim_rate,
            period=self.period_ns / NS_PER_S,
            min_on_time_share=self._float("min_on_time_share"),
            use_sim_time=bool(self.get_parameter("use_sim_time").value),
            tick_source=self.tick_source,
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


def main(args: list[str] | None = None) -> None:
    """Console script ``twin_node``: run :class:`TwinNode` until SIGINT/SIGTERM.

    Accepts ROS arguments, e.g. ``twin_node --ros-args --params-file config/twin_node.yaml``.
    """
    raise SystemExit(run_node(sys.argv if args is None else args))


def run_node(argv: list[str]) -> int:
    """Run :class:`TwinNode` with ROS arguments ``argv`` until shut down; the exit code."""
    return run_node_process("twin_node", argv, TwinNode, _executor)


def _executor(node: TwinNode) -> Executor:
    """The executor the ``executor`` parameter names, spinning ``node``, with the process's
    scheduling set up (``thread_priority``)."""
    executor = make_executor(node._str("executor"), node.context)
    executor.add_node(node)
    priority = node._int("thread_priority")
    scheduling = prepare_process(priority)
    if priority:
        node.get_logger().info(f"executor thread: {scheduling}")
    return executor


if __name__ == "__main__":
    main()
