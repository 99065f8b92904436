"""The twin node's messages from a model output: DragTorque and ContactStateArray bytes
decoded by rclpy, temperature in deg C at the edge, nothing non-finite published."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from ballscrew_twin_msgs.msg import ContactStateArray, DragTorque
from rclpy.serialization import deserialize_message

from ballscrew_twin.models.base import ContactStates, OperatingPoint, TwinOutput
from ballscrew_twin.models.catalog import CatalogModel
from ballscrew_twin.params import load_config
from ballscrew_twin.ros import cdr
from ballscrew_twin.ros.twin_messages import (
    encode_contacts,
    encode_torque,
    finite_output,
    sphere_index_within_nut,
    torque_values,
)

from .conftest import TORQUES

OP = OperatingPoint(screw_speed=10.0, temperature=303.15, preload=1500.0, axial_load=-20.0)


@pytest.fixture(scope="module")
def output() -> TwinOutput:
    return CatalogModel(load_config(None)).evaluate(OP)


def _contacts(spheres: list[int], nuts: list[int]) -> ContactStates:
    n = len(spheres)
    floats = {f.name: np.linspace(1.0, 2.0, n) for f in dataclasses.fields(ContactStates)}
    floats.update(
        sphere=np.asarray(spheres, dtype=np.int64),
        nut=np.asarray(nuts, dtype=np.int64),
        half_groove=np.zeros(n, dtype=np.int64),
        in_contact=np.ones(n, dtype=np.bool_),
    )
    return ContactStates(**floats)


def test_drag_torque_carries_the_output_in_si_and_deg_c(output: TwinOutput) -> None:
    data = encode_torque(cdr.DragTorqueEncoder("screw"), output, 7, 500, real_time_factor=42.0)
    msg = deserialize_message(data, DragTorque)
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (7, 500)
    assert msg.header.frame_id == "screw" and msg.fidelity == output.fidelity
    assert tuple(getattr(msg, f) for f in TORQUES) == torque_values(output)
    assert msg.total == output.drag_torque and msg.real_time_factor == 42.0
    assert msg.temperature == pytest.approx(30.0)  # deg C (sensor_msgs convention)
    assert (msg.screw_speed, msg.preload, msg.axial_load) == (
        output.operating_point.screw_speed,
        output.operating_point.preload,
        output.operating_point.axial_load,
    )


def test_a_non_finite_torque_is_found(output: TwinOutput) -> None:
    assert finite_output(output)
    bad = dataclasses.replace(output, drag_torque=math.nan)
    assert not finite_output(bad)


def test_contact_states_with_sphere_index_within_each_nut(output: TwinOutput) -> None:
    cs = _contacts([0, 1, 5, 6], [0, 0, 1, 1])
    assert sphere_index_within_nut(cs).tolist() == [0, 1, 0, 1]
    msg = deserialize_message(
        encode_contacts(dataclasses.replace(output, contacts=cs), 1, 2, "f"), ContactStateArray
    )
    assert msg.header.frame_id == "f" and len(msg.contacts) == 4
    assert [c.sphere_index for c in msg.contacts] == [0, 1, 0, 1]
    assert [c.normal_force for c in msg.contacts] == cs.normal_force.tolist()


def test_non_finite_contact_states_are_not_encoded(output: TwinOutput) -> None:
    cs = _contacts([0, 1], [0, 1])
    cs.max_pressure[1] = math.inf
    assert encode_contacts(dataclasses.replace(output, contacts=cs), 0, 0, "f") is None
