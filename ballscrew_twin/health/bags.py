"""Robust reading of recorded bench bags (rosbag2, mcap or sqlite3) into time-ordered SI series.

Two layers:

- :func:`open_raw_bag` gives the bag's topics and its serialized messages in time order
  (what ``replay`` publishes). It survives damage: a bag folder without ``metadata.yaml`` is
  read from its storage file; an mcap file whose end is missing (recording killed, disk full,
  copy cut short) or whose index is broken is scanned record by record and every complete
  message is kept, including the readable part of a cut compressed chunk; a range of the file
  that cannot be read (corrupt chunk, malformed sqlite page) is isolated by bisection in time
  and skipped. Everything skipped or repaired is listed in ``issues``.
- :func:`read_bench_bag` decodes the bench topics (schema below) into :class:`Series` in SI
  units: torque [N m], screw speed [rad/s], screw angle [rad], temperature [K] (the bag holds
  degrees Celsius, ``sensor_msgs/Temperature``'s own convention, converted here at the edge),
  preload [N]. A required topic that is missing, of the wrong message type or with nothing
  readable is a :class:`BagError` naming the topic and what is wrong; an optional one is
  skipped and listed in ``issues``; undecodable or non-finite messages are skipped and counted.

Bench bag schema (``BenchTopics`` defaults):

- ``/bench/torque`` ``geometry_msgs/msg/WrenchStamped``: ``wrench.torque.z`` drive torque on the
  screw [N m], with the sign of the speed (or ``std_msgs/msg/Float64``);
- ``/bench/joint_states`` ``sensor_msgs/msg/JointState``: joint ``screw``, position [rad],
  velocity [rad/s] (or ``std_msgs/msg/Float64`` speed [rad/s]);
- ``/bench/temperature`` ``sensor_msgs/msg/Temperature``: temperature [deg C], variance;
- ``/bench/preload`` ``geometry_msgs/msg/WrenchStamped``: ``wrench.force.z`` load-cell preload
  [N] (or ``std_msgs/msg/Float64``).

Sample times are header stamps (log time for ``Float64``, which has no header), in seconds
since the earliest sample of the recording. The ground truth of a generated bag is in the side file
``<bag>.truth.json`` (:func:`truth_path`) and in ``metadata.yaml`` ``custom_data``.
"""

from __future__ import annotations

import heapq
import json
import math
import sqlite3
import struct
from collections import Counter
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import NDArray

from ..errors import BagError
from ..units import CELSIUS_ZERO, stamp_to_ns

FloatArray = NDArray[np.float64]

#: Key of the ground truth (a JSON string) in the bag's ``metadata.yaml`` ``custom_data``.
TRUTH_KEY = "ballscrew_twin.truth"
#: Suffix of the ground-truth side file next to the bag folder.
TRUTH_SUFFIX = ".truth.json"
#: Narrowest time range [ns] bisection isolates before it gives a range up as unreadable.
MIN_BISECT_WINDOW_NS = 1_000_000
#: Time range [ns] read at a time from an indexed bag.
READ_WINDOW_NS = 5_000_000_000
#: Header stamps further than this from the bag time [ns] are reported (they are still used).
STAMP_TOLERANCE_NS = 1_000_000_000

#: Bench channels and the message types accepted for each.
ACCEPTED_TYPES: dict[str, tuple[str, ...]] = {
    "torque": ("geometry_msgs/msg/WrenchStamped", "std_msgs/msg/Float64"),
    "speed": ("sensor_msgs/msg/JointState", "std_msgs/msg/Float64"),
    "temperature": ("sensor_msgs/msg/Temperature",),
    "preload": ("geometry_msgs/msg/WrenchStamped", "std_msgs/msg/Float64"),
}
#: Channels of a :class:`BenchRecording` (``angle`` comes with ``speed`` from a JointState).
CHANNELS = ("torque", "speed", "angle", "temperature", "preload")
#: Unit of each channel's values.
UNITS = {"torque": "N m", "speed": "rad/s", "angle": "rad", "temperature": "K", "preload": "N"}


class _UnreadableError(Exception):
    """A time range of an indexed bag could not be read (message says which)."""


# ---------------------------------------------------------------------------------------------
# Raw layer


@dataclass(frozen=True)
class TopicInfo:
    """One topic of a bag.

    Attributes:
        topic: topic name.
        msgtype: message type, ``pkg/msg/Name``.
        msgdef: message definition text stored in the bag (may be empty).
        count: messages the bag's index announces (-1 when unknown, e.g. a salvaged file).
    """

    topic: str
    msgtype: str
    msgdef: str
    count: int


@dataclass(frozen=True)
class RawMessage:
    """A serialized message: topic, type, bag (log) time [ns] and CDR bytes."""

    topic: str
    msgtype: str
    log_time: int
    data: bytes


@dataclass
class RawBag:
    """A bag opened for reading raw messages; see :func:`open_raw_bag`.

    Attributes:
        path: the path given.
        storage: ``"mcap"`` or ``"sqlite3"``.
        topics: topic name -> :class:`TopicInfo`.
        start_ns: log time of the first message [ns] (0 for an empty bag).
        end_ns: log time of the last message [ns].
        custom_data: ``metadata.yaml`` ``custom_data`` (empty when absent).
        issues: what was skipped or repaired, in reading order; grows while messages are read.
    """

    path: Path
    storage: str
    topics: dict[str, TopicInfo]
    start_ns: int
    end_ns: int
    custom_data: dict[str, str]
    issues: list[str] = field(default_factory=list)
    _reader: Any = None
    _salvaged: list[RawMessage] | None = None
    _mcap_file: Path | None = None
    _accounted: bool = False

    def messages(self, topics: Sequence[str] | None = None) -> Iterator[RawMessage]:
        """Messages of ``topics`` (all when None) in log-time order.

        Unreadable time ranges are skipped and recorded in :attr:`issues`; after the first
        complete pass, so are the messages the bag announces but that could not be read (per
        chunk of an mcap file, from its message index; else per topic, from its counts).
        """
        wanted = set(self.topics if topics is None else topics)
        unknown = sorted(wanted - set(self.topics))
        if unknown:
            raise BagError(f"{self.path}: no topic(s) {unknown}; the bag has {sorted(self.topics)}")
        read: Counter[tuple[str, int]] = Counter()
        for m in self._read(wanted):
            read[m.topic, m.log_time] += 1
            yield m
        if not self._accounted:
            self._accounted = True
            self.issues.extend(self._losses(wanted, read))

    def _losses(self, wanted: set[str], read: Counter[tuple[str, int]]) -> list[str]:
        """What the bag announces on ``wanted`` but was not ``read`` ((topic, log time) counts)."""
        if self._mcap_file is not None:
            channels, chunks = _mcap_index(self._mcap_file)
            if any(chunk.entries for chunk in chunks):
                return _chunk_losses(self._mcap_file, self.start_ns, channels, chunks, wanted, read)
        per_topic = Counter(topic for topic, _ in read.elements())
        return [
            f"{self.path}: {info.count - per_topic[topic]} of {info.count} message(s) on "
            f"{topic} announced by the bag could not be read"
            for topic, info in sorted(self.topics.items())
            if topic in wanted and per_topic[topic] < info.count
        ]

    def _read(self, wanted: set[str]) -> Iterator[RawMessage]:
        """Messages of the ``wanted`` topics in log-time order, salvaging what fails."""
        if self._salvaged is not None:
            yield from (m for m in self._salvaged if m.topic in wanted)
            return
        connections = [c for c in self._reader.connections if c.topic in wanted]
        start = self.start_ns
        while connections and start <= self.end_ns:
            stop = min(start + READ_WINDOW_NS, self.end_ns + 1)
            try:
                window = self._window(connections, start, stop)
            except _UnreadableError as err:
                if self._mcap_file is None:
                    raise BagError(str(err)) from err
                self.issues.append(f"{err}; the mcap file is scanned record by record instead")
                _, self._salvaged = _salvage_scan(self._mcap_file, self.issues)
                yield from (m for m in self._salvaged if m.topic in wanted and m.log_time >= start)
                return
            yield from window
            start = stop

    def _window(self, connections: list[Any], start: int, stop: int) -> list[RawMessage]:
        """Messages with log time in [start, stop).

        An sqlite3 range that fails is bisected down to :data:`MIN_BISECT_WINDOW_NS` and the
        unreadable part skipped; an mcap failure (a whole chunk is lost at once) raises
        :class:`_UnreadableError`, and the caller scans the file instead.
        """
        try:
            return [
                RawMessage(c.topic, c.msgtype, t, bytes(raw))
                for c, t, raw in self._reader.messages(connections, start=start, stop=stop)
            ]
        except Exception as err:  # any storage failure: isolate and report
            where = (
                f"{self.path}: messages between {(start - self.start_ns) * 1e-9:.3f} s and "
                f"{(stop - self.start_ns) * 1e-9:.3f} s unreadable ({type(err).__name__}: {err})"
            )
            if self.storage == "mcap":
                raise _UnreadableError(where) from err
            if stop - start <= MIN_BISECT_WINDOW_NS:
                self.issues.append(f"{where}; skipped")
                return []
            middle = (start + stop) // 2
            return self._window(connections, start, middle) + self._window(
                connections, middle, stop
            )

    def close(self) -> None:
        """Close the storage."""
        if self._reader is not None:
            self._reader.close()
            self._reader = None

    def __enter__(self) -> RawBag:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _storage_file(folder: Path) -> Path | None:
    """The single ``*.mcap`` or ``*.db3`` file of a bag folder (None: none or several)."""
    files = sorted(folder.glob("*.mcap")) + sorted(folder.glob("*.db3"))
    return files[0] if len(files) == 1 else None


def _metadata_problem(meta: Path) -> str | None:
    """Why ``metadata.yaml`` cannot be read as text (None when it can): not UTF-8, unreadable."""
    try:
        meta.read_bytes().decode("utf-8")
    except UnicodeDecodeError as err:
        return f"not UTF-8 (byte 0x{err.object[err.start]:02x} at offset {err.start})"
    except OSError as err:
        return f"unreadable ({err.strerror})"
    return None


def _custom_data(folder: Path, issues: list[str]) -> dict[str, str]:
    """``custom_data`` of the bag's metadata.yaml (empty when absent or unreadable)."""
    meta = folder / "metadata.yaml"
    if not meta.is_file() or _metadata_problem(meta) is not None:
        return {}
    try:
        data = yaml.safe_load(meta.read_text(encoding="utf-8"))
        custom = data["rosbag2_bagfile_information"].get("custom_data") or {}
    except (OSError, ValueError, yaml.YAMLError, KeyError, TypeError, AttributeError) as err:
        issues.append(f"{meta}: custom_data unreadable ({err})")
        return {}
    return {str(k): str(v) for k, v in custom.items()} if isinstance(custom, dict) else {}


def open_raw_bag(path: str | Path) -> RawBag:
    """Open a rosbag2 bag (folder, or a bare ``.mcap`` / ``.db3`` file) for raw reading.

    Raises:
        BagError: the path does not exist, is not a bag, or nothing in it is readable.
    """
    from rosbags.rosbag2 import Reader

    given = Path(path)
    issues: list[str] = []
    if not given.exists():
        raise BagError(f"{given}: bag does not exist")
    target = given
    if given.is_dir():
        storage_file = _storage_file(given)
        meta = given / "metadata.yaml"
        if not meta.is_file():
            if storage_file is None:
                raise BagError(
                    f"{given}: not a bag (no metadata.yaml and not exactly one *.mcap or *.db3)"
                )
            issues.append(f"{given}: metadata.yaml missing; read {storage_file.name} directly")
            target = storage_file
        elif (problem := _metadata_problem(meta)) is not None:
            if storage_file is None:
                raise BagError(
                    f"{meta}: {problem}, and the folder has not exactly one *.mcap or *.db3 to "
                    "read instead"
                )
            issues.append(f"{meta}: {problem}; ignored, read {storage_file.name} directly")
            target = storage_file
    elif given.suffix not in (".mcap", ".db3"):
        raise BagError(f"{given}: not a bag folder nor a .mcap or .db3 file")
    custom = _custom_data(given if given.is_dir() else given.parent, issues)
    if target.is_dir() and (storage_file := _storage_file(target)) is not None:
        mcap_file: Path | None = storage_file if storage_file.suffix == ".mcap" else None
    else:
        mcap_file = target if target.suffix == ".mcap" else None
    storage = "mcap" if mcap_file is not None else "sqlite3"
    try:
        reader = Reader(target)
        reader.open()
    except Exception as err:  # rosbags raises many kinds; salvage or report
        damaged = mcap_file or _db3_file(target)
        if damaged is None:
            raise BagError(f"{given}: cannot open bag ({type(err).__name__}: {err})") from err
        issues.append(f"{damaged}: index unreadable ({err}); read record by record instead")
        if mcap_file is not None:
            topics, messages = _salvage_scan(mcap_file, issues)
        else:
            topics, messages = _salvage_sqlite(damaged, issues)
        start, end = messages[0].log_time, messages[-1].log_time
        return RawBag(given, storage, topics, start, end, custom, issues, None, messages, mcap_file)
    topics = {
        c.topic: TopicInfo(c.topic, c.msgtype, c.msgdef.data, c.msgcount)
        for c in reader.connections
    }
    start = reader.start_time if reader.message_count else 0
    end = reader.end_time - 1 if reader.message_count else -1
    return RawBag(given, storage, topics, start, end, custom, issues, reader, None, mcap_file)


def _db3_file(target: Path) -> Path | None:
    """The sqlite3 storage file of ``target`` (a bag folder or a .db3 file), if any."""
    if target.is_dir():
        found = _storage_file(target)
        return found if found is not None and found.suffix == ".db3" else None
    return target if target.suffix == ".db3" else None


def _salvage_sqlite(file: Path, issues: list[str]) -> tuple[dict[str, TopicInfo], list[RawMessage]]:
    """Topics and every readable message of a damaged rosbag2 sqlite3 file (log-time order).

    Messages are read by ranges of their row id; a range that fails is bisected down to single
    rows, so only the rows on damaged pages are lost.

    Raises:
        BagError: the file cannot be opened, its topics table is unreadable, or no message is.
    """
    try:
        con = sqlite3.connect(f"file:{file}?mode=ro", uri=True)
    except sqlite3.Error as err:
        raise BagError(f"{file}: cannot open database ({err})") from err
    try:
        try:
            rows = con.execute("SELECT id, name, type FROM topics").fetchall()
        except sqlite3.Error as err:
            raise BagError(f"{file}: topics table unreadable ({err})") from err
        try:
            last = int(con.execute("SELECT max(id) FROM messages").fetchone()[0] or 0)
        except sqlite3.Error:
            last = 2**40  # unknown: bisection skips empty ranges quickly
        names = {int(tid): (str(name), str(msgtype)) for tid, name, msgtype in rows}
        found: list[tuple[int, int, bytes]] = []
        lost: list[tuple[int, int]] = []

        def read(lo: int, hi: int) -> None:
            try:
                rows = con.execute(
                    "SELECT topic_id, timestamp, data FROM messages WHERE id >= ? AND id < ?",
                    (lo, hi),
                ).fetchall()  # all or nothing: a failing range is retried in halves
                found.extend((int(ts), int(tid), bytes(data)) for tid, ts, data in rows)
            except sqlite3.Error:
                if hi - lo <= 1:
                    lost.append((lo, hi))
                    return
                middle = (lo + hi) // 2
                read(lo, middle)
                read(middle, hi)

        read(0, last + 1)
    finally:
        con.close()
    if lost:
        issues.append(f"{file}: {len(lost)} message row(s) on damaged pages skipped")
    orphans = sum(1 for _, tid, _ in found if tid not in names)
    if orphans:
        issues.append(f"{file}: {orphans} message(s) of an unknown topic skipped")
    messages = [
        RawMessage(names[tid][0], names[tid][1], ts, data)
        for ts, tid, data in sorted(found, key=lambda m: (m[0], m[1]))
        if tid in names
    ]
    if not messages:
        raise BagError(f"{file}: no readable message in the bag ({'; '.join(issues)})")
    counts: dict[str, int] = {}
    for m in messages:
        counts[m.topic] = counts.get(m.topic, 0) + 1
    topics = {n: TopicInfo(n, t, "", counts.get(n, 0)) for n, t in names.values()}
    return topics, messages


# ---------------------------------------------------------------------------------------------
# Salvage of a damaged mcap file: scan records sequentially, keep every complete message.

_MCAP_MAGIC = b"\x89MCAP0\r\n"
_OP_FOOTER, _OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE, _OP_CHUNK = 0x02, 0x03, 0x04, 0x05, 0x06
_OP_MESSAGE_INDEX = 0x07


class _CutError(Exception):
    """A record runs past the end of the available bytes."""


class _Buffer:
    """Little-endian reads from bytes; :class:`_CutError` at the end."""

    def __init__(self, data: bytes) -> None:
        self.data = data
        self.pos = 0

    def take(self, n: int) -> bytes:
        if n < 0 or self.pos + n > len(self.data):
            raise _CutError
        out = self.data[self.pos : self.pos + n]
        self.pos += n
        return out

    def u16(self) -> int:
        return int(struct.unpack("<H", self.take(2))[0])

    def u32(self) -> int:
        return int(struct.unpack("<I", self.take(4))[0])

    def u64(self) -> int:
        return int(struct.unpack("<Q", self.take(8))[0])

    def string(self) -> str:
        return self.take(self.u32()).decode("utf-8", errors="replace")

    @property
    def left(self) -> int:
        return len(self.data) - self.pos


def _decompress_partial(data: bytes, compression: str) -> bytes:
    """As much of a (possibly cut) compressed chunk as can be decompressed."""
    if compression == "":
        return data
    if compression == "zstd":
        from backports import zstd

        return bytes(zstd.ZstdDecompressor().decompress(data))
    if compression == "lz4":
        import lz4.frame  # type: ignore[import-untyped]

        return bytes(lz4.frame.LZ4FrameDecompressor().decompress(data))
    raise _CutError


@dataclass
class _Scan:
    """State of a salvage scan."""

    schemas: dict[int, tuple[str, str]] = field(default_factory=dict)  # id -> (name, text)
    channels: dict[int, tuple[str, int]] = field(default_factory=dict)  # id -> (topic, schema)
    messages: list[tuple[int, int, bytes]] = field(default_factory=list)  # (time, channel, data)
    cut: bool = False
    bad_chunks: int = 0


def _scan_records(buf: _Buffer, scan: _Scan, top: bool) -> None:
    """Read records until the bytes end; complete ones are stored in ``scan``."""
    while buf.left > 0:
        try:
            op = buf.take(1)[0]
            length = buf.u64()
        except _CutError:
            length = -1
        if length < 0 or length > buf.left:  # the bytes end inside this record
            if top:
                scan.cut = True
            else:
                scan.bad_chunks += 1
            if not (top and op == _OP_CHUNK and length > 0):
                return
            length = buf.left  # a cut chunk: use what there is of it
        body = _Buffer(buf.take(length))
        try:
            if op == _OP_SCHEMA:
                sid = body.u16()
                name = body.string()
                body.string()  # encoding
                scan.schemas[sid] = (name, body.take(body.u32()).decode("utf-8", "replace"))
            elif op == _OP_CHANNEL:
                cid, sid = body.u16(), body.u16()
                scan.channels[cid] = (body.string(), sid)
            elif op == _OP_MESSAGE:
                cid = body.u16()
                body.u32()  # sequence
                log_time = body.u64()
                body.u64()  # publish time
                scan.messages.append((log_time, cid, body.take(body.left)))
            elif op == _OP_CHUNK and top:
                body.take(28)  # start, end, uncompressed size, crc
                compression = body.string()
                size = body.u64()
                _scan_chunk(body.data[body.pos : body.pos + size], compression, scan)
        except _CutError:
            scan.bad_chunks += 1


def _scan_chunk(data: bytes, compression: str, scan: _Scan) -> None:
    """Records of one chunk, as far as they can be decompressed."""
    try:
        inner = _decompress_partial(data, compression)
    except Exception:  # a chunk that does not decompress at all is lost
        scan.bad_chunks += 1
        return
    _scan_records(_Buffer(inner), scan, top=False)


def _salvage_scan(file: Path, issues: list[str]) -> tuple[dict[str, TopicInfo], list[RawMessage]]:
    """Topics and every complete message (log-time order) of a damaged mcap file.

    Raises:
        BagError: unreadable file, not an mcap file, or no complete message in it.
    """
    try:
        data = file.read_bytes()
    except OSError as err:
        raise BagError(f"{file}: cannot read ({err.strerror})") from err
    if not data.startswith(_MCAP_MAGIC):
        raise BagError(f"{file}: not an mcap file (bad magic bytes)")
    scan = _Scan()
    _scan_records(_Buffer(data[len(_MCAP_MAGIC) :]), scan, top=True)
    if scan.cut:
        issues.append(f"{file}: file ends inside a record (truncated); the rest was used")
    if scan.bad_chunks:
        issues.append(
            f"{file}: {scan.bad_chunks} chunk(s) or record(s) unreadable or cut, skipped "
            "from the first damaged byte on"
        )
    topics: dict[str, TopicInfo] = {}
    messages: list[RawMessage] = []
    orphans = 0
    for cid, (topic, sid) in scan.channels.items():
        name, text = scan.schemas.get(sid, ("", ""))
        topics[topic] = TopicInfo(topic, name, text, sum(1 for m in scan.messages if m[1] == cid))
    for log_time, cid, payload in sorted(scan.messages, key=lambda m: (m[0], m[1])):
        if cid not in scan.channels:
            orphans += 1
            continue
        topic, sid = scan.channels[cid]
        messages.append(RawMessage(topic, scan.schemas.get(sid, ("", ""))[0], log_time, payload))
    if orphans:
        issues.append(f"{file}: {orphans} message(s) of an unknown channel skipped")
    if not messages:
        raise BagError(f"{file}: no readable message in the bag ({'; '.join(issues)})")
    return topics, messages


# ---------------------------------------------------------------------------------------------
# What an mcap file announces: its chunks and their message indexes, to count what was lost.


@dataclass(frozen=True)
class _IndexedChunk:
    """A chunk record of an mcap file and the messages its message-index records list.

    Attributes:
        start_ns, end_ns: log times of its first and last message [ns].
        entries: (channel id, log time [ns]) of every message listed for the chunk.
    """

    start_ns: int
    end_ns: int
    entries: list[tuple[int, int]] = field(default_factory=list)


def _mcap_index(file: Path) -> tuple[dict[int, str], list[_IndexedChunk]]:
    """Channel id -> topic and the chunks of an mcap file with their message-index entries.

    Only the top-level record headers, channel and message-index records are read (no chunk
    is decompressed). A damaged or cut file gives what was read before the damage.
    """
    channels: dict[int, str] = {}
    chunks: list[_IndexedChunk] = []
    try:
        size = file.stat().st_size
        with file.open("rb") as handle:
            pos = len(_MCAP_MAGIC)
            while pos + 9 <= size:
                handle.seek(pos)
                head = _Buffer(handle.read(9))
                op, length = head.take(1)[0], head.u64()
                if length > size - pos - 9 or op == _OP_FOOTER:
                    break
                if op == _OP_CHUNK:
                    start, end = struct.unpack("<QQ", handle.read(16))
                    chunks.append(_IndexedChunk(start, end))
                elif op == _OP_MESSAGE_INDEX and chunks:
                    body = _Buffer(handle.read(length))
                    cid = body.u16()
                    listed = struct.iter_unpack("<QQ", body.take(body.u32()))
                    chunks[-1].entries.extend((cid, log_time) for log_time, _ in listed)
                elif op == _OP_CHANNEL:
                    body = _Buffer(handle.read(length))
                    cid = body.u16()
                    body.u16()  # schema id
                    channels[cid] = body.string()
                pos += 9 + length
    except (OSError, _CutError, struct.error):
        pass  # keep what was read before the damage
    return channels, chunks


def _chunk_losses(
    file: Path,
    start_ns: int,
    channels: dict[int, str],
    chunks: list[_IndexedChunk],
    wanted: set[str],
    read: Counter[tuple[str, int]],
) -> list[str]:
    """One line per chunk with messages that its index lists on ``wanted`` topics but that were
    not ``read`` ((topic, log time) counts; consumed), and one for messages read that no index
    lists."""
    out: list[str] = []
    unread = Counter(read)
    for k, chunk in enumerate(chunks):
        listed = [(channels[c], t) for c, t in chunk.entries if channels.get(c) in wanted]
        lost: Counter[str] = Counter()
        for key in listed:
            if unread[key] > 0:
                unread[key] -= 1
            else:
                lost[key[0]] += 1
        if lost:
            span = (
                f"{(chunk.start_ns - start_ns) * 1e-9:.3f}-{(chunk.end_ns - start_ns) * 1e-9:.3f}"
            )
            per_topic = ", ".join(f"{topic} {n}" for topic, n in sorted(lost.items()))
            out.append(
                f"{file}: chunk {k + 1} of {len(chunks)} ({span} s): {lost.total()} of its "
                f"{len(listed)} indexed message(s) lost ({per_topic})"
            )
    indexed = {channels[c] for chunk in chunks for c, _ in chunk.entries if c in channels}
    extra = sum(n for (topic, _), n in unread.items() if n > 0 and topic in indexed)
    if extra:
        out.append(
            f"{file}: {extra} message(s) read at a log time no chunk index lists (damaged record "
            "headers?)"
        )
    return out


# ---------------------------------------------------------------------------------------------
# Typed layer: the bench topics in SI units


@dataclass(frozen=True)
class BenchTopics:
    """Topic names of the bench signals and the joint of the screw in a JointState."""

    torque: str = "/bench/torque"
    speed: str = "/bench/joint_states"
    temperature: str = "/bench/temperature"
    preload: str = "/bench/preload"
    joint_name: str = "screw"

    def topic_of(self, channel: str) -> str:
        """Topic carrying ``channel`` (``angle`` rides with ``speed``)."""
        return str(getattr(self, "speed" if channel == "angle" else channel))


@dataclass(frozen=True)
class Series:
    """One bench channel, time ordered, SI units.

    Attributes:
        channel: ``torque``, ``speed``, ``angle``, ``temperature`` or ``preload``.
        topic: topic it came from.
        msgtype: message type of that topic.
        time: sample times since the recording's earliest sample [s] (header stamps).
        value: values [N m, rad/s, rad, K or N: see :data:`UNITS`].
        variance: variance of each value when the message carries it (temperature) [unit^2].
    """

    channel: str
    topic: str
    msgtype: str
    time: FloatArray
    value: FloatArray
    variance: FloatArray | None = None

    @property
    def unit(self) -> str:
        """Unit of :attr:`value`."""
        return UNITS[self.channel]

    def __len__(self) -> int:
        return len(self.time)


@dataclass(frozen=True)
class Sample:
    """One measured value: time since the bag start [s], channel, value [SI, see UNITS]."""

    time: float
    channel: str
    value: float


@dataclass(frozen=True)
class BenchRecording:
    """The bench channels of a bag, SI units.

    Attributes:
        path: the bag.
        storage: ``"mcap"`` or ``"sqlite3"``.
        start_ns: header stamp of the earliest sample of any channel [ns]; the ``time`` arrays
            count from it (for a generated bag it is also the bag's first log time).
        duration: time from the earliest to the latest sample [s].
        channels: channel name -> :class:`Series` (only channels present and readable).
        truth: ground truth of a generated bag (side file, else bag metadata), or None.
        issues: what was skipped or repaired while reading.
    """

    path: Path
    storage: str
    start_ns: int
    duration: float
    channels: dict[str, Series]
    truth: dict[str, Any] | None
    issues: tuple[str, ...]

    def series(self, channel: str) -> Series:
        """The :class:`Series` of ``channel``; BagError naming what the bag has otherwise."""
        if channel not in self.channels:
            raise BagError(
                f"{self.path}: no readable {channel!r} channel; available: {sorted(self.channels)}"
            )
        return self.channels[channel]

    def samples(self) -> Iterator[Sample]:
        """Every sample of every channel, merged in time order (ties: channel order)."""
        order = {name: k for k, name in enumerate(CHANNELS)}

        def stream(s: Series) -> Iterator[tuple[float, int, float]]:
            rank = order[s.channel]
            for t, v in zip(s.time.tolist(), s.value.tolist(), strict=True):
                yield t, rank, v

        for t, rank, v in heapq.merge(*(stream(s) for s in self.channels.values())):
            yield Sample(t, CHANNELS[rank], v)


def truth_path(bag: str | Path) -> Path:
    """Ground-truth side file of a bag: ``<bag>.truth.json`` next to the bag folder."""
    path = Path(bag)
    return path.with_name(path.name + TRUTH_SUFFIX)


def read_truth(bag: str | Path) -> dict[str, Any] | None:
    """Ground truth of a generated bag from its side file, or None when there is none.

    Raises:
        BagError: the side file exists but is not valid JSON of a mapping.
    """
    file = truth_path(bag)
    if not file.is_file():
        return None
    try:
        data = json.loads(file.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as err:
        raise BagError(f"{file}: ground truth unreadable ({err})") from err
    if not isinstance(data, dict):
        raise BagError(f"{file}: ground truth must be a JSON object")
    return data


@dataclass
class _Collector:
    """Values of one channel as they are decoded."""

    topic: str
    msgtype: str
    time: list[int] = field(default_factory=list)
    value: list[float] = field(default_factory=list)
    variance: list[float] = field(default_factory=list)


def _stamp_ns(msg: Any) -> int:
    """Header stamp of a message [ns] (0 when it has none)."""
    header = getattr(msg, "header", None)
    if header is None:
        return 0
    return stamp_to_ns(header.stamp)


def _joint_index(msg: Any, joint: str) -> int | None:
    """Index of ``joint`` in a JointState (0 when the message names no joint; None when it
    names others only)."""
    names = list(msg.name)
    if joint in names:
        return names.index(joint)
    return None if names else 0


def _decode(channel: str, msg: Any, msgtype: str, joint: str) -> dict[str, float] | None:
    """SI values of one message: {channel: value, ...}; None when it lacks them."""
    if msgtype == "std_msgs/msg/Float64":
        return {channel: float(msg.data)}
    if channel == "torque":
        return {"torque": float(msg.wrench.torque.z)}
    if channel == "preload":
        return {"preload": float(msg.wrench.force.z)}
    if channel == "temperature":
        return {
            "temperature": float(msg.temperature) + CELSIUS_ZERO,
            "temperature_variance": float(msg.variance),
        }
    index = _joint_index(msg, joint)
    if index is None:
        return None
    out: dict[str, float] = {}
    if len(msg.velocity) > index:
        out["speed"] = float(msg.velocity[index])
    if len(msg.position) > index:
        out["angle"] = float(msg.position[index])
    return out or None


def _check_topics(
    raw: RawBag, topics: BenchTopics, required: Sequence[str], issues: list[str]
) -> dict[str, str]:
    """Channel -> message type of the usable bench topics; BagError for a required one."""
    usable: dict[str, str] = {}
    problems: list[str] = []
    for channel, accepted in ACCEPTED_TYPES.items():
        topic = topics.topic_of(channel)
        info = raw.topics.get(topic)
        if info is None:
            why = f"topic {topic} ({channel}) is missing"
        elif info.msgtype not in accepted:
            why = (
                f"topic {topic} ({channel}) has type {info.msgtype or '<unknown>'}, "
                f"expected {' or '.join(accepted)}"
            )
        else:
            usable[channel] = info.msgtype
            continue
        needed = channel in required or (channel == "speed" and "angle" in required)
        (problems if needed else issues).append(
            why if needed else f"{raw.path}: {why}; channel skipped"
        )
    if problems:
        raise BagError(
            f"{raw.path}: {'; '.join(problems)} (topics in the bag: "
            f"{ {t: i.msgtype for t, i in sorted(raw.topics.items())} })"
        )
    return usable


def read_bench_bag(
    path: str | Path,
    topics: BenchTopics | None = None,
    required: Sequence[str] = ("torque", "speed"),
) -> BenchRecording:
    """Read the bench channels of a bag into SI series (see the module docstring).

    Args:
        path: bag folder, or a bare ``.mcap`` / ``.db3`` file.
        topics: topic names (default: the bench schema).
        required: channels without which the bag is useless (BagError when missing).

    Raises:
        BagError: unreadable bag, or a required channel missing, wrongly typed or empty.
    """
    from rosbags.typesys import Stores, get_typestore

    topics = topics or BenchTopics()
    unknown = sorted(set(required) - set(CHANNELS))
    if unknown:
        raise BagError(f"required channel(s) {unknown} unknown; channels are {list(CHANNELS)}")
    store = get_typestore(Stores.ROS2_JAZZY)
    with open_raw_bag(path) as raw:
        issues = raw.issues
        usable = _check_topics(raw, topics, required, issues)
        by_topic = {topics.topic_of(ch): ch for ch in usable}
        collectors: dict[str, _Collector] = {}
        failures: dict[str, list[str]] = {}
        nonfinite: dict[str, int] = {}
        stamp_offset: dict[str, int] = {}
        joints: set[str] = set()  # joint names of JointStates without the screw's joint
        for m in raw.messages(sorted(by_topic)):
            channel = by_topic[m.topic]
            try:
                msg = store.deserialize_cdr(m.data, m.msgtype)
                values = _decode(channel, msg, m.msgtype, topics.joint_name)
            except Exception as err:  # a damaged payload: count and skip
                failures.setdefault(m.topic, []).append(f"{type(err).__name__}: {err}")
                continue
            if values is None:
                names = [str(n) for n in getattr(msg, "name", ())]
                joints.update(names)
                failures.setdefault(m.topic, []).append(
                    f"no joint {topics.joint_name!r} (joints: {names})"
                )
                continue
            stamp = _stamp_ns(msg) or m.log_time
            offset = abs(stamp - m.log_time)
            stamp_offset[m.topic] = max(stamp_offset.get(m.topic, 0), offset)
            for name, value in values.items():
                if name == "temperature_variance":
                    continue
                if not math.isfinite(value):
                    nonfinite[f"{m.topic} ({name})"] = nonfinite.get(f"{m.topic} ({name})", 0) + 1
                    continue
                col = collectors.setdefault(name, _Collector(m.topic, m.msgtype))
                col.time.append(stamp)
                col.value.append(value)
                if name == "temperature":
                    col.variance.append(values["temperature_variance"])
        if joints and "speed" not in collectors and "angle" not in collectors:
            why = (
                f"{raw.path}: joint {topics.joint_name!r} is not in {topics.speed}; joints "
                f"found: {sorted(joints)}"
            )
            if {"speed", "angle"} & set(required):
                raise BagError(why)
            issues.append(f"{why}; speed and angle skipped")
            failures.pop(topics.speed)
        for topic, errors in failures.items():
            issues.append(
                f"{raw.path}: {len(errors)} message(s) on {topic} could not be decoded and were "
                f"skipped (first: {errors[0]})"
            )
        for what, count in nonfinite.items():
            issues.append(f"{raw.path}: {count} non-finite value(s) on {what} skipped")
        for topic, offset in stamp_offset.items():
            if offset > STAMP_TOLERANCE_NS:
                issues.append(
                    f"{raw.path}: header stamps on {topic} differ from the bag (log) time by up "
                    f"to {offset * 1e-9:.3g} s (recorded on another clock?); header stamps used"
                )
        start_ns = min((min(c.time) for c in collectors.values() if c.time), default=0)
        channels = _series(raw, collectors, start_ns, issues)
        empty = [ch for ch in required if ch not in channels]
        if empty:
            raise BagError(
                f"{raw.path}: no readable sample of required channel(s) {empty}"
                + (f" ({'; '.join(issues)})" if issues else "")
            )
        truth = read_truth(path)
        if truth is None and TRUTH_KEY in raw.custom_data:
            try:
                truth = json.loads(raw.custom_data[TRUTH_KEY])
            except json.JSONDecodeError as err:
                issues.append(f"{raw.path}: ground truth in metadata unreadable ({err})")
        return BenchRecording(
            path=Path(path),
            storage=raw.storage,
            start_ns=start_ns,
            duration=max((int(s.time[-1] * 1e9) for s in channels.values()), default=0) * 1e-9,
            channels=channels,
            truth=truth,
            issues=tuple(issues),
        )


def _series(
    raw: RawBag, collectors: dict[str, _Collector], start_ns: int, issues: list[str]
) -> dict[str, Series]:
    """Time-sorted :class:`Series` of the collected values; out-of-order stamps reported."""
    out: dict[str, Series] = {}
    for name in CHANNELS:
        col = collectors.get(name)
        if col is None or not col.time:
            continue
        stamps = np.asarray(col.time, dtype=np.int64)
        backwards = int(np.count_nonzero(np.diff(stamps) < 0))
        if backwards:
            issues.append(
                f"{raw.path}: {backwards} backward step(s) of the header stamps on {col.topic} "
                f"({name}); samples sorted by stamp"
            )
        order = np.argsort(stamps, kind="stable")
        time = (stamps[order] - start_ns).astype(np.float64) * 1e-9
        variance = np.asarray(col.variance, dtype=np.float64)[order] if col.variance else None
        out[name] = Series(
            channel=name,
            topic=col.topic,
            msgtype=col.msgtype,
            time=time,
            value=np.asarray(col.value, dtype=np.float64)[order],
            variance=variance,
        )
    return out
