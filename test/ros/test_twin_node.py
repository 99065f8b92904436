"""The twin node in-process on loopback: commands in, torque/contacts/diagnostics out."""

from __future__ import annotations

import dataclasses
import itertools
import math
import time
from collections.abc import Callable

import pytest
from ballscrew_twin_msgs.msg import ContactStateArray, DragTorque
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState, Temperature
from std_msgs.msg import Float64

from ballscrew_twin.models.base import OperatingPoint, TwinOutput
from ballscrew_twin.models.catalog import CatalogModel, drag_torque_zhou
from ballscrew_twin.models.validity import DEFAULT_MAX_PRELOAD
from ballscrew_twin.params import load_config
from ballscrew_twin.ros import diagnostics, fidelity_modes
from ballscrew_twin.ros.fidelity_modes import ModelSettings, unavailable
from ballscrew_twin.ros.inputs import NS_PER_S
from ballscrew_twin.ros.twin_node import STARTUP_GRACE_NS, TwinNode

from .conftest import OPERATING_POINT, TORQUES, SpinUntil

SPEED = 10.47  # rad/s (100 rpm)


class Bench(Node):
    """Stands in for a test bench: publishes commands, records what the twin publishes."""

    def __init__(self, executor: SingleThreadedExecutor) -> None:
        super().__init__("bench", context=executor.context)
        self.torques: list[DragTorque] = []
        self.contacts: list[ContactStateArray] = []
        self.diagnostics: list[DiagnosticArray] = []
        qos = qos_profile_sensor_data
        self.speed = self.create_publisher(Float64, "speed_command", qos)
        self.joint = self.create_publisher(JointState, "joint_states", qos)
        self.temp = self.create_publisher(Temperature, "temperature", qos)
        self.preload = self.create_publisher(Float64, "preload_command", qos)
        self.axial = self.create_publisher(Float64, "axial_load_command", qos)
        self.clock = self.create_publisher(Clock, "/clock", 10)
        self.create_subscription(DragTorque, "drag_torque", self.torques.append, 100)
        self.create_subscription(ContactStateArray, "contact_states", self.contacts.append, 10)
        self.create_subscription(DiagnosticArray, "/diagnostics", self.diagnostics.append, 10)
        executor.add_node(self)

    def command(self, speed: float, temp_c: float, preload: float) -> Callable[[], None]:
        """A function that publishes this command once (to call repeatedly while spinning)."""

        def publish() -> None:
            self.speed.publish(Float64(data=speed))
            self.temp.publish(Temperature(temperature=temp_c))
            self.preload.publish(Float64(data=preload))

        return publish


def _twin(executor: SingleThreadedExecutor, **params: object) -> TwinNode:
    overrides = [Parameter(k, value=v) for k, v in params.items()]
    node = TwinNode(context=executor.context, parameter_overrides=overrides)
    executor.add_node(node)
    return node


@pytest.fixture
def twin(executor: SingleThreadedExecutor) -> TwinNode:
    return _twin(executor, fidelity="catalog")


def _all_finite(msg: DragTorque) -> bool:
    return all(math.isfinite(getattr(msg, f)) for f in TORQUES + OPERATING_POINT)


def _reach(
    spin_until: SpinUntil,
    executor: SingleThreadedExecutor,
    bench: Bench,
    speed: float,
    temp_c: float,
    preload: float,
) -> DragTorque:
    """Command an operating point until a torque computed at it arrives; return that torque."""

    def arrived() -> bool:
        if not bench.torques:
            return False
        m = bench.torques[-1]
        return (
            math.isclose(m.screw_speed, speed)
            and math.isclose(m.preload, preload)
            and math.isclose(m.temperature, temp_c, abs_tol=1e-9)
        )

    assert spin_until(executor, arrived, every=bench.command(speed, temp_c, preload)), (
        f"no drag_torque at speed {speed} rad/s, {temp_c} deg C, {preload} N"
    )
    return bench.torques[-1]


def _stamp_ns(stamp: Time) -> int:
    return int(stamp.sec) * NS_PER_S + int(stamp.nanosec)


def _published_after(
    spin_until: SpinUntil, executor: SingleThreadedExecutor, bench: Bench, t_ns: int
) -> DragTorque:
    """The first torque of a tick due after ``t_ns`` (older ones may still be in flight)."""

    def later() -> list[DragTorque]:
        return [m for m in bench.torques if _stamp_ns(m.header.stamp) > t_ns]

    assert spin_until(executor, lambda: bool(later()))
    return later()[0]


def test_command_moves_torque_the_right_way_within_a_few_ticks(
    executor: SingleThreadedExecutor, twin: TwinNode, spin_until: SpinUntil
) -> None:
    bench = Bench(executor)
    low = _reach(spin_until, executor, bench, SPEED, 20.0, 1000.0)
    assert low.temperature == pytest.approx(20.0)  # deg C at the message edge (REP 103)

    # One preload step; note when the node took it, then find the first torque computed at it.
    accepted_at: list[int] = []

    def step_and_watch() -> None:
        bench.preload.publish(Float64(data=3000.0))
        if not accepted_at and twin.inputs.preload.value == 3000.0:
            assert twin.inputs.preload.last_arrival_ns is not None
            accepted_at.append(twin.inputs.preload.last_arrival_ns)

    skipped_before = twin.ticks.totals.skipped
    assert spin_until(executor, lambda: bool(accepted_at), every=step_and_watch)
    assert spin_until(executor, lambda: bench.torques[-1].preload == 3000.0)
    first = next(m for m in bench.torques if m.preload == 3000.0)
    ticks_after = (_stamp_ns(first.header.stamp) - accepted_at[0]) / twin.period_ns
    # The next tick run takes the command; ticks skipped under load (counted) come on top.
    assert ticks_after <= 1.0 + (twin.ticks.totals.skipped - skipped_before)

    # Eq. 52 is linear in preload: three times the preload, three times the torque.
    assert first.total == pytest.approx(3.0 * low.total, rel=1e-12)
    assert all(_all_finite(m) for m in bench.torques)
    config = load_config(None).screw
    assert low.total == pytest.approx(
        drag_torque_zhou(
            1000.0,
            0.002,
            config.nominal_contact_angle,
            config.pitch_radius,
            config.ball_radius,
            config.helix_angle,
        )
    )

    backward = _reach(spin_until, executor, bench, -SPEED, 20.0, 3000.0)
    assert backward.total == pytest.approx(-first.total)


@pytest.mark.parametrize("tick_source", ["thread", "executor"])
def test_torque_published_at_the_simulation_rate_on_a_fixed_grid(
    executor: SingleThreadedExecutor, spin_until: SpinUntil, tick_source: str
) -> None:
    twin = _twin(executor, fidelity="catalog", tick_source=tick_source)
    assert twin.tick_source.startswith({"thread": "thread (", "executor": "executor"}[tick_source])
    bench = Bench(executor)
    assert spin_until(executor, lambda: len(bench.torques) >= 200)
    stamps = [_stamp_ns(m.header.stamp) for m in bench.torques[-150:]]
    steps = {b - a for a, b in itertools.pairwise(stamps)}
    # Consecutive ticks are one period apart (a multiple when ticks were skipped under load).
    assert all(s > 0 and s % twin.period_ns == 0 for s in steps)
    assert twin.period_ns == NS_PER_S // 1000


@pytest.mark.parametrize("fidelity_mode", ["quasi_static", "realtime"])
def test_contact_states_carry_every_sphere(
    executor: SingleThreadedExecutor, spin_until: SpinUntil, fidelity_mode: str
) -> None:
    why = unavailable(fidelity_mode, ModelSettings(config=load_config(None)))
    if why is not None:
        pytest.skip(f"{fidelity_mode} model not available here: {why}")
    twin = _twin(
        executor,
        fidelity=fidelity_mode,
        steady_mode="full",
        sim_rate_hz=200.0,
        contact_rate_hz=50.0,
        initial_screw_speed=SPEED,
    )
    bench = Bench(executor)
    assert spin_until(executor, lambda: len(bench.contacts) >= 2, timeout=30.0)
    msg = bench.contacts[-1]
    z = twin.config.screw.balls_per_nut
    rows = {(c.nut, c.sphere_index, c.half_groove) for c in msg.contacts}
    assert rows == {(n, i, g) for n in (0, 1) for i in range(z) for g in range(4)}
    loaded = [c for c in msg.contacts if c.in_contact]
    assert {(c.nut, c.sphere_index) for c in loaded} == {(n, i) for n in (0, 1) for i in range(z)}
    assert all(c.normal_force > 0.0 and math.isfinite(c.max_pressure) for c in loaded)
    assert msg.fidelity == bench.torques[-1].fidelity


def test_parameters_reject_out_of_range_and_say_why(
    executor: SingleThreadedExecutor, twin: TwinNode, spin_until: SpinUntil
) -> None:
    bench = Bench(executor)
    before = _reach(spin_until, executor, bench, SPEED, 20.0, 1500.0)

    assert not twin.set_parameters([Parameter("sim_rate_hz", value=5000.0)])[0].successful
    assert not twin.set_parameters([Parameter("torque_topic", value="x")])[0].successful
    too_fast = twin.set_parameters([Parameter("contact_rate_hz", value=1500.0)])[0]
    assert not too_fast.successful and "contact_rate_hz" in too_fast.reason
    unknown = twin.set_parameters([Parameter("fidelity", value="psychic")])[0]
    assert not unknown.successful and "psychic" in unknown.reason
    assert not twin.set_parameters([Parameter("max_catch_up_ticks", value=0)])[0].successful

    assert twin.set_parameters([Parameter("mu_lit", value=0.004)])[0].successful
    after = _published_after(spin_until, executor, bench, twin._now_ns())
    assert after.total == pytest.approx(2.0 * before.total)  # Eq. 52: linear in mu

    assert twin.set_parameters([Parameter("sim_rate_hz", value=250.0)])[0].successful
    assert twin.period_ns == NS_PER_S // 250


def test_sim_time_follows_clock_and_survives_a_jump_back(
    executor: SingleThreadedExecutor, spin_until: SpinUntil
) -> None:
    twin = _twin(executor, fidelity="catalog", use_sim_time=True, sim_rate_hz=100.0)
    bench = Bench(executor)
    sim = {"ns": 1000 * NS_PER_S}

    def advance() -> None:  # 10 ms of sim time per spin step (much faster than wall time)
        sim["ns"] += 10_000_000
        bench.clock.publish(
            Clock(clock=Time(sec=sim["ns"] // NS_PER_S, nanosec=sim["ns"] % NS_PER_S))
        )

    assert spin_until(executor, lambda: len(bench.torques) >= 30, every=advance)
    stamps = [_stamp_ns(m.header.stamp) for m in bench.torques[-20:]]
    assert all(1000 * NS_PER_S < s <= sim["ns"] for s in stamps)
    assert all(b - a == twin.period_ns for a, b in itertools.pairwise(stamps))

    sim["ns"] = 500 * NS_PER_S  # replay restarted: the clock jumps back
    count = len(bench.torques)

    def after_jump() -> list[int]:
        stamps = [_stamp_ns(m.header.stamp) for m in bench.torques[count:]]
        return [s for s in stamps if s < 1000 * NS_PER_S]

    assert spin_until(executor, lambda: len(after_jump()) >= 10, every=advance)
    assert twin.ticks.totals.clock_jumps_back == 1
    assert all(500 * NS_PER_S <= s <= sim["ns"] for s in after_jump())
    assert _stamp_ns(bench.torques[-1].header.stamp) < 1000 * NS_PER_S


def test_a_stall_on_wall_time_counts_every_tick_not_published(
    executor: SingleThreadedExecutor, spin_until: SpinUntil
) -> None:
    twin = _twin(executor, fidelity="catalog", sim_rate_hz=100.0)
    bench = Bench(executor)
    # past start-up (a tick on time, or the grace time over): skipped ticks count from then on
    assert spin_until(
        executor,
        lambda: len(bench.torques) >= 3 and not twin.ticks.starting_up,
        timeout=STARTUP_GRACE_NS / NS_PER_S + 5.0,
    )
    skipped = twin.ticks.totals.skipped
    with twin.tick_lock:  # the tick thread cannot run: a 1.5 s stall (> the 1 s jump limit)
        time.sleep(1.5)
    published = twin.ticks.totals.published
    assert spin_until(executor, lambda: twin.ticks.totals.published >= published + 3)
    assert twin.ticks.totals.clock_jumps_forward == 1
    # ~150 ticks of 10 ms were due in the stall: counted as skipped, not lost.
    assert 130 <= twin.ticks.totals.skipped - skipped <= 170


def test_use_sim_time_switched_at_run_time_moves_the_ticks_to_the_clock(
    executor: SingleThreadedExecutor, spin_until: SpinUntil
) -> None:
    twin = _twin(executor, fidelity="catalog", sim_rate_hz=100.0)
    bench = Bench(executor)
    assert spin_until(executor, lambda: len(bench.torques) >= 3)
    assert twin.tick_source.startswith("thread")
    wall = _stamp_ns(bench.torques[-1].header.stamp)

    assert twin.set_parameters([Parameter("use_sim_time", value=True)])[0].successful
    assert twin.tick_source == "executor timer"
    sim = {"ns": 7 * NS_PER_S}

    def advance() -> None:
        sim["ns"] += 10_000_000
        bench.clock.publish(
            Clock(clock=Time(sec=sim["ns"] // NS_PER_S, nanosec=sim["ns"] % NS_PER_S))
        )

    def on_sim_time() -> list[int]:
        # Sim time is seconds since 7 s; wall time since 1970.
        return [s for m in bench.torques if (s := _stamp_ns(m.header.stamp)) < 1000 * NS_PER_S]

    assert spin_until(executor, lambda: len(on_sim_time()) >= 5, every=advance)
    assert all(7 * NS_PER_S < s <= sim["ns"] for s in on_sim_time())

    assert twin.set_parameters([Parameter("use_sim_time", value=False)])[0].successful
    assert twin.tick_source.startswith("thread")
    after = _published_after(spin_until, executor, bench, wall)
    assert after.header.stamp.sec > 1_000_000  # wall time again (seconds since 1970)


def test_joint_state_speed_input(executor: SingleThreadedExecutor, spin_until: SpinUntil) -> None:
    _twin(
        executor,
        fidelity="catalog",
        speed_type="joint_state",
        speed_topic="joint_states",
        speed_joint="screw",
    )
    bench = Bench(executor)

    def publish() -> None:
        msg = JointState(name=["carriage", "screw"], velocity=[0.1, -SPEED])
        msg.header.stamp = bench.get_clock().now().to_msg()
        bench.joint.publish(msg)

    assert spin_until(
        executor,
        lambda: bool(bench.torques) and bench.torques[-1].screw_speed == -SPEED,
        every=publish,
    )
    assert bench.torques[-1].total < 0.0


def test_diagnostics_report_model_real_time_inputs_and_validity(
    executor: SingleThreadedExecutor, spin_until: SpinUntil
) -> None:
    twin = _twin(executor, fidelity="catalog", diagnostics_rate_hz=5.0, stale_after=0.2)
    bench = Bench(executor)
    assert spin_until(executor, lambda: len(bench.diagnostics) >= 1)
    names = {s.name for s in bench.diagnostics[-1].status}
    assert {
        "ballscrew_twin: model",
        "ballscrew_twin: real time",
        "ballscrew_twin: input preload",
        "ballscrew_twin: validity",
    } <= names

    checks = {c.name: c for c in twin.diagnostic_checks()}
    assert checks["input preload"].level == diagnostics.WARN  # nothing received yet
    assert "no message yet" in checks["input preload"].message
    assert checks["input axial load"].level == diagnostics.OK  # optional input

    bench.preload.publish(Float64(data=2000.0))
    assert spin_until(executor, lambda: twin.inputs.preload.value == 2000.0)
    assert twin.diagnostic_checks()[2 + 2].level == diagnostics.OK  # preload fresh
    time.sleep(0.3)  # longer than stale_after: the publisher went away
    checks = {c.name: c for c in twin.diagnostic_checks()}
    assert "stale" in checks["input preload"].message
    assert "catalog" in checks["model"].message


def test_node_name_and_defaults(executor: SingleThreadedExecutor) -> None:
    node = TwinNode(context=executor.context)
    executor.add_node(node)
    assert node.get_name() == "ballscrew_twin"
    assert node.get_parameter("sim_rate_hz").value == 1000.0
    assert node.get_parameter("contact_rate_hz").value == 100.0
    assert node.get_parameter("fidelity").value == "auto"
    assert node.inputs.limits.max_screw_speed == node.config.screw.critical_speed
    why = unavailable("realtime", ModelSettings(config=node.config))
    assert node.models.choice.mode == ("catalog" if why else "realtime")
    if why:
        assert "realtime" in node.models.choice.reason


class FakeRealTime:
    """Stands in for the real-time model: Eq. 52 under another name, or a step that raises."""

    name = "fake_realtime"

    def __init__(self, fail: bool) -> None:
        self.fail = fail
        self.catalog = CatalogModel(load_config(None))

    def reset(self, op: OperatingPoint) -> None:
        op.validate()

    def step(self, op: OperatingPoint, dt: float) -> TwinOutput:
        if self.fail:
            raise FloatingPointError("diverged")
        return dataclasses.replace(self.catalog.evaluate(op), fidelity=self.name)


def _with_fake_realtime(monkeypatch: pytest.MonkeyPatch, fail: bool) -> None:
    real_build = fidelity_modes.build

    def build(mode: str, settings: ModelSettings) -> object:
        return FakeRealTime(fail) if mode == "realtime" else real_build(mode, settings)

    monkeypatch.setattr(fidelity_modes, "build", build)


def test_auto_steps_down_when_the_model_overruns_its_budget(
    executor: SingleThreadedExecutor, spin_until: SpinUntil, monkeypatch: pytest.MonkeyPatch
) -> None:
    _with_fake_realtime(monkeypatch, fail=False)
    twin = _twin(executor, fidelity="auto", sim_rate_hz=100.0)
    assert twin.models.choice.mode == "realtime"
    bench = Bench(executor)
    assert spin_until(executor, lambda: bool(bench.torques))
    assert bench.torques[-1].fidelity == "fake_realtime"

    # Windows in which every step took 90 % of the 10 ms step (the budget is 50 %): the first
    # is tolerated (start-up, a hiccup), the second in a row is not.
    for expected in ("realtime", "catalog"):
        with twin.tick_lock:  # the ticks run on a thread of their own
            twin.models.step_down.window = type(twin.models.step_down.window)()
            for _ in range(100):
                twin.models.step_down.window.add(step_time=9e-3, latency_ns=200_000)
            twin._review_fidelity()
        assert twin.models.choice.mode == expected
    assert twin.models.switches == 1
    assert "took 9.000 ms per step" in twin.models.choice.reason
    after = _published_after(spin_until, executor, bench, twin._now_ns())
    assert after.fidelity.startswith("catalog")
    assert "stepped down" in {c.name: c for c in twin.diagnostic_checks()}["model"].message


def test_failing_model_is_replaced_and_reported(
    executor: SingleThreadedExecutor, spin_until: SpinUntil, monkeypatch: pytest.MonkeyPatch
) -> None:
    _with_fake_realtime(monkeypatch, fail=True)
    twin = _twin(executor, fidelity="realtime", sim_rate_hz=100.0)
    bench = Bench(executor)
    assert spin_until(executor, lambda: len(bench.torques) >= 3)
    assert all(_all_finite(m) and m.fidelity.startswith("catalog") for m in bench.torques)
    assert twin.models.choice.mode == "realtime"  # explicitly requested: kept, catalogue stands in
    assert spin_until(executor, lambda: twin.ticks.window.failures > 0)
    check = {c.name: c for c in twin.diagnostic_checks()}["model"]
    assert check.level == diagnostics.WARN and "failed steps" in check.message
    assert twin.models.failures >= 3


@pytest.mark.parametrize(
    ("params", "named"),
    [
        ({"contact_rate_hz": 500.0, "sim_rate_hz": 100.0}, "contact_rate_hz"),
        ({"initial_temperature": 600.0}, "initial_temperature"),
        ({"fidelity": "psychic"}, "fidelity"),
    ],
)
def test_bad_start_up_parameters_refused(
    executor: SingleThreadedExecutor, params: dict[str, object], named: str
) -> None:
    with pytest.raises(ValueError, match=named):
        TwinNode(
            context=executor.context,
            parameter_overrides=[Parameter(k, value=v) for k, v in params.items()],
        )


def test_outside_the_envelope_clamped_and_warned(
    executor: SingleThreadedExecutor, spin_until: SpinUntil
) -> None:
    twin = _twin(executor, fidelity="catalog")
    bench = Bench(executor)
    inside = _reach(spin_until, executor, bench, SPEED, 20.0, 1000.0)
    # 20 kN: a plausible command (within limits.max_preload) beyond the validated 5 kN.
    bench.preload.publish(Float64(data=20_000.0))
    assert spin_until(
        executor,
        lambda: twin.inputs.preload.value == 20_000.0,
        every=lambda: bench.preload.publish(Float64(data=20_000.0)),
    )
    after = _published_after(spin_until, executor, bench, twin._now_ns())
    envelope_max = DEFAULT_MAX_PRELOAD  # N
    assert after.preload == envelope_max
    assert after.total == pytest.approx(inside.total * envelope_max / 1000.0)  # Eq. 52 linear
    check = {c.name: c for c in twin.diagnostic_checks()}["validity"]
    assert check.level == diagnostics.WARN and "preload" in check.message
