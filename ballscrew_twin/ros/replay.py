"""``ballscrew-twin replay BAG [--rate X] [--topics T ...] [--loop]``: publish a recorded bag.

``ros2 bag play`` is not available from PyPI; this plays a rosbag2 bag (mcap or sqlite3, read
with ``rosbags`` through :func:`~ballscrew_twin.bags.reader.open_raw_bag`, so a truncated or
partly corrupt bag plays everything readable and says what it skipped) on its own topics:

- messages are published as recorded (serialized bytes, not decoded), paced by their bag time
  divided by ``--rate`` (1: real time, 10: ten times faster, 0: as fast as possible);
- ``/clock`` (``rosgraph_msgs/Clock``) carries the bag time, before every message and at about
  ``--clock-rate`` Hz while waiting, so nodes with ``use_sim_time`` follow the bag's time;
- ``--loop`` plays the bag again and again; the clock keeps increasing (each pass is shifted by
  the bag's length plus one mean message interval), header stamps inside messages are the
  recorded ones;
- publishers are reliable, keep-last ``--depth`` (default 10000: ten seconds of a 1 kHz topic
  at 1x, two at 5x): both reliable and best-effort (sensor-data) subscribers receive them. The
  depth bounds how far a reliable subscriber's DDS layer may lag (what it has not acknowledged
  is resent from there), not how far its callbacks may lag: DDS takes the messages into the
  subscriber's own queue (its depth) at once, and a node starved of CPU works through that
  queue after the replay has ended (measured with ``--depth 100``, a health node beside three
  busy-looping processes: 301 of the 4000 torque messages of a 5x replay processed when the
  replay ended, the rest within the next 30 s, none lost). ``--wait-subscribers S`` waits up
  to S seconds for every played topic to have a subscriber, and then half a second for the
  subscribers' side of the match, before starting;
- at the end, ``--drain S`` (default 10 s) waits up to S seconds until every reliable
  subscriber has acknowledged every message, and names the topics that were not. A publisher
  that goes away drops what its subscribers have not yet acknowledged: a reliable subscriber
  in a process that was stopped while 2000 messages were published received 102 of them when
  the publisher exited at once, and all 2000 when it drained first (rclpy
  ``Publisher.wait_for_all_acked``); a health node starved of CPU lost the last 5 % of a 5x
  replay that way (3800 of 4000 torque messages, two test runs and a benchmark on 2 cores);
- while playing, every topic's count of matched subscribers is checked every 0.05 s: a
  subscriber that goes (or that DDS unmatches) misses what is published meanwhile, and the
  drain cannot resend it, since it waits only for the subscribers matched at its end. The
  replay names such topics with their counts (at the start, the fewest).

Stops at the end of the bag, or cleanly on Ctrl-C / SIGTERM. Every argument after
``--ros-args`` goes to ROS unchanged.
"""

from __future__ import annotations

import argparse
import importlib
import math
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

from ..bags.reader import RawBag, open_raw_bag
from ..bags.records import RawMessage
from ..errors import ReplayError
from ..params import check_number, limits, positive
from ..units import ns_to_stamp
from .command_args import add_ros_arguments, ros_argv

CLOCK_TOPIC = "/clock"
#: History depth of the reliable publishers [messages] (see the module doc).
DEFAULT_DEPTH = 10_000
#: Longest single sleep while pacing [s], so that a stop request is seen quickly.
MAX_SLEEP = 0.05
#: Longest wait at the end for the subscribers' acknowledgements [s] (``--drain``).
DEFAULT_DRAIN = 10.0
#: Longest single wait for acknowledgements while draining [s] (a stop request is seen).
DRAIN_SLICE = 0.25
#: Period of the check of every topic's subscriber count while playing [s].
SUBSCRIBER_CHECK = 0.05
#: Wait after every played topic has a subscriber [s]: DDS discovery is not symmetric, and a
#: best-effort subscriber drops what arrives before it has matched the publisher in turn.
MATCH_SETTLE = 0.5


def message_class(msgtype: str) -> Any:
    """The rclpy message class of ``pkg/msg/Name`` (ReplayError when not importable)."""
    parts = msgtype.split("/")
    if len(parts) != 3 or parts[1] != "msg":
        raise ReplayError(f"message type {msgtype!r} is not of the form pkg/msg/Name")
    try:
        return getattr(importlib.import_module(f"{parts[0]}.msg"), parts[2])
    except (ImportError, AttributeError) as err:
        raise ReplayError(f"message type {msgtype} is not installed ({err})") from err


@dataclass
class PlayStats:
    """What a replay did: messages published per topic, passes, skipped topics, issues."""

    published: dict[str, int] = field(default_factory=dict)
    passes: int = 0
    skipped_topics: dict[str, str] = field(default_factory=dict)
    stopped: bool = False
    #: topics whose reliable subscribers had not acknowledged everything when the drain ended
    unacknowledged: list[str] = field(default_factory=list)
    #: per topic, subscribers when the playing started and the fewest seen while playing
    subscribers: dict[str, tuple[int, int]] = field(default_factory=dict)

    @property
    def lost_subscribers(self) -> dict[str, tuple[int, int]]:
        """Topics that had fewer subscribers at some time of the playing than at its start:
        (at the start, fewest). What was published meanwhile never reached the ones that went
        (or that DDS unmatched), and the drain cannot resend it: it waits only for the
        subscribers matched at its end."""
        return {t: (first, low) for t, (first, low) in self.subscribers.items() if low < first}

    @property
    def total(self) -> int:
        """Messages published on all topics."""
        return sum(self.published.values())


class BagPlayer:
    """Publishes the messages of a :class:`RawBag` on ``node``, paced by bag time.

    Args:
        node: the rclpy node that owns the publishers.
        bag: the opened bag.
        topics: topics to play (None: all the bag's topics whose type is installed).
        rate: playback speed relative to real time (> 0), or 0 for as fast as possible.
        loop: play again and again until stopped.
        clock: publish ``/clock``.
        clock_rate: ``/clock`` rate while waiting between messages [Hz].
        depth: history depth of the reliable publishers.
    """

    def __init__(
        self,
        node: Any,
        bag: RawBag,
        topics: Sequence[str] | None = None,
        rate: float = 1.0,
        loop: bool = False,
        clock: bool = True,
        clock_rate: float = 100.0,
        depth: int = DEFAULT_DEPTH,
    ) -> None:
        from rclpy.qos import QoSProfile, ReliabilityPolicy

        check_number(
            rate,
            limits("-", 0.0, math.inf, hint="0: no pacing"),
            "rate",
            text=False,
            error=ReplayError,
        )
        check_number(clock_rate, positive("Hz"), "clock_rate", text=False, error=ReplayError)
        check_number(
            depth, limits("-", 1, math.inf, integer=True), "depth", text=False, error=ReplayError
        )
        wanted = list(bag.topics) if topics is None else list(topics)
        missing = sorted(set(wanted) - set(bag.topics))
        if missing:
            raise ReplayError(
                f"{bag.path}: topic(s) {missing} not in the bag; it has {sorted(bag.topics)}"
            )
        self.node = node
        self.bag = bag
        self.rate = rate
        self.loop = loop
        self.clock_period = 1.0 / clock_rate
        self.stats = PlayStats()
        qos = QoSProfile(depth=depth, reliability=ReliabilityPolicy.RELIABLE)
        self.publishers: dict[str, Any] = {}
        for topic in wanted:
            msgtype = bag.topics[topic].msgtype
            try:
                cls = message_class(msgtype)
            except ReplayError as err:
                if topics is not None:
                    raise
                self.stats.skipped_topics[topic] = str(err)
                continue
            self.publishers[topic] = node.create_publisher(cls, topic, qos)
            self.stats.published[topic] = 0
        if not self.publishers:
            raise ReplayError(f"{bag.path}: no topic can be played ({self.stats.skipped_topics})")
        self._clock_cls = message_class("rosgraph_msgs/msg/Clock")
        self.clock_pub = node.create_publisher(self._clock_cls, CLOCK_TOPIC, QoSProfile(depth=10))
        self.clock = clock
        self._last_clock_ns = -1

    @property
    def period_ns(self) -> int:
        """Bag time added per loop pass [ns]: its length plus one mean message interval."""
        count = sum(max(info.count, 0) for t, info in self.bag.topics.items())
        span = max(self.bag.end_ns - self.bag.start_ns, 0)
        return span + (span // max(count - 1, 1) if count > 1 else 1_000_000)

    def matched(self) -> bool:
        """Every played topic has at least one matched subscriber."""
        return all(p.get_subscription_count() > 0 for p in self.publishers.values())

    def wait_for_subscribers(self, timeout: float, ok: Callable[[], bool]) -> bool:
        """Wait up to ``timeout`` [s] for every played topic to have a subscriber, then
        :data:`MATCH_SETTLE` more (the subscriber's side of the match completes after ours)."""
        deadline = time.monotonic() + timeout
        while ok() and time.monotonic() < deadline:
            if self.matched():
                settled = time.monotonic() + MATCH_SETTLE
                while ok() and time.monotonic() < settled:
                    time.sleep(MAX_SLEEP)
                return True
            time.sleep(MAX_SLEEP)
        return self.matched()

    def _publish_clock(self, bag_ns: int) -> None:
        if self.clock and bag_ns > self._last_clock_ns:
            msg = self._clock_cls()
            msg.clock.sec, msg.clock.nanosec = ns_to_stamp(bag_ns)
            self.clock_pub.publish(msg)
            self._last_clock_ns = bag_ns

    def _messages(self) -> Iterator[tuple[int, RawMessage]]:
        """(bag time incl. loop shift [ns], message), pass after pass."""
        shift = 0
        while True:
            self.stats.passes += 1
            for m in self.bag.messages(sorted(self.publishers)):
                yield m.log_time + shift, m
            if not self.loop:
                return
            shift += self.period_ns

    def _count_subscribers(self) -> None:
        """Fold the topics' subscriber counts now into ``stats.subscribers``."""
        for topic, publisher in self.publishers.items():
            count = publisher.get_subscription_count()
            first, low = self.stats.subscribers.get(topic, (count, count))
            self.stats.subscribers[topic] = (first, min(low, count))

    def play(self, ok: Callable[[], bool]) -> PlayStats:
        """Publish until the bag ends (or forever with ``loop``) or ``ok()`` turns false;
        the topics' subscriber counts are watched meanwhile (``stats.lost_subscribers``)."""
        wall0 = time.monotonic()
        last_clock_wall = last_check = wall0
        self._count_subscribers()
        start = self.bag.start_ns
        for bag_ns, m in self._messages():
            if time.monotonic() - last_check >= SUBSCRIBER_CHECK:
                self._count_subscribers()
                last_check = time.monotonic()
            if self.rate > 0.0:
                due = wall0 + (bag_ns - start) * 1e-9 / self.rate
                while (now := time.monotonic()) < due:
                    if not ok():
                        self.stats.stopped = True
                        return self.stats
                    if now - last_clock_wall >= self.clock_period:
                        self._publish_clock(start + int((now - wall0) * self.rate * 1e9))
                        last_clock_wall = now
                    time.sleep(min(due - now, MAX_SLEEP, self.clock_period))
            if not ok():
                self.stats.stopped = True
                return self.stats
            self._publish_clock(bag_ns)
            self.publishers[m.topic].publish(m.data)
            self.stats.published[m.topic] += 1
        self._count_subscribers()
        return self.stats

    def drain(self, timeout: float, ok: Callable[[], bool]) -> list[str]:
        """Wait up to ``timeout`` [s] until every reliable subscriber of every played topic
        has acknowledged every message published; return the topics (sorted) still waiting
        when the time is up or ``ok()`` turns false (also kept in ``stats.unacknowledged``).
        Best-effort subscribers acknowledge nothing and are not waited for."""
        from rclpy.duration import Duration

        deadline = time.monotonic() + max(timeout, 0.0)
        waiting = sorted(self.publishers)
        while True:
            left = deadline - time.monotonic()
            step = Duration(nanoseconds=int(max(min(left, DRAIN_SLICE), 0.0) * 1e9))
            waiting = [t for t in waiting if not self.publishers[t].wait_for_all_acked(step)]
            if not waiting or left <= 0.0 or not ok():
                break
        self.stats.unacknowledged = waiting
        return waiting


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``replay``."""
    parser.add_argument("bag", help="bag folder, or a .mcap / .db3 file")
    parser.add_argument(
        "--rate", type=float, default=1.0, help="speed relative to real time (0: no pacing)"
    )
    parser.add_argument("--topics", nargs="+", default=None, help="topics to play (default all)")
    parser.add_argument("--loop", action="store_true", help="play again and again until stopped")
    parser.add_argument("--no-clock", action="store_true", help="do not publish /clock")
    parser.add_argument("--clock-rate", type=float, default=100.0, help="/clock rate [Hz]")
    parser.add_argument(
        "--depth", type=int, default=DEFAULT_DEPTH, help="publisher history depth [messages]"
    )
    parser.add_argument(
        "--drain",
        type=float,
        default=DEFAULT_DRAIN,
        help="at the end, wait up to this long [s] for every reliable subscriber to "
        "acknowledge every message (0: exit at once; what is not acknowledged is lost)",
    )
    parser.add_argument(
        "--wait-subscribers",
        type=float,
        default=0.0,
        help="wait up to this long [s] for a subscriber on every played topic",
    )
    add_ros_arguments(parser)


def run(args: argparse.Namespace) -> int:
    """Play the bag; 0 when played (or stopped by a signal), BagError/ReplayError otherwise."""
    import rclpy
    from rclpy.executors import ExternalShutdownException

    check_number(
        args.drain,
        limits("s", 0.0, math.inf, hint="0: no wait"),
        "--drain",
        text=False,
        error=ReplayError,
    )

    rclpy.init(args=ros_argv("ballscrew-twin-replay", args))
    context = rclpy.get_default_context()
    node = None
    try:
        with open_raw_bag(args.bag) as bag:
            for issue in bag.issues:
                print(f"replay: warning: {issue}", file=sys.stderr)
            seen = len(bag.issues)
            node = rclpy.create_node("bag_replay", context=context)
            player = BagPlayer(
                node,
                bag,
                topics=args.topics,
                rate=args.rate,
                loop=args.loop,
                clock=not args.no_clock,
                clock_rate=args.clock_rate,
                depth=args.depth,
            )
            for topic, why in player.stats.skipped_topics.items():
                print(f"replay: warning: {topic} not played: {why}", file=sys.stderr)
            if args.wait_subscribers > 0.0 and not player.wait_for_subscribers(
                args.wait_subscribers, context.ok
            ):
                print(
                    "replay: warning: not every topic has a subscriber; playing anyway",
                    file=sys.stderr,
                )
            print(
                f"replay: playing {args.bag} ({len(player.publishers)} topics, rate {args.rate:g})",
                flush=True,
            )
            stats = player.play(context.ok)
            for topic, (first, low) in stats.lost_subscribers.items():
                print(
                    f"replay: warning: {topic}: {first} subscriber(s) at the start, {low} at one "
                    "time; the messages published meanwhile did not reach the ones that went "
                    "(or that DDS unmatched), and the drain cannot resend them",
                    file=sys.stderr,
                )
            if not stats.stopped and player.drain(args.drain, context.ok):
                print(
                    f"replay: warning: {', '.join(stats.unacknowledged)}: not every reliable "
                    f"subscriber acknowledged every message within --drain {args.drain:g} s; "
                    "the last messages may not have arrived",
                    file=sys.stderr,
                )
            for issue in bag.issues[seen:]:
                print(f"replay: warning: {issue}", file=sys.stderr)
        print(
            f"replay: published {stats.total} messages in {stats.passes} pass(es)"
            + (" (stopped)" if stats.stopped else ""),
            flush=True,
        )
        return 0
    except (KeyboardInterrupt, ExternalShutdownException):
        return 0
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown(context=context)
