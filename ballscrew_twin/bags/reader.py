"""Reading a rosbag2 bag (mcap or sqlite3) as raw messages in time order, surviving damage.

:func:`open_raw_bag` gives the bag's topics and its serialized messages in log-time order (what
``replay`` publishes and what :mod:`.bench` decodes). A bag folder without a readable
``metadata.yaml`` is read from its storage file; a storage file whose index cannot be opened is
salvaged (:mod:`.salvage`); a time range that cannot be read (corrupt chunk, malformed sqlite
page) is isolated by bisection in time and skipped. Everything skipped or repaired is listed in
:attr:`RawBag.issues`.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from ..errors import BagError
from .records import RawMessage, TopicInfo
from .salvage import chunk_losses, mcap_index, salvage_mcap, salvage_sqlite

#: Narrowest time range [ns] bisection isolates before it gives a range up as unreadable.
MIN_BISECT_WINDOW_NS = 1_000_000
#: Time range [ns] read at a time from an indexed bag.
READ_WINDOW_NS = 5_000_000_000


class _UnreadableError(Exception):
    """A time range of an indexed bag could not be read (message says which)."""


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
            channels, chunks = mcap_index(self._mcap_file)
            if any(chunk.entries for chunk in chunks):
                return chunk_losses(self._mcap_file, self.start_ns, channels, chunks, wanted, read)
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
                _, self._salvaged = salvage_mcap(self._mcap_file, self.issues)
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
            topics, messages = salvage_mcap(mcap_file, issues)
        else:
            topics, messages = salvage_sqlite(damaged, issues)
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
