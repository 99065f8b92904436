"""The CDR encoders of :mod:`ballscrew_twin.ros.cdr` against independent oracles.

- rclpy: ``deserialize_message`` of the encoded bytes gives back every field bit for bit, and
  ``serialize_message`` of the equivalent message agrees at every byte that is not padding (rmw
  leaves padding uninitialised). Which bytes are data is worked out here by a generic walk over
  the message's own field types (``get_fields_and_field_types``), not from the encoder; every
  other byte of the encoding must be zero.
- rosbags, which writes zero padding: ``serialize_cdr`` of the same message built in the
  project's rosbags type store (:func:`ballscrew_twin.bags.writer.project_typestore`) is equal byte
  for byte.
- DDS: published as ``bytes`` on loopback, a subscription receives the message.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pytest
from ballscrew_twin_msgs.msg import ContactState, ContactStateArray, DragTorque
from builtin_interfaces.msg import Time
from hypothesis import given, settings
from hypothesis import strategies as st
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.serialization import deserialize_message, serialize_message
from std_msgs.msg import Header

from ballscrew_twin.bags.writer import project_typestore
from ballscrew_twin.errors import MessageEncodingError
from ballscrew_twin.ros.cdr import (
    CONTACT_FLOAT_FIELDS,
    DragTorqueEncoder,
    encode_contact_states,
    header_stamp_ns,
)

from .conftest import OPERATING_POINT, TORQUES, SpinUntil

#: Sizes [byte] of the primitive field types as rclpy names them.
PRIMITIVE_SIZES = {"boolean": 1, "uint8": 1, "uint16": 2, "int32": 4, "uint32": 4, "double": 8}
#: ASCII strings of every length 0..9 (all alignments of what follows them).
LENGTHS = range(10)

FINITE = st.floats(allow_nan=False, allow_infinity=False)
TEXT = st.text(st.characters(codec="utf-8", exclude_characters="\x00"), max_size=10)


@pytest.fixture(scope="module")
def store() -> Any:
    """rosbags type store with the project's messages."""
    return project_typestore()


@dataclass(frozen=True)
class Drag:
    """Field values of one DragTorque."""

    sec: int
    nanosec: int
    frame_id: str
    fidelity: str
    torques: tuple[float, ...]
    point: tuple[float, ...]  # real_time_factor, screw_speed, temperature, preload, axial_load


@dataclass(frozen=True)
class Contacts:
    """Field values of one ContactStateArray (row i is contacts[i])."""

    sec: int
    nanosec: int
    frame_id: str
    fidelity: str
    sphere_index: np.ndarray
    nut: np.ndarray
    half_groove: np.ndarray
    in_contact: np.ndarray
    columns: list[np.ndarray]

    def encode(self) -> bytes:
        return encode_contact_states(
            self.sec,
            self.nanosec,
            self.frame_id,
            self.fidelity,
            self.sphere_index,
            self.nut,
            self.half_groove,
            self.in_contact,
            self.columns,
        )

    def row(self, i: int) -> dict[str, Any]:
        values: dict[str, Any] = {
            "sphere_index": int(self.sphere_index[i]),
            "nut": int(self.nut[i]),
            "half_groove": int(self.half_groove[i]),
            "in_contact": bool(self.in_contact[i]),
        }
        values.update(
            (f, float(c[i])) for f, c in zip(CONTACT_FLOAT_FIELDS, self.columns, strict=True)
        )
        return values


def _bits(x: float) -> int:
    """The float64's bit pattern (tells -0.0 from 0.0)."""
    return int(np.float64(x).view(np.uint64))


def _wild_floats(rng: np.random.Generator, n: int) -> np.ndarray:
    """n finite floats of every sign and magnitude, subnormals and extremes included."""
    values = rng.standard_normal(n) * 10.0 ** rng.integers(-320, 306, n)
    specials = [-0.0, 5e-324, -2.2e-308, 1.7976931348623157e308, -1.7976931348623157e308]
    values[: min(n, len(specials))] = specials[:n]
    return rng.permutation(values)


def _contacts(n: int, frame_id: str, fidelity: str, seed: int = 0) -> Contacts:
    rng = np.random.default_rng(seed)
    return Contacts(
        sec=int(rng.integers(-(2**31), 2**31)),
        nanosec=int(rng.integers(0, 2**32)),
        frame_id=frame_id,
        fidelity=fidelity,
        sphere_index=rng.integers(0, 2**16, n),
        nut=rng.integers(0, 2**8, n),
        half_groove=rng.integers(0, 2**8, n),
        in_contact=rng.random(n) < 0.5,
        columns=[_wild_floats(rng, n) for _ in CONTACT_FLOAT_FIELDS],
    )


# ---------------------------------------------------------------------------------------------
# Oracles


def _data_spans(msg: Any, at: int, spans: list[tuple[int, int]]) -> int:
    """Append the byte ranges [start, end) holding data of ``msg`` (CDR from offset ``at``,
    counted after the encapsulation header); return the offset after the message.

    Generic over the field types rclpy reports, so it shares nothing with the encoder.
    """
    for name, kind in msg.get_fields_and_field_types().items():
        value = getattr(msg, name)
        if kind in PRIMITIVE_SIZES:
            size = PRIMITIVE_SIZES[kind]
            at = -(-at // size) * size
            spans.append((at, at + size))
            at += size
        elif kind == "string":
            at = -(-at // 4) * 4
            size = 4 + len(value.encode("utf-8")) + 1
            spans.append((at, at + size))
            at += size
        elif kind.startswith("sequence<"):
            at = -(-at // 4) * 4
            spans.append((at, at + 4))
            at += 4
            for element in value:
                at = _data_spans(element, at, spans)
        else:
            at = _data_spans(value, at, spans)
    return at


def _check_against_rclpy(encoded: bytes, msg: Any) -> None:
    """Same length as rclpy's serialisation, equal at every data byte, zero elsewhere."""
    reference = serialize_message(msg)
    assert len(encoded) == len(reference)
    assert encoded[:4] == reference[:4] == b"\x00\x01\x00\x00"
    spans: list[tuple[int, int]] = []
    end = _data_spans(msg, 0, spans)
    assert 4 + end == len(encoded)
    is_data = np.zeros(len(encoded), dtype=bool)
    for start, stop in spans:
        is_data[4 + start : 4 + stop] = True
    is_data[:4] = True
    mine = np.frombuffer(encoded, dtype=np.uint8)
    theirs = np.frombuffer(reference, dtype=np.uint8)
    wrong = np.flatnonzero(is_data & (mine != theirs))
    assert wrong.size == 0, f"data bytes differ from rclpy's at {wrong.tolist()}"
    dirty = np.flatnonzero(~is_data & (mine != 0))
    assert dirty.size == 0, f"padding bytes not zero at {dirty.tolist()}"


def _header(sec: int, nanosec: int, frame_id: str) -> Header:
    return Header(stamp=Time(sec=sec, nanosec=nanosec), frame_id=frame_id)


def _drag_rclpy(d: Drag) -> DragTorque:
    return DragTorque(
        header=_header(d.sec, d.nanosec, d.frame_id),
        fidelity=d.fidelity,
        **dict(zip(TORQUES, d.torques, strict=True)),
        **dict(zip(OPERATING_POINT, d.point, strict=True)),
    )


def _rosbags_header(store: Any, sec: int, nanosec: int, frame_id: str) -> Any:
    time = store.types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec)
    return store.types["std_msgs/msg/Header"](stamp=time, frame_id=frame_id)


def _check_drag(store: Any, encoder: DragTorqueEncoder, d: Drag) -> None:
    encoded = encoder.encode(d.sec, d.nanosec, d.torques, d.fidelity, *d.point)
    assert isinstance(encoded, bytes)

    got = deserialize_message(encoded, DragTorque)
    assert (got.header.stamp.sec, got.header.stamp.nanosec) == (d.sec, d.nanosec)
    assert (got.header.frame_id, got.fidelity) == (d.frame_id, d.fidelity)
    for name, value in zip(TORQUES + OPERATING_POINT, d.torques + d.point, strict=True):
        assert _bits(getattr(got, name)) == _bits(value), name

    _check_against_rclpy(encoded, _drag_rclpy(d))

    typename = "ballscrew_twin_msgs/msg/DragTorque"
    bag_msg = store.types[typename](
        header=_rosbags_header(store, d.sec, d.nanosec, d.frame_id),
        fidelity=d.fidelity,
        **dict(zip(TORQUES, d.torques, strict=True)),
        **dict(zip(OPERATING_POINT, d.point, strict=True)),
    )
    assert encoded == bytes(store.serialize_cdr(bag_msg, typename))


def _check_contacts(store: Any, c: Contacts) -> None:
    encoded = c.encode()
    assert isinstance(encoded, bytes)
    n = len(c.sphere_index)

    got = deserialize_message(encoded, ContactStateArray)
    assert (got.header.stamp.sec, got.header.stamp.nanosec) == (c.sec, c.nanosec)
    assert (got.header.frame_id, got.fidelity) == (c.frame_id, c.fidelity)
    assert len(got.contacts) == n
    for name, expected in (
        ("sphere_index", c.sphere_index),
        ("nut", c.nut),
        ("half_groove", c.half_groove),
        ("in_contact", c.in_contact),
    ):
        assert [getattr(s, name) for s in got.contacts] == expected.tolist(), name
    for name, column in zip(CONTACT_FLOAT_FIELDS, c.columns, strict=True):
        assert [_bits(getattr(s, name)) for s in got.contacts] == [_bits(v) for v in column], name

    msg = ContactStateArray(
        header=_header(c.sec, c.nanosec, c.frame_id),
        fidelity=c.fidelity,
        contacts=[ContactState(**c.row(i)) for i in range(n)],
    )
    _check_against_rclpy(encoded, msg)

    typename = "ballscrew_twin_msgs/msg/ContactStateArray"
    state = store.types["ballscrew_twin_msgs/msg/ContactState"]
    bag_msg = store.types[typename](
        header=_rosbags_header(store, c.sec, c.nanosec, c.frame_id),
        fidelity=c.fidelity,
        contacts=[state(**c.row(i)) for i in range(n)],
    )
    assert encoded == bytes(store.serialize_cdr(bag_msg, typename))


# ---------------------------------------------------------------------------------------------
# Every alignment


def test_contact_float_fields_are_the_message_order() -> None:
    fields = ContactState.get_fields_and_field_types()
    assert tuple(f for f, kind in fields.items() if kind == "double") == CONTACT_FLOAT_FIELDS
    assert list(fields)[:4] == ["sphere_index", "nut", "half_groove", "in_contact"]
    drag = DragTorque.get_fields_and_field_types()
    assert tuple(f for f, kind in drag.items() if kind == "double") == TORQUES + OPERATING_POINT


@pytest.mark.parametrize("frame_len", LENGTHS)
def test_drag_torque_every_string_length(store: Any, frame_len: int) -> None:
    rng = np.random.default_rng(frame_len)
    encoder = DragTorqueEncoder("abcdefghi"[:frame_len])
    for fidelity_len in LENGTHS:
        values = _wild_floats(rng, 14).tolist()
        drag = Drag(
            sec=int(rng.integers(-(2**31), 2**31)),
            nanosec=int(rng.integers(0, 2**32)),
            frame_id=encoder.frame_id,
            fidelity="qrstuvwxy"[:fidelity_len],
            torques=tuple(values[:9]),
            point=tuple(values[9:]),
        )
        _check_drag(store, encoder, drag)


@pytest.mark.parametrize("n", [0, 1, 2, 7, 200])
@pytest.mark.parametrize("frame_len", LENGTHS)
def test_contact_states_every_string_length(store: Any, n: int, frame_len: int) -> None:
    for fidelity_len in LENGTHS:
        contacts = _contacts(n, "abcdefghi"[:frame_len], "qrstuvwxy"[:fidelity_len], seed=n)
        _check_contacts(store, contacts)


def test_contact_states_accept_narrow_dtypes_and_lists(store: Any) -> None:
    c = _contacts(5, "screw", "quasi-static")
    narrow = replace(
        c,
        sphere_index=c.sphere_index.astype(np.uint16),
        nut=c.nut.astype(np.uint8),
        half_groove=c.half_groove.astype(np.int16),
        in_contact=c.in_contact.astype(np.int64),
    )
    assert narrow.encode() == c.encode()
    as_lists = encode_contact_states(
        c.sec,
        c.nanosec,
        c.frame_id,
        c.fidelity,
        c.sphere_index.tolist(),
        c.nut.tolist(),
        c.half_groove.tolist(),
        c.in_contact.tolist(),
        [col.tolist() for col in c.columns],
    )
    assert as_lists == c.encode()


def test_drag_torque_encoder_many_fidelities(store: Any) -> None:
    """Cycling through more fidelity strings than the cache holds stays correct."""
    encoder = DragTorqueEncoder("ball_screw")
    for i in range(2 * 40):
        fidelity = f"model-{i % 40}" + "x" * (i % 5)
        values = tuple(float(i + k) for k in range(14))
        _check_drag(store, encoder, Drag(i, i, "ball_screw", fidelity, values[:9], values[9:]))


# ---------------------------------------------------------------------------------------------
# Property tests


@settings(max_examples=150, deadline=None)
@given(
    sec=st.integers(-(2**31), 2**31 - 1),
    nanosec=st.integers(0, 2**32 - 1),
    frame_id=TEXT,
    fidelity=TEXT,
    values=st.lists(FINITE, min_size=14, max_size=14),
)
def test_drag_torque_property(
    store: Any, sec: int, nanosec: int, frame_id: str, fidelity: str, values: list[float]
) -> None:
    drag = Drag(sec, nanosec, frame_id, fidelity, tuple(values[:9]), tuple(values[9:]))
    _check_drag(store, DragTorqueEncoder(frame_id), drag)


@settings(max_examples=150, deadline=None)
@given(data=st.data(), n=st.integers(0, 6))
def test_contact_states_property(store: Any, data: st.DataObject, n: int) -> None:
    def ints(high: int) -> np.ndarray:
        return np.array(data.draw(st.lists(st.integers(0, high), min_size=n, max_size=n)))

    floats = st.lists(FINITE, min_size=n, max_size=n)
    contacts = Contacts(
        sec=data.draw(st.integers(-(2**31), 2**31 - 1)),
        nanosec=data.draw(st.integers(0, 2**32 - 1)),
        frame_id=data.draw(TEXT),
        fidelity=data.draw(TEXT),
        sphere_index=ints(2**16 - 1),
        nut=ints(2**8 - 1),
        half_groove=ints(2**8 - 1),
        in_contact=np.array(data.draw(st.lists(st.booleans(), min_size=n, max_size=n)), bool),
        columns=[np.array(data.draw(floats), dtype=np.float64) for _ in CONTACT_FLOAT_FIELDS],
    )
    _check_contacts(store, contacts)


# ---------------------------------------------------------------------------------------------
# Bad input


def _encode_drag(**change: Any) -> bytes:
    args: dict[str, Any] = {
        "sec": 1,
        "nanosec": 2,
        "values": (0.1,) * 9,
        "fidelity": "catalog-zhou",
        "real_time_factor": 1.0,
        "screw_speed": 10.0,
        "temperature": 26.85,
        "preload": 1000.0,
        "axial_load": -250.0,
    }
    args.update(change)
    return DragTorqueEncoder("ball_screw").encode(**args)


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"values": (0.1,) * 8}, "9 torques.*got 8"),
        ({"values": (0.1,) * 10}, "9 torques.*got 10"),
        ({"sec": 2**31}, "sec 2147483648 .*int32"),
        ({"sec": -(2**31) - 1}, "sec .*int32"),
        ({"nanosec": -1}, "nanosec -1 .*uint32"),
        ({"nanosec": 2**32}, "nanosec .*uint32"),
        ({"preload": "1000"}, "not a number"),
        ({"values": (0.1,) * 8 + (None,)}, "not a number"),
        ({"fidelity": "a\x00b"}, "fidelity .*NUL"),
        ({"fidelity": "\ud800"}, "fidelity .*UTF-8"),
    ],
)
def test_drag_torque_bad_input(change: dict[str, Any], match: str) -> None:
    with pytest.raises(MessageEncodingError, match=match):
        _encode_drag(**change)


def test_drag_torque_bad_frame_id() -> None:
    with pytest.raises(MessageEncodingError, match=r"frame_id .*NUL"):
        DragTorqueEncoder("screw\x00")


def _shorter(a: np.ndarray) -> np.ndarray:
    return a[:-1]


Change = Callable[[Contacts], Contacts]


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (lambda c: replace(c, nut=_shorter(c.nut)), "nut has shape \\(3,\\).*length 4"),
        (lambda c: replace(c, sphere_index=_shorter(c.sphere_index)), "nut has shape"),
        (lambda c: replace(c, in_contact=_shorter(c.in_contact)), "in_contact has shape"),
        (lambda c: replace(c, columns=c.columns[:10]), "11 float arrays.*got 10"),
        (lambda c: replace(c, columns=[*c.columns, c.columns[0]]), "11 float arrays.*got 12"),
        (
            lambda c: replace(c, columns=[*c.columns[:10], _shorter(c.columns[10])]),
            "column slip_speed has shape",
        ),
        (
            lambda c: replace(c, columns=[c.columns[0].reshape(2, 2), *c.columns[1:]]),
            "column normal_force has shape",
        ),
        (lambda c: replace(c, sphere_index=np.array([0, 1, 2, 65536])), "sphere_index .*uint16"),
        (lambda c: replace(c, sphere_index=np.array([-1, 1, 2, 3])), "sphere_index .*uint16"),
        (lambda c: replace(c, nut=np.array([0, 1, 256, 0])), "nut .*uint8"),
        (lambda c: replace(c, half_groove=np.array([0, -3, 2, 0])), "half_groove .*uint8"),
        (lambda c: replace(c, sphere_index=np.array([0.0, 1.5, 2.0, 3.0])), "integers"),
        (lambda c: replace(c, sphere_index=np.zeros((2, 2), int)), "sphere_index must be 1-D"),
        (lambda c: replace(c, in_contact=np.array([0.0, 1.0, 0.0, 1.0])), "in_contact .*bools"),
        (lambda c: replace(c, sec=2**31), "sec .*int32"),
        (lambda c: replace(c, nanosec=-1), "nanosec .*uint32"),
        (lambda c: replace(c, frame_id="a\x00"), "frame_id .*NUL"),
        (lambda c: replace(c, fidelity="\x00"), "fidelity .*NUL"),
    ],
)
def test_contact_states_bad_input(change: Change, match: str) -> None:
    with pytest.raises(MessageEncodingError, match=match):
        change(_contacts(4, "screw", "quasi-static")).encode()


# ---------------------------------------------------------------------------------------------
# Published as bytes


def test_published_bytes_arrive_as_messages(
    executor: SingleThreadedExecutor, spin_until: SpinUntil
) -> None:
    node = Node("cdr_bytes", context=executor.context)
    executor.add_node(node)
    torques: list[DragTorque] = []
    states: list[ContactStateArray] = []
    node.create_subscription(DragTorque, "cdr_drag", torques.append, 10)
    node.create_subscription(ContactStateArray, "cdr_contacts", states.append, 10)
    drag_pub = node.create_publisher(DragTorque, "cdr_drag", 10)
    contacts_pub = node.create_publisher(ContactStateArray, "cdr_contacts", 10)
    drag = DragTorqueEncoder("ball_screw").encode(
        7, 8, tuple(0.01 * k for k in range(9)), "catalog-zhou", 2.0, -10.47, 40.0, 3000.0, 150.0
    )
    contacts = _contacts(200, "ball_screw", "quasi-static")

    def publish() -> None:
        drag_pub.publish(drag)
        contacts_pub.publish(contacts.encode())

    assert spin_until(executor, lambda: bool(torques and states), every=publish)
    assert torques[0].fidelity == "catalog-zhou"
    assert math.isclose(torques[0].spin, 0.08)
    assert torques[0].screw_speed == -10.47
    assert (torques[0].temperature, torques[0].axial_load) == (40.0, 150.0)
    got = states[0]
    assert len(got.contacts) == 200
    assert got.contacts[199].sphere_index == contacts.sphere_index[199]
    assert _bits(got.contacts[123].film_thickness) == _bits(contacts.columns[6][123])


@pytest.mark.parametrize(("sec", "nanosec"), [(0, 0), (1_764_230_000, 999_999_999), (-5, 7)])
def test_header_stamp_is_read_from_what_rclpy_serialises(sec: int, nanosec: int) -> None:
    """The stamp of a message rclpy serialised, read without deserialising it."""
    header = Header(stamp=Time(sec=sec, nanosec=nanosec), frame_id="screw")
    for msg in (DragTorque(header=header, fidelity="x"), ContactStateArray(header=header)):
        assert header_stamp_ns(serialize_message(msg)) == sec * 1_000_000_000 + nanosec
