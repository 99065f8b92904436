"""Each custom message type goes through rclpy (publisher -> DDS on loopback -> subscription)
and arrives with every field unchanged."""

from __future__ import annotations

import math
from typing import Any

import pytest
from ballscrew_twin_msgs.msg import ContactState, ContactStateArray, DragTorque, HealthResidual
from builtin_interfaces.msg import Time
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from std_msgs.msg import Header

from .conftest import SpinUntil


def _header(sec: int) -> Header:
    return Header(stamp=Time(sec=sec, nanosec=123_456_789), frame_id="screw")


def _contact(i: int) -> ContactState:
    return ContactState(
        sphere_index=1000 + i,
        nut=ContactState.NUT_SLAVE,
        half_groove=ContactState.N2,
        in_contact=True,
        normal_force=123.25 + i,
        friction_force=0.5,
        contact_angle=math.radians(45.0),
        max_pressure=2.1e9,
        semi_axis_x=1.2e-4,
        semi_axis_y=6.5e-4,
        film_thickness=1.5e-7,
        tallian_parameter=3.2,
        lubricant_share=0.75,
        dry_share=0.25,
        slip_speed=1.0e-3,
    )


def _drag_torque() -> DragTorque:
    return DragTorque(
        header=_header(11),
        total=0.0383,
        nut_master=0.0191,
        nut_slave=0.0192,
        lubricant_shear=0.01,
        dry_contact=0.02,
        rolling_resistance=0.003,
        hysteresis=0.004,
        curvature=0.0005,
        spin=0.0008,
        fidelity="catalog-zhou",
        real_time_factor=0.004,
        screw_speed=-10.47,
        temperature=313.15,
        preload=3000.0,
    )


def _health() -> HealthResidual:
    return HealthResidual(
        header=_header(12),
        signal="drag_torque",
        measured=0.041,
        predicted=0.038,
        residual=0.003,
        normalized_residual=1.5,
        test_statistic=7.25,
        threshold=10.0,
        verdict=HealthResidual.WARN,
        fault_class="lubricant_degradation",
        confidence=0.6,
    )


SAMPLES: list[tuple[type, Any]] = [
    (ContactState, _contact(0)),
    (
        ContactStateArray,
        ContactStateArray(
            header=_header(10), fidelity="quasi-static", contacts=[_contact(0), _contact(1)]
        ),
    ),
    (DragTorque, _drag_torque()),
    (HealthResidual, _health()),
]


@pytest.mark.parametrize(("msg_type", "sent"), SAMPLES, ids=lambda v: getattr(v, "__name__", ""))
def test_round_trip(
    executor: SingleThreadedExecutor, spin_until: SpinUntil, msg_type: type, sent: Any
) -> None:
    node = Node("msg_round_trip", context=executor.context)
    executor.add_node(node)
    received: list[Any] = []
    node.create_subscription(msg_type, "round_trip", received.append, 10)
    pub = node.create_publisher(msg_type, "round_trip", 10)

    assert spin_until(executor, lambda: bool(received), every=lambda: pub.publish(sent))
    got = received[0]
    for field in sent.get_fields_and_field_types():
        assert getattr(got, field) == getattr(sent, field), field
    assert got == sent


def test_constants() -> None:
    assert (ContactState.NUT_MASTER, ContactState.NUT_SLAVE) == (0, 1)
    assert (ContactState.S1, ContactState.S2, ContactState.N1, ContactState.N2) == (0, 1, 2, 3)
    assert (
        HealthResidual.OK,
        HealthResidual.WARN,
        HealthResidual.FAULT,
        HealthResidual.UNKNOWN,
    ) == (0, 1, 2, 3)


def test_field_types() -> None:
    fields = ContactState.get_fields_and_field_types()
    assert fields["sphere_index"] == "uint16"
    assert fields["nut"] == "uint8"
    assert fields["half_groove"] == "uint8"
    assert fields["in_contact"] == "boolean"
    assert ContactStateArray.get_fields_and_field_types()["contacts"] == (
        "sequence<ballscrew_twin_msgs/ContactState>"
    )
    assert DragTorque.get_fields_and_field_types()["header"] == "std_msgs/Header"
    assert HealthResidual.get_fields_and_field_types()["verdict"] == "uint8"
