"""Salvage of damaged rosbag2 storage files: what can still be read, and what was lost.

- :func:`salvage_sqlite`: every readable message of an sqlite3 file whose pages are damaged
  (ranges of row ids bisected down to the damaged rows);
- :func:`salvage_mcap`: every complete message of an mcap file scanned record by record (a file
  whose end is missing, or whose index or a chunk is broken), including the readable part of a
  cut compressed chunk;
- :func:`mcap_index` and :func:`chunk_losses`: what an mcap file's chunk index announces, to
  report per chunk the messages that could not be read.

Every issue found is appended to the caller's ``issues`` list; nothing here needs ``rosbags``.
"""

from __future__ import annotations

import sqlite3
import struct
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import BagError
from .records import RawMessage, TopicInfo


def salvage_sqlite(file: Path, issues: list[str]) -> tuple[dict[str, TopicInfo], list[RawMessage]]:
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
# A damaged mcap file: scan records sequentially, keep every complete message.

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


def salvage_mcap(file: Path, issues: list[str]) -> tuple[dict[str, TopicInfo], list[RawMessage]]:
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
class IndexedChunk:
    """A chunk record of an mcap file and the messages its message-index records list.

    Attributes:
        start_ns, end_ns: log times of its first and last message [ns].
        entries: (channel id, log time [ns]) of every message listed for the chunk.
    """

    start_ns: int
    end_ns: int
    entries: list[tuple[int, int]] = field(default_factory=list)


def mcap_index(file: Path) -> tuple[dict[int, str], list[IndexedChunk]]:
    """Channel id -> topic and the chunks of an mcap file with their message-index entries.

    Only the top-level record headers, channel and message-index records are read (no chunk
    is decompressed). A damaged or cut file gives what was read before the damage.
    """
    channels: dict[int, str] = {}
    chunks: list[IndexedChunk] = []
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
                    chunks.append(IndexedChunk(start, end))
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


def chunk_losses(
    file: Path,
    start_ns: int,
    channels: dict[int, str],
    chunks: list[IndexedChunk],
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
