"""What every reader of a bag hands out: the topics it holds and its messages, still serialized.

Both the indexed reader (:mod:`.reader`) and the salvage of damaged storage files
(:mod:`.salvage`) return these records. Times are bag (log) times in integer nanoseconds.
"""

from __future__ import annotations

from dataclasses import dataclass


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
