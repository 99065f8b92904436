"""Reading bench bags: round trip, types, and damaged bags (built on the fly in tmp_path)."""

from __future__ import annotations

import json
import math
import shutil
import struct
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from ballscrew_twin.bags.bench import read_bench_bag
from ballscrew_twin.bags.bench_writer import write_bench_bag
from ballscrew_twin.bags.reader import open_raw_bag
from ballscrew_twin.bags.recording import TRUTH_KEY, BenchTopics, truth_path
from ballscrew_twin.errors import BagError
from ballscrew_twin.health.bench_data import START_NS, generate
from ballscrew_twin.health.bench_scene import bench_scene_from_mapping
from ballscrew_twin.units import SCREW_FRAME_ID

STORE = get_typestore(Stores.ROS2_JAZZY)
T = STORE.types
T0 = 1_800_000_000 * 10**9  # ns, start of the hand-made bags
WRENCH = "geometry_msgs/msg/WrenchStamped"
JOINT = "sensor_msgs/msg/JointState"
TEMPERATURE = "sensor_msgs/msg/Temperature"
FLOAT = "std_msgs/msg/Float64"

Entry = tuple[str, str, int, Any]  # topic, type, log time [ns], message (or raw bytes)


def _header(ns: int) -> Any:
    return T["std_msgs/msg/Header"](
        stamp=T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9),
        frame_id="screw",
    )


def _wrench(ns: int, torque: float = 0.0, force: float = 0.0) -> Any:
    v = T["geometry_msgs/msg/Vector3"]
    return T[WRENCH](
        header=_header(ns),
        wrench=T["geometry_msgs/msg/Wrench"](
            force=v(x=0.0, y=0.0, z=force), torque=v(x=0.0, y=0.0, z=torque)
        ),
    )


def _joint(ns: int, speed: float, angle: float, extra: int = 0, name: str = "screw") -> Any:
    names = [name] + [f"j{k}" for k in range(extra)]
    return T[JOINT](
        header=_header(ns),
        name=names,
        position=np.full(len(names), angle),
        velocity=np.full(len(names), speed),
        effort=np.zeros(0),
    )


def _write(
    folder: Path, entries: Sequence[Entry], storage: str = "mcap", compress: bool = False
) -> Path:
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    writer = Writer(folder, version=9, storage_plugin=plugin)
    if compress:
        writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    with writer:
        conns: dict[str, Any] = {}
        for topic, msgtype, ns, msg in entries:
            if topic not in conns:
                conns[topic] = writer.add_connection(topic, msgtype, typestore=STORE)
            raw = msg if isinstance(msg, bytes) else STORE.serialize_cdr(msg, msgtype)
            writer.write(conns[topic], ns, raw)
    return folder


def _basic(n: int = 50, dt: int = 10_000_000) -> list[Entry]:
    """Torque and joint states at 100 Hz, temperature and preload at 10 Hz (known values)."""
    out: list[Entry] = []
    for k in range(n):
        ns = T0 + k * dt
        out.append(("/bench/torque", WRENCH, ns, _wrench(ns, torque=0.01 + 1e-5 * k)))
        out.append(("/bench/joint_states", JOINT, ns, _joint(ns, 10.0 + 0.01 * k, 0.1 * k)))
        if k % 10 == 0:
            temp = T[TEMPERATURE](header=_header(ns), temperature=20.0 + 0.1 * k, variance=0.0025)
            out.append(("/bench/temperature", TEMPERATURE, ns, temp))
            out.append(("/bench/preload", WRENCH, ns, _wrench(ns, force=1500.0 + k)))
    return out


# ---------------------------------------------------------------------------------------------
# Round trip with the generator's writer


@pytest.fixture(scope="module")
def small_data() -> Any:
    scene = bench_scene_from_mapping(
        {
            "name": "tiny",
            "duration": 1.0,
            "model_step": 0.5,
            "profile": [{"time": 0.0, "speed": 10.0, "temperature": 300.0, "preload": 1000.0}],
            "sensors": {"torque": {"rate": 100.0}, "speed": {"rate": 50.0}},
        },
        "tiny.yaml",
    )
    return generate(scene, seed=3)


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_generated_bag_reads_back_in_si_units(
    small_data: Any, tmp_path: Path, storage: str
) -> None:
    bag = write_bench_bag(small_data, tmp_path / "bag", START_NS, storage=storage)
    rec = read_bench_bag(bag)
    assert rec.storage == storage
    assert rec.issues == ()
    np.testing.assert_array_equal(rec.series("torque").value, small_data.torque)
    np.testing.assert_allclose(rec.series("torque").time, small_data.torque_time, atol=1e-9)
    np.testing.assert_array_equal(rec.series("speed").value, small_data.speed)
    np.testing.assert_array_equal(rec.series("angle").value, small_data.angle)
    # deg C in the bag, K out of the reader
    np.testing.assert_allclose(rec.series("temperature").value, small_data.temperature, atol=1e-9)
    variance = rec.series("temperature").variance
    assert variance is not None
    np.testing.assert_allclose(variance, small_data.temperature_variance)
    np.testing.assert_array_equal(rec.series("preload").value, small_data.preload)
    assert rec.truth == small_data.truth
    assert json.loads(truth_path(bag).read_text()) == small_data.truth


def test_truth_comes_from_bag_metadata_without_side_file(small_data: Any, tmp_path: Path) -> None:
    bag = write_bench_bag(small_data, tmp_path / "bag", START_NS)
    truth_path(bag).unlink()
    rec = read_bench_bag(bag)
    assert rec.truth == small_data.truth
    raw = open_raw_bag(bag)
    assert json.loads(raw.custom_data[TRUTH_KEY]) == small_data.truth
    raw.close()


def test_samples_are_merged_in_time_order(tmp_path: Path) -> None:
    rec = read_bench_bag(_write(tmp_path / "b", _basic()))
    samples = list(rec.samples())
    assert len(samples) == sum(len(s) for s in rec.channels.values())
    times = [s.time for s in samples]
    assert times == sorted(times)
    assert {s.channel for s in samples} == {"torque", "speed", "angle", "temperature", "preload"}


def test_values_and_times_of_a_hand_made_bag(tmp_path: Path) -> None:
    rec = read_bench_bag(_write(tmp_path / "b", _basic()))
    torque = rec.series("torque")
    np.testing.assert_allclose(torque.time, 0.01 * np.arange(50), atol=1e-12)
    np.testing.assert_allclose(torque.value, 0.01 + 1e-5 * np.arange(50))
    np.testing.assert_allclose(rec.series("temperature").value, 293.15 + np.arange(0, 50, 10) * 0.1)
    np.testing.assert_allclose(rec.series("preload").value, 1500.0 + np.arange(0, 50, 10))
    assert rec.start_ns == T0
    assert rec.duration == pytest.approx(0.49)


# ---------------------------------------------------------------------------------------------
# Types and topics


def test_wrong_type_on_a_required_topic_is_an_error_naming_topic_and_types(
    tmp_path: Path,
) -> None:
    entries = [e for e in _basic() if e[0] != "/bench/torque"]
    entries += [("/bench/torque", "std_msgs/msg/String", T0, T["std_msgs/msg/String"](data="x"))]
    with pytest.raises(BagError) as err:
        read_bench_bag(_write(tmp_path / "b", entries))
    text = str(err.value)
    assert "/bench/torque" in text and "std_msgs/msg/String" in text
    assert "geometry_msgs/msg/WrenchStamped" in text


def test_wrong_type_on_an_optional_topic_is_skipped_and_reported(tmp_path: Path) -> None:
    entries = [e for e in _basic() if e[0] != "/bench/temperature"]
    entries += [("/bench/temperature", FLOAT, T0, T[FLOAT](data=20.0))]
    rec = read_bench_bag(_write(tmp_path / "b", entries))
    assert "temperature" not in rec.channels
    assert len(rec.series("torque")) == 50
    assert any("/bench/temperature" in i and FLOAT in i for i in rec.issues)


def test_missing_topics(tmp_path: Path) -> None:
    no_speed = [e for e in _basic() if e[0] != "/bench/joint_states"]
    with pytest.raises(BagError, match=r"topic /bench/joint_states \(speed\) is missing"):
        read_bench_bag(_write(tmp_path / "a", no_speed))
    no_preload = [e for e in _basic() if e[0] != "/bench/preload"]
    rec = read_bench_bag(_write(tmp_path / "b", no_preload))
    assert any("/bench/preload (preload) is missing" in i for i in rec.issues)
    with pytest.raises(BagError, match=r"no readable 'preload' channel"):
        rec.series("preload")


def test_float64_topics_and_other_topic_names(tmp_path: Path) -> None:
    entries: list[Entry] = []
    for k in range(10):
        ns = T0 + k * 20_000_000
        entries.append(("/t", FLOAT, ns, T[FLOAT](data=0.02)))
        entries.append(("/w", FLOAT, ns, T[FLOAT](data=-5.0)))
    topics = BenchTopics(torque="/t", speed="/w")
    rec = read_bench_bag(_write(tmp_path / "b", entries), topics=topics)
    np.testing.assert_allclose(rec.series("torque").time, 0.02 * np.arange(10), atol=1e-12)
    np.testing.assert_array_equal(rec.series("speed").value, -5.0)
    assert "angle" not in rec.channels


def test_joint_is_found_by_name_among_several(tmp_path: Path) -> None:
    entries = [e for e in _basic(5) if e[0] != "/bench/joint_states"]
    msg = T[JOINT](
        header=_header(T0),
        name=["motor", "screw"],
        position=np.array([9.0, 1.5]),
        velocity=np.array([99.0, 3.0]),
        effort=np.zeros(0),
    )
    entries.append(("/bench/joint_states", JOINT, T0, msg))
    rec = read_bench_bag(_write(tmp_path / "b", entries))
    assert rec.series("speed").value.tolist() == [3.0]
    assert rec.series("angle").value.tolist() == [1.5]


# ---------------------------------------------------------------------------------------------
# Damaged content


def test_undecodable_and_non_finite_messages_are_skipped_and_counted(tmp_path: Path) -> None:
    entries = _basic(20)
    entries.append(("/bench/torque", WRENCH, T0 + 5, b"\x00\x01\x00\x00garbage"))
    entries.append(("/bench/torque", WRENCH, T0 + 6, _wrench(T0 + 6, torque=math.nan)))
    rec = read_bench_bag(_write(tmp_path / "b", entries))
    assert len(rec.series("torque")) == 20
    assert np.all(np.isfinite(rec.series("torque").value))
    assert any("1 message(s) on /bench/torque could not be decoded" in i for i in rec.issues)
    assert any("1 non-finite value(s) on /bench/torque" in i for i in rec.issues)


def test_backward_header_stamps_are_sorted_and_reported(tmp_path: Path) -> None:
    entries = [e for e in _basic(10) if e[0] != "/bench/torque"]
    stamps = [T0 + k * 10_000_000 for k in (0, 1, 2, 5, 3, 4, 6)]
    for k, ns in enumerate(stamps):
        log = T0 + k * 10_000_000
        entries.append(("/bench/torque", WRENCH, log, _wrench(ns, torque=float(ns - T0))))
    rec = read_bench_bag(_write(tmp_path / "b", entries))
    torque = rec.series("torque")
    assert np.all(np.diff(torque.time) > 0)
    np.testing.assert_allclose(torque.value * 1e-9, torque.time, atol=1e-12)
    assert any("1 backward step(s)" in i for i in rec.issues)


def _mcap_file(folder: Path) -> Path:
    return next(folder.glob("*.mcap"))


def _chunk_offsets(data: bytes) -> list[tuple[int, int]]:
    """(start, length) of the top-level chunk records of an mcap file (independent parser)."""
    pos, out = 8, []
    while pos + 9 <= len(data):
        op = data[pos]
        (length,) = struct.unpack("<Q", data[pos + 1 : pos + 9])
        if op == 0x06:
            out.append((pos, 9 + length))
        if op == 0x02:  # footer
            break
        pos += 9 + length
    return out


def _big_entries(count: int = 150) -> list[Entry]:
    """Torque k and ~25 kB joint states at 100 Hz: about 40 pairs per 1 MB chunk."""
    entries: list[Entry] = []
    for k in range(count):
        ns = T0 + k * 10_000_000
        entries.append(("/bench/torque", WRENCH, ns, _wrench(ns, torque=float(k))))
        entries.append(("/bench/joint_states", JOINT, ns, _joint(ns, float(k), 0.0, extra=999)))
    return entries


@pytest.mark.parametrize("compress", [False, True])
def test_truncated_mcap_keeps_every_complete_message(tmp_path: Path, compress: bool) -> None:
    bag = _write(tmp_path / "b", _big_entries(), compress=compress)
    file = _mcap_file(bag)
    data = file.read_bytes()
    start, length = _chunk_offsets(data)[1]
    recovered = []
    for end in (start, start + length // 2):  # cut before, then inside the second chunk
        file.write_bytes(data[:end])
        rec = read_bench_bag(bag)
        torque = rec.series("torque").value
        # what was recovered is exactly the beginning of the recording
        np.testing.assert_array_equal(torque, np.arange(len(torque), dtype=float))
        assert any("index unreadable" in i for i in rec.issues)
        recovered.append(len(torque))
    assert any("truncated" in i for i in rec.issues)
    assert 0 < recovered[0] <= recovered[1] < 150
    if not compress:  # uncompressed: the complete records of the cut chunk are kept too
        assert recovered[1] > recovered[0]


@pytest.mark.parametrize("compress", [False, True])
def test_corrupt_chunk_is_skipped_and_the_other_chunks_are_used(
    tmp_path: Path, compress: bool
) -> None:
    bag = _write(tmp_path / "b", _big_entries(), compress=compress)
    file = _mcap_file(bag)
    data = bytearray(file.read_bytes())
    chunks = _chunk_offsets(bytes(data))
    assert len(chunks) >= 3
    start, length = chunks[1]
    middle, size = start + length // 2, length // 8  # damage inside the second chunk only
    data[middle : middle + size] = b"\xa5" * size
    file.write_bytes(bytes(data))
    rec = read_bench_bag(bag)
    torque = rec.series("torque").value
    assert 0 < len(torque) < 150
    # every torque sample kept is one that was written, and the first and last chunks survive
    assert set(torque.tolist()) <= set(map(float, range(150)))
    assert torque[0] == 0.0 and torque[-1] == 149.0
    assert any("unreadable" in i for i in rec.issues)


def test_corrupt_sqlite_pages_are_skipped(tmp_path: Path) -> None:
    entries: list[Entry] = []
    for k in range(3000):
        ns = T0 + k * 10_000_000
        entries.append(("/bench/torque", WRENCH, ns, _wrench(ns, torque=float(k))))
        entries.append(("/bench/joint_states", JOINT, ns, _joint(ns, 1.0, 0.0)))
    bag = _write(tmp_path / "b", entries, storage="sqlite3")
    file = next(bag.glob("*.db3"))
    data = bytearray(file.read_bytes())
    page = 4096
    middle = (len(data) // 2 // page) * page
    data[middle : middle + 2 * page] = b"\xa5" * (2 * page)  # two pages of the messages table
    file.write_bytes(bytes(data))
    rec = read_bench_bag(bag)
    torque = rec.series("torque").value
    # only rows of the damaged pages are lost (a 4 kB page holds a few dozen of these rows)
    assert 3000 - 200 < len(torque) < 3000
    assert len(set(torque.tolist())) == len(torque)
    assert set(torque.tolist()) <= set(map(float, range(3000)))
    assert any("message row(s) on damaged pages skipped" in i for i in rec.issues)


def test_bag_without_metadata_or_as_bare_file(tmp_path: Path) -> None:
    bag = _write(tmp_path / "b", _basic())
    bare = tmp_path / "copy.mcap"
    shutil.copy(_mcap_file(bag), bare)
    assert len(read_bench_bag(bare).series("torque")) == 50
    (bag / "metadata.yaml").unlink()
    rec = read_bench_bag(bag)
    assert len(rec.series("torque")) == 50
    assert any("metadata.yaml missing" in i for i in rec.issues)


def test_not_a_bag(tmp_path: Path) -> None:
    with pytest.raises(BagError, match="does not exist"):
        read_bench_bag(tmp_path / "nothing")
    (tmp_path / "empty").mkdir()
    with pytest.raises(BagError, match="not a bag"):
        read_bench_bag(tmp_path / "empty")
    (tmp_path / "x.txt").write_text("hello")
    with pytest.raises(BagError, match="not a bag folder nor"):
        read_bench_bag(tmp_path / "x.txt")
    (tmp_path / "bad.mcap").write_bytes(b"this is not mcap at all")
    with pytest.raises(BagError, match=r"bad\.mcap"):
        read_bench_bag(tmp_path / "bad.mcap")


def test_raw_messages_in_log_time_order_and_unknown_topic(tmp_path: Path) -> None:
    with open_raw_bag(_write(tmp_path / "b", _basic(30))) as raw:
        times = [m.log_time for m in raw.messages()]
        assert times == sorted(times)
        assert raw.topics["/bench/torque"].count == 30
        with pytest.raises(BagError, match=r"no topic\(s\) \['/nope'\]"):
            list(raw.messages(["/nope"]))


# ---------------------------------------------------------------------------------------------
# Bad input of issue 13: metadata not UTF-8, a record lost inside a chunk, a joint not in the bag


def _break_metadata(bag: Path) -> None:
    meta = bag / "metadata.yaml"
    meta.write_bytes(meta.read_bytes().replace(b"rosbag2_bagfile_information", b"ros\xe9bag", 1))


def test_metadata_not_utf8_is_noted_and_the_storage_file_read(tmp_path: Path) -> None:
    bag = _write(tmp_path / "b", _basic())
    _break_metadata(bag)
    rec = read_bench_bag(bag)
    assert len(rec.series("torque")) == 50
    (note,) = [i for i in rec.issues if "metadata.yaml" in i]
    assert "not UTF-8 (byte 0xe9 at offset" in note and _mcap_file(bag).name in note
    shutil.copy(_mcap_file(bag), bag / "second.mcap")  # nothing single to read instead
    with pytest.raises(BagError, match=r"metadata\.yaml: not UTF-8 .* not exactly one"):
        read_bench_bag(bag)


def _message_records(chunk: bytes) -> list[int]:
    """Offsets in an uncompressed chunk record (from its op byte) of its message records."""
    (compression_len,) = struct.unpack("<I", chunk[9 + 28 : 9 + 32])
    assert compression_len == 0  # uncompressed
    pos = 9 + 32 + 8  # records start after their byte length
    out = []
    while pos + 9 <= len(chunk):
        op = chunk[pos]
        (length,) = struct.unpack("<Q", chunk[pos + 1 : pos + 9])
        if op == 0x05:
            out.append(pos)
        pos += 9 + length
    return out


def test_a_message_record_lost_inside_a_chunk_is_counted(tmp_path: Path) -> None:
    bag = _write(tmp_path / "b", _big_entries())
    file = _mcap_file(bag)
    data = bytearray(file.read_bytes())
    chunks = _chunk_offsets(bytes(data))
    start, length = chunks[1]
    records = _message_records(bytes(data[start : start + length]))
    for record in records[:3]:  # three records of the second chunk now name no channel
        data[start + record + 9 : start + record + 11] = b"\xff\xff"
    file.write_bytes(bytes(data))
    rec = read_bench_bag(bag)
    read = len(rec.series("torque")) + len(rec.series("speed"))
    assert read == 300 - 3  # the reader drops them silently...
    (note,) = [i for i in rec.issues if "indexed message(s) lost" in i]  # ...the index does not
    assert f"chunk 2 of {len(chunks)}" in note
    assert f"3 of its {len(records)} indexed message(s) lost" in note


@pytest.mark.parametrize("compress", [False, True])
def test_messages_of_a_corrupt_chunk_are_counted(tmp_path: Path, compress: bool) -> None:
    bag = _write(tmp_path / "b", _big_entries(), compress=compress)
    file = _mcap_file(bag)
    data = bytearray(file.read_bytes())
    start, length = _chunk_offsets(bytes(data))[1]
    middle, size = start + length // 2, length // 8
    data[middle : middle + size] = b"\xa5" * size
    file.write_bytes(bytes(data))
    with open_raw_bag(bag) as raw:
        read = sum(1 for _ in raw.messages())
        lost = [i for i in raw.issues if "indexed message(s) lost" in i]
    assert lost and all("chunk 2 of" in i for i in lost)
    counted = sum(int(i.split("): ")[1].split(" of ")[0]) for i in lost)
    assert counted == 300 - read > 0


def test_intact_bags_report_no_loss(small_data: Any, tmp_path: Path) -> None:
    for storage in ("mcap", "sqlite3"):
        bag = write_bench_bag(small_data, tmp_path / storage, START_NS, storage=storage)
        with open_raw_bag(bag) as raw:
            messages = list(raw.messages())
            assert len(messages) == sum(t.count for t in raw.topics.values())
            assert raw.issues == []
        # every header names the screw's frame (the one definition in units.py)
        frames = {STORE.deserialize_cdr(m.data, m.msgtype).header.frame_id for m in messages}
        assert frames == {SCREW_FRAME_ID}


def test_a_joint_not_in_the_bag_is_an_error_naming_the_joints_found(tmp_path: Path) -> None:
    bag = _write(tmp_path / "b", _basic())
    with pytest.raises(
        BagError, match=r"joint 'motor' is not in /bench/joint_states; .*\['screw'\]"
    ):
        read_bench_bag(bag, topics=BenchTopics(joint_name="motor"))
    rec = read_bench_bag(bag, topics=BenchTopics(joint_name="motor"), required=("torque",))
    assert "speed" not in rec.channels and "angle" not in rec.channels
    assert any("joint 'motor' is not in" in i for i in rec.issues)


def test_an_unnamed_joint_is_the_screw(tmp_path: Path) -> None:
    entries = [e for e in _basic(5) if e[0] != "/bench/joint_states"]
    msg = T[JOINT](
        header=_header(T0),
        name=[],
        position=np.array([1.5]),
        velocity=np.array([3.0]),
        effort=np.zeros(0),
    )
    entries.append(("/bench/joint_states", JOINT, T0, msg))
    rec = read_bench_bag(_write(tmp_path / "b", entries))
    assert rec.series("speed").value.tolist() == [3.0]
