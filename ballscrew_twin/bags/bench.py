"""The bench bag: its topics decoded into time-ordered SI series, and its ground truth.

:func:`read_bench_bag` reads a bag with :func:`~ballscrew_twin.bags.reader.open_raw_bag` (so a
damaged bag gives what is readable) and decodes the bench topics (schema below) into a
:class:`~ballscrew_twin.bags.recording.BenchRecording` in SI units: torque [N m], screw speed
[rad/s], screw angle [rad], temperature [K] (the bag holds degrees Celsius,
``sensor_msgs/Temperature``'s own convention, converted here at the edge), preload [N]. A
required topic that is missing, of the wrong message type or with nothing readable is a
:class:`BagError` naming the topic and what is wrong; an optional one is skipped and listed in
``issues``; undecodable or non-finite messages are skipped and counted.

Bench bag schema (``BenchTopics`` defaults):

- ``/bench/torque`` ``geometry_msgs/msg/WrenchStamped``: ``wrench.torque.z`` drive torque on the
  screw [N m], with the sign of the speed (or ``std_msgs/msg/Float64``);
- ``/bench/joint_states`` ``sensor_msgs/msg/JointState``: joint ``screw``, position [rad],
  velocity [rad/s] (or ``std_msgs/msg/Float64`` speed [rad/s]);
- ``/bench/temperature`` ``sensor_msgs/msg/Temperature``: temperature [deg C], variance;
- ``/bench/preload`` ``geometry_msgs/msg/WrenchStamped``: ``wrench.force.z`` load-cell preload
  [N] (or ``std_msgs/msg/Float64``).

Sample times are header stamps (log time for ``Float64``, which has no header), in seconds
since the earliest sample of the recording. The ground truth of a generated bag is in the side
file ``<bag>.truth.json`` (:func:`~ballscrew_twin.bags.recording.truth_path`) and in
``metadata.yaml`` ``custom_data``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import BagError
from ..units import CELSIUS_ZERO, stamp_to_ns
from .reader import RawBag, open_raw_bag
from .recording import CHANNELS, TRUTH_KEY, BenchRecording, BenchTopics, Series, read_truth

#: Header stamps further than this from the bag time [ns] are reported (they are still used).
STAMP_TOLERANCE_NS = 1_000_000_000

#: Bench channels and the message types accepted for each.
ACCEPTED_TYPES: dict[str, tuple[str, ...]] = {
    "torque": ("geometry_msgs/msg/WrenchStamped", "std_msgs/msg/Float64"),
    "speed": ("sensor_msgs/msg/JointState", "std_msgs/msg/Float64"),
    "temperature": ("sensor_msgs/msg/Temperature",),
    "preload": ("geometry_msgs/msg/WrenchStamped", "std_msgs/msg/Float64"),
}


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
