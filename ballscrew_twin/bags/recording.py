"""A bench recording in SI units: its channels, their series, the bench topics they come from,
and the ground truth of a generated one.

:func:`ballscrew_twin.bags.bench.read_bench_bag` builds a :class:`BenchRecording` from a bag;
the health monitor, calibration, the generator and the nodes use these types without reading
any bag.
"""

from __future__ import annotations

import heapq
import json
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import BagError

FloatArray = NDArray[np.float64]

#: Channels of a :class:`BenchRecording` (``angle`` comes with ``speed`` from a JointState).
CHANNELS = ("torque", "speed", "angle", "temperature", "preload")
#: Unit of each channel's values.
UNITS = {"torque": "N m", "speed": "rad/s", "angle": "rad", "temperature": "K", "preload": "N"}
#: Key of the ground truth (a JSON string) in the bag's ``metadata.yaml`` ``custom_data``.
TRUTH_KEY = "ballscrew_twin.truth"
#: Suffix of the ground-truth side file next to the bag folder.
TRUTH_SUFFIX = ".truth.json"


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
