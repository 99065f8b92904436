"""Writing a bench recording as a bag of the bench-bag schema (docs/bench_data.md; read back by
:mod:`.bench`): torque and preload as WrenchStamped, the screw's joint state, the temperature,
and the ground truth in ``metadata.yaml`` and the side file ``<bag>.truth.json``.

What is written is any set of sampled channels (:class:`BenchChannels`): the bench-data
generator's recordings (:class:`ballscrew_twin.health.bench_data.BenchData`) are one.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray
from rosbags.typesys import Stores, get_typestore

from ..errors import BagError
from ..units import CELSIUS_ZERO, SCREW_FRAME_ID, ns_to_stamp
from .recording import TRUTH_KEY, BenchTopics, truth_path
from .writer import BagWriter, storage_plugin

FloatArray = NDArray[np.float64]


class BenchChannels(Protocol):
    """The sampled channels of a bench recording (instants [s] from the bag's start; SI)."""

    @property
    def torque_time(self) -> FloatArray:
        """Torque-meter instants [s]."""
        ...

    @property
    def torque(self) -> FloatArray:
        """Torque [N m]."""
        ...

    @property
    def speed_time(self) -> FloatArray:
        """Encoder instants [s]."""
        ...

    @property
    def speed(self) -> FloatArray:
        """Screw speed [rad/s]."""
        ...

    @property
    def angle(self) -> FloatArray:
        """Screw angle [rad]."""
        ...

    @property
    def temperature_time(self) -> FloatArray:
        """Thermometer instants [s]."""
        ...

    @property
    def temperature(self) -> FloatArray:
        """Temperature [K]."""
        ...

    @property
    def temperature_variance(self) -> FloatArray:
        """Its variance [K^2]."""
        ...

    @property
    def preload_time(self) -> FloatArray:
        """Load-cell instants [s]."""
        ...

    @property
    def preload(self) -> FloatArray:
        """Preload [N]."""
        ...

    @property
    def truth(self) -> dict[str, Any]:
        """The ground truth (JSON-ready)."""
        ...


def _nanoseconds(start_ns: int, seconds: FloatArray) -> NDArray[np.int64]:
    """Bag time [ns] of instants [s] since ``start_ns`` [ns]."""
    return start_ns + np.round(np.asarray(seconds) * 1e9).astype(np.int64)


def write_bench_bag(
    data: BenchChannels,
    path: str | Path,
    start_ns: int,
    storage: str = "mcap",
    topics: BenchTopics | None = None,
) -> Path:
    """Write ``data`` as a rosbag2 bag (zstd-compressed mcap, or sqlite3) plus the side file
    ``<bag>.truth.json``; the truth is also in ``metadata.yaml`` ``custom_data``. Its
    instants [s] count from ``start_ns``, the bag time of t = 0 [ns].

    Raises:
        BagError: the bag folder exists already or cannot be written; unknown storage.
    """
    plugin = storage_plugin(storage, BagError)
    folder = Path(path)
    if folder.exists():
        raise BagError(f"{folder}: bag folder exists already")
    topics = topics or BenchTopics()
    store = get_typestore(Stores.ROS2_JAZZY)
    t = store.types
    header_cls, time_cls = t["std_msgs/msg/Header"], t["builtin_interfaces/msg/Time"]
    vector, wrench_cls = t["geometry_msgs/msg/Vector3"], t["geometry_msgs/msg/Wrench"]
    stamped = "geometry_msgs/msg/WrenchStamped"
    joint = "sensor_msgs/msg/JointState"
    temperature = "sensor_msgs/msg/Temperature"
    zero = vector(x=0.0, y=0.0, z=0.0)
    no_effort = np.zeros(0, dtype=np.float64)

    def header(ns: int) -> Any:
        sec, nanosec = ns_to_stamp(ns)
        return header_cls(stamp=time_cls(sec=sec, nanosec=nanosec), frame_id=SCREW_FRAME_ID)

    def torque_msg(ns: int, v: float) -> Any:
        z = vector(x=0.0, y=0.0, z=v)
        return t[stamped](header=header(ns), wrench=wrench_cls(force=zero, torque=z))

    def preload_msg(ns: int, v: float) -> Any:
        z = vector(x=0.0, y=0.0, z=v)
        return t[stamped](header=header(ns), wrench=wrench_cls(force=z, torque=zero))

    def joint_msg(ns: int, w: float, a: float) -> Any:
        return t[joint](
            header=header(ns),
            name=[topics.joint_name],
            position=np.array([a]),
            velocity=np.array([w]),
            effort=no_effort,
        )

    def temperature_msg(ns: int, kelvin: float, var: float) -> Any:
        return t[temperature](header=header(ns), temperature=kelvin - CELSIUS_ZERO, variance=var)

    streams: list[tuple[str, str, FloatArray, Callable[..., Any], tuple[FloatArray, ...]]] = [
        (topics.torque, stamped, data.torque_time, torque_msg, (data.torque,)),
        (topics.speed, joint, data.speed_time, joint_msg, (data.speed, data.angle)),
        (
            topics.temperature,
            temperature,
            data.temperature_time,
            temperature_msg,
            (data.temperature, data.temperature_variance),
        ),
        (topics.preload, stamped, data.preload_time, preload_msg, (data.preload,)),
    ]
    truth_json = json.dumps(data.truth, sort_keys=True)
    try:
        writer = BagWriter(folder, plugin, compressed=True)
        writer.set_custom_data(TRUTH_KEY, truth_json)
        with writer:
            records: list[tuple[int, int, bytes]] = []
            connections = []
            for k, (topic, msgtype, times, make, columns) in enumerate(streams):
                connections.append(writer.add_connection(topic, msgtype, typestore=store))
                rows = zip(
                    _nanoseconds(start_ns, times).tolist(),
                    *(c.tolist() for c in columns),
                    strict=True,
                )
                for ns, *values in rows:
                    payload = store.serialize_cdr(make(ns, *values), msgtype)
                    records.append((ns, k, bytes(payload)))
            records.sort(key=lambda r: (r[0], r[1]))
            for ns, k, raw in records:
                writer.write(connections[k], ns, raw)
    except OSError as err:
        raise BagError(f"{folder}: cannot write bag ({err.strerror})") from err
    side = truth_path(folder)
    side.write_text(json.dumps(data.truth, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    return folder
