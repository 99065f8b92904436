"""Direct CDR serialisers for the twin's high-rate messages (``DragTorque``, ``ContactStateArray``).

rclpy's ``Publisher.publish`` also takes ``bytes``: an already serialised message, handed to the
middleware as is (``publish_raw``). Building the Python message objects and rclpy's Python -> C
conversion is what costs at the twin's rates: building and serialising took ~18 us per
``DragTorque`` (1 kHz) and ~2.4 ms per 200-row ``ContactStateArray`` (100 Hz), against ~0.6 us
and ~20 us for the encoders here, which write the bytes straight from floats and numpy arrays
(the 200-row array alone took ~0.55 ms in ``serialize_message`` once built).

Wire format (OMG CDR, as rmw produces it): a 4-byte encapsulation header ``00 01 00 00`` (plain
CDR, little endian), then the fields in message order. Each primitive is aligned to its own size
(2, 4 or 8 bytes) counted from the byte after the encapsulation header; a string is a uint32
length (UTF-8 bytes + the terminating NUL), the bytes and the NUL; a sequence is a uint32 count
and its elements; bool is one byte 0/1. Padding is written as zero bytes (rmw leaves it
uninitialised). Field layouts follow ``msg_defs/msg/*.msg``; ``test/ros/test_cdr.py`` checks
them against rclpy and rosbags.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from ..errors import MessageEncodingError
from ..units import NS_PER_S

#: Encapsulation header of plain little-endian CDR (representation id 0x0001, options 0).
ENCAPSULATION = b"\x00\x01\x00\x00"

#: Fidelity strings whose packer a :class:`DragTorqueEncoder` keeps before starting afresh.
MAX_CACHED_FIDELITIES = 32

#: ``ContactState`` float64 fields, in message order.
CONTACT_FLOAT_FIELDS = (
    "normal_force",
    "friction_force",
    "contact_angle",
    "max_pressure",
    "semi_axis_x",
    "semi_axis_y",
    "film_thickness",
    "tallian_parameter",
    "lubricant_share",
    "dry_share",
    "slip_speed",
)

#: Offset of the first float64 in a ``ContactState`` that starts 8-aligned [byte]: the uint16,
#: two uint8 and the bool take 5 bytes, padded to 8.
_CONTACT_FLOATS_AT = 8
#: Bytes of the integer head of a ``ContactState`` (uint16, uint8, uint8, bool).
_CONTACT_HEAD = 5

#: One ``ContactState`` that starts at an 8-aligned offset (every element but possibly the first;
#: see :func:`encode_contact_states`).
CONTACT_RECORD = np.dtype(
    {
        "names": ["sphere_index", "nut", "half_groove", "in_contact", *CONTACT_FLOAT_FIELDS],
        "formats": ["<u2", "u1", "u1", "?"] + ["<f8"] * len(CONTACT_FLOAT_FIELDS),
        "offsets": [0, 2, 3, 4]
        + [_CONTACT_FLOATS_AT + 8 * i for i in range(len(CONTACT_FLOAT_FIELDS))],
        "itemsize": _CONTACT_FLOATS_AT + 8 * len(CONTACT_FLOAT_FIELDS),
    }
)

_UINT32 = struct.Struct("<I")
_STAMP = struct.Struct("<iI")


def _align(offset: int, size: int) -> int:
    """``offset`` [byte] rounded up to a multiple of ``size`` [byte]."""
    return -(-offset // size) * size


def _string_body(name: str, text: str) -> bytes:
    """CDR string without padding: uint32 length (incl. the NUL), UTF-8 bytes, NUL.

    Raises:
        MessageEncodingError: ``text`` is not a str, holds a NUL or cannot be encoded as UTF-8.
    """
    if not isinstance(text, str):
        raise MessageEncodingError(f"{name} must be a str, got {type(text).__name__}")
    if "\x00" in text:
        raise MessageEncodingError(
            f"{name} {text!r} contains a NUL character, which ROS strings cannot hold"
        )
    try:
        data = text.encode("utf-8")
    except UnicodeEncodeError as err:
        raise MessageEncodingError(
            f"{name} {text!r} is not encodable as UTF-8 ({err.reason})"
        ) from err
    return _UINT32.pack(len(data) + 1) + data + b"\x00"


def header_stamp_ns(raw: bytes) -> int:
    """The ``header.stamp`` [ns] of a serialised message whose first field is a
    ``std_msgs/Header`` (``DragTorque``, ``ContactStateArray``, ...): its int32 sec and uint32
    nanosec right after the encapsulation header, read without deserialising the rest."""
    sec, nanosec = _STAMP.unpack_from(raw, len(ENCAPSULATION))
    return int(sec) * NS_PER_S + int(nanosec)


def _check_stamp(sec: int, nanosec: int) -> None:
    """MessageEncodingError when the stamp does not fit builtin_interfaces/Time (int32, uint32)."""
    if not -(2**31) <= sec < 2**31:
        raise MessageEncodingError(
            f"sec {sec} is outside the int32 range of builtin_interfaces/Time"
        )
    if not 0 <= nanosec < 2**32:
        raise MessageEncodingError(
            f"nanosec {nanosec} is outside the uint32 range of builtin_interfaces/Time"
        )


class DragTorqueEncoder:
    """Serialises ``ballscrew_twin_msgs/DragTorque`` with a fixed ``header.frame_id``.

    One :meth:`encode` is a single ``struct.Struct.pack`` call; the packer (layout and padding)
    depends on the frame id and the fidelity string and is compiled once per fidelity.

    Args:
        frame_id: ``header.frame_id`` of every message.

    Raises:
        MessageEncodingError: ``frame_id`` holds a NUL or is not valid UTF-8 text.
    """

    def __init__(self, frame_id: str) -> None:
        self.frame_id = frame_id
        self._frame = _string_body("frame_id", frame_id)
        self._packers: dict[str, tuple[struct.Struct, bytes]] = {}

    def _packer(self, fidelity: str) -> tuple[struct.Struct, bytes]:
        """Packer and string body of ``fidelity``, compiled on first use and cached."""
        fid = _string_body("fidelity", fidelity)
        # Offsets count from the byte after the encapsulation header.
        torques_at = _align(8 + len(self._frame), 8)  # stamp (8 bytes), frame_id
        fidelity_at = torques_at + 9 * 8  # 8-aligned, so also 4-aligned for the length
        rest_at = _align(fidelity_at + len(fid), 8)
        layout = (
            f"<4siI{len(self._frame)}s{torques_at - 8 - len(self._frame)}x9d"
            f"{len(fid)}s{rest_at - fidelity_at - len(fid)}x5d"
        )
        if len(self._packers) >= MAX_CACHED_FIDELITIES:
            self._packers.clear()
        self._packers[fidelity] = entry = (struct.Struct(layout), fid)
        return entry

    def encode(
        self,
        sec: int,
        nanosec: int,
        values: Sequence[float],
        fidelity: str,
        real_time_factor: float,
        screw_speed: float,
        temperature: float,
        preload: float,
        axial_load: float,
    ) -> bytes:
        """The CDR bytes (with encapsulation header) of one ``DragTorque``, ready to publish.

        Args:
            sec: ``header.stamp.sec`` [s] (int32).
            nanosec: ``header.stamp.nanosec`` [ns] (uint32).
            values: the nine torques in message order: total, nut_master, nut_slave,
                lubricant_shear, dry_contact, rolling_resistance, hysteresis, curvature,
                spin [N m].
            fidelity: name of the model that produced the values [-].
            real_time_factor: simulated time advanced / wall time spent [-].
            screw_speed: screw angular speed [rad/s].
            temperature: lubricant / contact temperature [deg C] (the message's unit).
            preload: axial preload between the nuts [N].
            axial_load: external axial load on the nut assembly [N].

        Raises:
            MessageEncodingError: not nine torques, a stamp out of range, a non-numeric value or a
                fidelity holding a NUL.
        """
        try:
            packer, fid = self._packers[fidelity]
        except KeyError:
            packer, fid = self._packer(fidelity)
        try:
            return packer.pack(
                ENCAPSULATION,
                sec,
                nanosec,
                self._frame,
                *values,
                fid,
                real_time_factor,
                screw_speed,
                temperature,
                preload,
                axial_load,
            )
        except struct.error as err:
            if len(values) != 9:
                raise MessageEncodingError(
                    f"values must hold the 9 torques total..spin [N m], got {len(values)}"
                ) from err
            _check_stamp(sec, nanosec)
            raise MessageEncodingError(f"DragTorque field is not a number: {err}") from err


def _index_array(name: str, values: ArrayLike, bits: int) -> np.ndarray:
    """``values`` as a 1-D integer array whose entries fit an unsigned ``bits``-bit field.

    An empty array may have any dtype (``np.asarray([])`` is float64).
    """
    array = np.asarray(values)
    if array.ndim != 1:
        raise MessageEncodingError(f"{name} must be 1-D, got shape {array.shape}")
    if array.dtype.kind == "u" and array.dtype.itemsize * 8 <= bits:
        return array
    if array.dtype.kind not in "iub" and array.size:
        raise MessageEncodingError(f"{name} must hold integers, got dtype {array.dtype}")
    if array.size and (array.min() < 0 or array.max() >= 2**bits):
        raise MessageEncodingError(
            f"{name} must lie in the uint{bits} range 0..{2**bits - 1}, "
            f"got {array.min()}..{array.max()}"
        )
    return array


def _flag_array(name: str, values: ArrayLike) -> np.ndarray:
    """``values`` as an array of bools or integers (nonzero is true); empty: any dtype."""
    array = np.asarray(values)
    if array.dtype.kind not in "biu" and array.size:
        raise MessageEncodingError(f"{name} must hold bools (or integers), got dtype {array.dtype}")
    return array


def encode_contact_states(
    sec: int,
    nanosec: int,
    frame_id: str,
    fidelity: str,
    sphere_index: ArrayLike,
    nut: ArrayLike,
    half_groove: ArrayLike,
    in_contact: ArrayLike,
    columns: Sequence[ArrayLike],
) -> bytes:
    """The CDR bytes (with encapsulation header) of one ``ContactStateArray``, ready to publish.

    Row ``i`` of the arrays is ``contacts[i]``. The records are written through a numpy
    structured view (:data:`CONTACT_RECORD`, 96 bytes) placed at the first 8-aligned offset at
    or after the sequence start. When the sequence starts 4 bytes short of that (the header
    strings decide), the first element's 5-byte integer head sits in those 4 bytes and the first
    padding byte, and its floats still land at the view's offset 8; from the second element on
    every element starts 8-aligned, 96 bytes apart.

    Args:
        sec: ``header.stamp.sec`` [s] (int32).
        nanosec: ``header.stamp.nanosec`` [ns] (uint32).
        frame_id: ``header.frame_id`` [-].
        fidelity: name of the model that computed the states [-].
        sphere_index: ball index within its nut, N integers in 0..65535 [-].
        nut: ``NUT_MASTER`` (0) or ``NUT_SLAVE`` (1), N integers in 0..255 [-].
        half_groove: ``S1``, ``S2``, ``N1`` or ``N2`` (0..3), N integers in 0..255 [-].
        in_contact: N bools (integers: nonzero is true) [-].
        columns: the 11 float arrays of length N in message order (:data:`CONTACT_FLOAT_FIELDS`):
            normal_force [N], friction_force [N], contact_angle [rad], max_pressure [Pa],
            semi_axis_x [m], semi_axis_y [m], film_thickness [m], tallian_parameter [-],
            lubricant_share [-], dry_share [-], slip_speed [m/s].

    Raises:
        MessageEncodingError: arrays of unequal length or not 1-D, not 11 columns, integers out
            of their field's range, a stamp out of range, or a string holding a NUL.
    """
    _check_stamp(sec, nanosec)
    heads = (
        ("sphere_index", _index_array("sphere_index", sphere_index, 16)),
        ("nut", _index_array("nut", nut, 8)),
        ("half_groove", _index_array("half_groove", half_groove, 8)),
        ("in_contact", _flag_array("in_contact", in_contact)),
    )
    count = len(heads[0][1])
    for name, array in heads:
        if array.shape != (count,):
            raise MessageEncodingError(
                f"{name} has shape {array.shape}; every array must be 1-D of the length "
                f"{count} of sphere_index"
            )
    if len(columns) != len(CONTACT_FLOAT_FIELDS):
        raise MessageEncodingError(
            f"columns must hold the {len(CONTACT_FLOAT_FIELDS)} float arrays "
            f"{', '.join(CONTACT_FLOAT_FIELDS)}; got {len(columns)}"
        )
    floats = [np.asarray(column, dtype=np.float64) for column in columns]
    for name, column in zip(CONTACT_FLOAT_FIELDS, floats, strict=True):
        if column.shape != (count,):
            raise MessageEncodingError(
                f"column {name} has shape {column.shape}; every array must be 1-D of the "
                f"length {count} of sphere_index"
            )

    frame = _string_body("frame_id", frame_id)
    fid = _string_body("fidelity", fidelity)
    # Offsets count from the byte after the encapsulation header.
    fidelity_at = _align(8 + len(frame), 4)
    count_at = _align(fidelity_at + len(fid), 4)
    start = count_at + 4
    records_at = _align(start, 8)
    total = records_at + count * CONTACT_RECORD.itemsize if count else start

    buffer = bytearray(len(ENCAPSULATION) + total)
    prefix = b"".join(
        (
            ENCAPSULATION,
            _STAMP.pack(sec, nanosec),
            frame,
            bytes(fidelity_at - 8 - len(frame)),
            fid,
            bytes(count_at - fidelity_at - len(fid)),
            _UINT32.pack(count),
        )
    )
    buffer[: len(prefix)] = prefix
    if count:
        here = len(ENCAPSULATION) + records_at
        records = np.ndarray((count,), dtype=CONTACT_RECORD, buffer=buffer, offset=here)
        for name, array in heads:
            records[name] = array
        for name, column in zip(CONTACT_FLOAT_FIELDS, floats, strict=True):
            records[name] = column
        if start != records_at:  # first element starts 4 bytes before the view
            there = len(ENCAPSULATION) + start
            buffer[there : there + _CONTACT_HEAD] = buffer[here : here + _CONTACT_HEAD]
            buffer[there + _CONTACT_HEAD : here + _CONTACT_FLOATS_AT] = bytes(
                here + _CONTACT_FLOATS_AT - there - _CONTACT_HEAD
            )
    return bytes(buffer)
