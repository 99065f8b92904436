"""The twin node's output messages as CDR bytes, from a model output (no rclpy here).

Published as bytes: building a Python DragTorque and converting it cost ~20 us a tick, the
encoder ~1 us; 200 contacts ~20 us against ~2.4 ms as 200 Python messages (``ros/cdr.py``).
Topics carry SI units except the temperature, in degrees Celsius at the message edge.
"""

from __future__ import annotations

import math

import numpy as np

from ..models.base import ContactStates, TwinOutput
from ..models.validity import all_finite
from ..units import CELSIUS_ZERO
from . import cdr


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


def finite_output(out: TwinOutput) -> bool:
    """Whether every number of ``out`` that goes into the torque message is finite."""
    return all(math.isfinite(v) for v in torque_values(out))


def encode_torque(
    encoder: cdr.DragTorqueEncoder,
    out: TwinOutput,
    sec: int,
    nanosec: int,
    *,
    real_time_factor: float,
) -> bytes:
    """The serialised DragTorque of one finite model output.

    Args:
        encoder: encoder of the node's frame id.
        out: model output [N m], finite; its ``operating_point`` (SI) is the point the model
            computed at (inside the validity envelope).
        sec, nanosec: stamp of the tick [s], [ns].
        real_time_factor: step / model compute time, >= 1 keeps up [-].
    """
    op = out.operating_point
    return encoder.encode(
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


def encode_contacts(out: TwinOutput, sec: int, nanosec: int, frame_id: str) -> bytes | None:
    """The serialised ContactStateArray of every resolved sphere/half-groove contact of
    ``out`` (stamp ``sec`` [s], ``nanosec`` [ns]), or None when a value is not finite."""
    cs = out.contacts
    assert cs is not None
    columns = [np.asarray(getattr(cs, name), dtype=np.float64) for name in cdr.CONTACT_FLOAT_FIELDS]
    if not all_finite(columns):
        return None
    return cdr.encode_contact_states(
        sec,
        nanosec,
        frame_id,
        out.fidelity,
        sphere_index_within_nut(cs),
        cs.nut,
        cs.half_groove,
        cs.in_contact,
        columns,
    )


def sphere_index_within_nut(cs: ContactStates) -> np.ndarray:
    """Index of each contact's sphere within its own nut, 0-based [-]."""
    index = np.asarray(cs.sphere, dtype=np.int64).copy()
    for nut in (0, 1):
        mask = cs.nut == nut
        if mask.any():
            index[mask] -= index[mask].min()
    return index
