"""Thousands of random and adversarial commands: the node rejects what is wrong, says why, and
keeps publishing finite torque at operating points inside its limits."""

from __future__ import annotations

import math
import random

from ballscrew_twin_msgs.msg import DragTorque
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import Temperature
from std_msgs.msg import Float64

from ballscrew_twin.ros import diagnostics
from ballscrew_twin.ros.twin_node import TwinNode
from ballscrew_twin.units import NS_PER_S, RPM

from .conftest import SpinUntil

COMMANDS = 4000
#: Values no input may take, and values only some inputs may take.
NASTY = (
    math.nan,
    math.inf,
    -math.inf,
    -1.0,
    -1e-300,
    1e300,
    -1e300,
    1e9,
    0.0,
    5e-324,
    3000.0,
    3000.0 / RPM,
    293.15,
    -273.15,
    1.0e4,
)


def _value(rng: random.Random) -> float:
    if rng.random() < 0.6:
        return rng.choice(NASTY)
    return rng.choice(
        (rng.uniform(-2500.0, 2500.0), rng.uniform(0.0, 6.0e4), rng.uniform(-60.0, 250.0))
    )


def _stamp(rng: random.Random, now_ns: int) -> Time:
    """Unset, current, stale, future, far past or random header stamps."""
    ns = rng.choice(
        (
            0,
            now_ns,
            now_ns - 5 * NS_PER_S,
            now_ns + 5 * NS_PER_S,
            now_ns - NS_PER_S // 10,
            rng.randrange(0, 2**31) * NS_PER_S,
        )
    )
    return Time(sec=ns // NS_PER_S, nanosec=ns % NS_PER_S)


def test_adversarial_commands_never_stop_or_corrupt_the_output(
    executor: SingleThreadedExecutor, spin_until: SpinUntil
) -> None:
    twin = TwinNode(
        context=executor.context,
        parameter_overrides=[
            Parameter("fidelity", value="catalog"),
            Parameter("sim_rate_hz", value=500.0),
        ],
    )
    executor.add_node(twin)
    bench = Node("bench", context=executor.context)
    executor.add_node(bench)
    torques: list[DragTorque] = []
    bench.create_subscription(DragTorque, "drag_torque", torques.append, 100)
    published: list[DiagnosticArray] = []
    bench.create_subscription(DiagnosticArray, "/diagnostics", published.append, 10)
    qos = qos_profile_sensor_data
    pubs = {
        "speed": bench.create_publisher(Float64, "speed_command", qos),
        "preload": bench.create_publisher(Float64, "preload_command", qos),
        "axial": bench.create_publisher(Float64, "axial_load_command", qos),
        "temperature": bench.create_publisher(Temperature, "temperature", qos),
    }
    handlers = {
        "speed": twin.inputs.on_speed,
        "preload": twin.inputs.on_preload,
        "axial": twin.inputs.on_axial_load,
        "temperature": twin.inputs.on_temperature,
    }
    assert spin_until(executor, lambda: len(torques) >= 5)

    rng = random.Random(20261121)
    for i in range(COMMANDS):
        target = rng.choice(tuple(pubs))
        value = _value(rng)
        if target == "temperature":
            msg: Float64 | Temperature = Temperature(temperature=value)
            msg.header.stamp = _stamp(rng, twin._now_ns())
        else:
            msg = Float64(data=value)
        if rng.random() < 0.5:
            handlers[target](msg)  # straight into the callback, as fast as it goes
        else:
            pubs[target].publish(msg)  # through DDS on loopback, bursts included
        if i % 25 == 0:
            for _ in range(rng.randrange(1, 6)):
                executor.spin_once(timeout_sec=0.0)

    count = len(torques)
    assert spin_until(executor, lambda: len(torques) >= count + 50)  # still publishing

    limits = twin.inputs.limits
    for m in torques:
        values = [
            getattr(m, f)
            for f in (
                "total",
                "nut_master",
                "nut_slave",
                "screw_speed",
                "temperature",
                "preload",
                "real_time_factor",
            )
        ]
        assert all(math.isfinite(v) for v in values), m
        assert abs(m.screw_speed) <= limits.max_screw_speed
        kelvin = m.temperature + 273.15  # the message carries deg C
        assert limits.min_temperature - 1e-9 <= kelvin <= limits.max_temperature + 1e-9
        assert 0.0 <= m.preload <= limits.max_preload
        assert m.fidelity.startswith("catalog")

    assert twin.inputs.rejected > COMMANDS // 4
    reasons = {c.last_rejection.split(" ")[0] for c in twin.inputs.channels if c.rejected}
    assert reasons  # each channel keeps its last reason
    checks = {c.name: c for c in twin.diagnostic_checks()}
    # a rejection is a WARN in the /diagnostics window it falls in: the windows published
    # during the run and the one this call closes (a publish may have closed the window of
    # the last rejections just before it)
    windows = [[(s.message, diagnostics.level_of(s)) for s in a.status] for a in published]
    windows.append([(c.message, c.level) for c in checks.values()])
    rejected = [(m, level) for w in windows for m, level in w if "rejected" in m]
    assert rejected and all(level >= diagnostics.WARN for _, level in rejected)
    assert checks["model"].level == diagnostics.OK  # the model itself never failed
