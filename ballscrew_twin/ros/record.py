"""``ballscrew-twin record --out BAG TOPIC[:TYPE] ...``: write topics into a rosbag2 bag.

``ros2 bag record`` is not available from PyPI; this subscribes to the given topics and writes
every message as received (serialized bytes, not decoded) into an mcap (default) or sqlite3 bag
with the ``rosbags`` library:

- a topic's type is given as ``TOPIC:pkg/msg/Name``, or discovered from the ROS graph (a topic
  that appears later is subscribed to as soon as it is seen; one never seen is reported);
- QoS ``--qos auto`` (default) matches the publishers: reliable when every publisher of the
  topic is reliable, best effort otherwise (a reliable subscriber receives nothing from a
  best-effort, sensor-data publisher); ``reliable`` / ``best_effort`` force it;
- the bag time of a message is its arrival time on the node's clock (``/clock`` with
  ``--ros-args -p use_sim_time:=true``, e.g. while recording a replay);
- the message definitions are stored in the bag (standard types and ``ballscrew_twin_msgs``),
  so any reader can decode it;
- an mcap bag's chunks are compressed with zstd, as the bench-data generator writes them (a
  replay of a sample bag: 803 kB uncompressed, 231 kB so; docs/benchmarks.md);
- the bag says it was recorded under ROS 2 ``jazzy`` (``ros_distro`` of its metadata, in
  ``metadata.yaml``, the mcap file's own copy and the sqlite3 schema table), where the bag
  library would write its own name.

Prints the messages written so far per topic every half second when they change. Stops
cleanly on Ctrl-C / SIGTERM or after ``--duration`` seconds; the bag is closed and valid either
way. Every argument after ``--ros-args`` goes to ROS unchanged.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import RecordError, ReplayError, ResultsError
from ..params import check_number, positive
from .command_args import add_ros_arguments, ros_argv
from .executors import spin_once
from .replay import message_class

QOS_MODES = ("auto", "reliable", "best_effort")
#: Interval between looks at the ROS graph for topics not yet subscribed [s].
GRAPH_POLL = 0.2
#: Interval between progress lines (messages so far per topic, printed when they change) [s].
PROGRESS_PERIOD = 0.5


@dataclass(frozen=True)
class TopicRequest:
    """A topic to record and, if given, its type ``pkg/msg/Name``."""

    topic: str
    msgtype: str | None = None


def parse_topic(text: str) -> TopicRequest:
    """``/topic`` or ``/topic:pkg/msg/Name`` -> :class:`TopicRequest` (RecordError if malformed)."""
    topic, _, msgtype = text.partition(":")
    if not topic.startswith("/") or len(topic) < 2 or any(c.isspace() for c in topic):
        raise RecordError(f"topic {text!r} must be an absolute name like /bench/torque[:TYPE]")
    if msgtype and len(msgtype.split("/")) != 3:
        raise RecordError(f"type {msgtype!r} of {topic} must be of the form pkg/msg/Name")
    return TopicRequest(topic, msgtype or None)


def _typestore() -> Any:
    """Jazzy type store with this project's messages (when their definitions are found)."""
    from rosbags.typesys import Stores, get_typestore

    from ..bags.writer import project_typestore

    try:
        return project_typestore()
    except ResultsError:
        return get_typestore(Stores.ROS2_JAZZY)


class BagRecorder:
    """Subscribes to topics on ``node`` and writes what arrives into a bag.

    Args:
        node: the rclpy node.
        out: bag folder to create (must not exist).
        requests: topics (and types) to record.
        storage: ``"mcap"`` or ``"sqlite3"``.
        qos: ``"auto"``, ``"reliable"`` or ``"best_effort"``.
        depth: subscription history depth.
        log: where progress lines go.
    """

    def __init__(
        self,
        node: Any,
        out: str | Path,
        requests: Sequence[TopicRequest],
        storage: str = "mcap",
        qos: str = "auto",
        depth: int = 1000,
        log: Callable[[str], None] = print,
    ) -> None:
        from ..bags.writer import BagWriter, storage_plugin

        plugin = storage_plugin(storage, RecordError)
        if qos not in QOS_MODES:
            raise RecordError(f"qos = {qos!r} must be one of {list(QOS_MODES)}")
        if not requests:
            raise RecordError("no topic to record")
        topics = [r.topic for r in requests]
        if len(set(topics)) != len(topics):
            raise RecordError(f"a topic is given twice: {topics}")
        self.out = Path(out)
        if self.out.exists():
            raise RecordError(f"{self.out}: bag folder exists already")
        self.node = node
        self.qos = qos
        self.depth = depth
        self.log = log
        self.store = _typestore()
        self.pending = {r.topic: r.msgtype for r in requests}
        self.counts: dict[str, int] = {}
        self._subscriptions: list[Any] = []
        self._connections: dict[str, Any] = {}
        self.storage = storage
        self.writer = BagWriter(self.out, plugin, compressed=True)
        try:
            self.writer.open()
        except OSError as err:
            raise RecordError(f"{self.out}: cannot create bag ({err.strerror})") from err
        self._closed = False

    def _qos_for(self, topic: str) -> Any:
        from rclpy.qos import QoSProfile, ReliabilityPolicy

        reliable = ReliabilityPolicy.RELIABLE
        if self.qos == "auto":
            infos = self.node.get_publishers_info_by_topic(topic)
            if any(i.qos_profile.reliability != reliable for i in infos):
                reliable = ReliabilityPolicy.BEST_EFFORT
        elif self.qos == "best_effort":
            reliable = ReliabilityPolicy.BEST_EFFORT
        return QoSProfile(depth=self.depth, reliability=reliable)

    def poll_graph(self) -> None:
        """Subscribe to every pending topic that can be: its type is given or seen in the graph,
        and with ``qos="auto"`` a publisher exists (its QoS decides the subscription's)."""
        if not self.pending:
            return
        graph = dict(self.node.get_topic_names_and_types())
        for topic, given in list(self.pending.items()):
            seen = graph.get(topic)
            msgtype = given or (seen[0] if seen else None)
            if msgtype is None:
                continue
            if self.qos == "auto" and not self.node.get_publishers_info_by_topic(topic):
                continue
            if given and seen and given not in seen:
                self.log(f"record: warning: {topic} is published as {seen}, not {given}")
            del self.pending[topic]
            self._subscribe(topic, msgtype)

    def _subscribe(self, topic: str, msgtype: str) -> None:
        if msgtype not in self.store.types:
            self.log(
                f"record: error: type {msgtype} of {topic} is unknown to the bag type store;"
                " not recorded"
            )
            return
        try:
            cls = message_class(msgtype)
        except ReplayError as err:
            self.log(f"record: error: {topic}: {err}; not recorded")
            return
        conn = self.writer.add_connection(topic, msgtype, typestore=self.store)
        self._connections[topic] = conn
        self.counts[topic] = 0
        qos = self._qos_for(topic)

        def on_message(data: bytes, topic: str = topic) -> None:
            if self._closed:
                return
            self.writer.write(
                self._connections[topic], self.node.get_clock().now().nanoseconds, data
            )
            self.counts[topic] += 1

        self._subscriptions.append(
            self.node.create_subscription(cls, topic, on_message, qos, raw=True)
        )
        self.log(f"record: subscribed to {topic} ({msgtype}, {qos.reliability.name.lower()})")

    def progress(self) -> str:
        """Messages written so far per topic, sorted: ``/a 10, /b 2`` (``no topic`` before any)."""
        return ", ".join(f"{t} {n}" for t, n in sorted(self.counts.items())) or "no topic"

    def close(self) -> None:
        """Stop writing and close the bag (it is valid afterwards)."""
        if not self._closed:
            self._closed = True
            for sub in self._subscriptions:
                self.node.destroy_subscription(sub)
            self.writer.close()


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``record``."""
    parser.add_argument("--out", required=True, help="bag folder to create (must not exist)")
    parser.add_argument("topics", nargs="+", help="TOPIC or TOPIC:pkg/msg/Name")
    parser.add_argument("--duration", type=float, default=None, help="stop after this long [s]")
    parser.add_argument("--storage", default="mcap", choices=("mcap", "sqlite3"))
    parser.add_argument("--qos", default="auto", choices=QOS_MODES)
    parser.add_argument("--depth", type=int, default=1000, help="subscription history depth")
    add_ros_arguments(parser)


def run(args: argparse.Namespace) -> int:
    """Record until Ctrl-C / SIGTERM or ``--duration``; 0 on a clean stop."""
    import rclpy
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor

    if args.duration is not None:
        check_number(args.duration, positive("s"), "--duration", error=RecordError)
    requests = [parse_topic(t) for t in args.topics]
    rclpy.init(args=ros_argv("ballscrew-twin-record", args))
    context = rclpy.get_default_context()
    node = rclpy.create_node("bag_record", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    recorder = None
    try:
        recorder = BagRecorder(
            node,
            args.out,
            requests,
            storage=args.storage,
            qos=args.qos,
            depth=args.depth,
            log=lambda line: print(line, flush=True),
        )
        recorder.poll_graph()
        print(f"record: recording into {args.out}", flush=True)
        start = time.monotonic()
        next_poll = start + GRAPH_POLL
        next_report, reported = start + PROGRESS_PERIOD, ""
        while context.ok():
            now = time.monotonic()
            if args.duration is not None and now - start >= args.duration:
                break
            if now >= next_poll:
                recorder.poll_graph()
                next_poll = now + GRAPH_POLL
            if now >= next_report:
                line = recorder.progress()
                if line != reported:
                    print(f"record: {line}", flush=True)
                    reported = line
                next_report = now + PROGRESS_PERIOD
            spin_once(executor, 0.05)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if recorder is not None:
            recorder.close()
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
    if recorder is not None:
        for topic in recorder.pending:
            print(f"record: warning: {topic} never appeared; not in the bag", file=sys.stderr)
        print(f"record: wrote {args.out} ({recorder.progress()})", flush=True)
    return 0
