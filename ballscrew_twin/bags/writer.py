"""Writing rosbag2 bags: the one writer of every bag the project writes, and its type store.

``simulate`` (:func:`ballscrew_twin.results.write_bag`), the bench-data generator
(:func:`ballscrew_twin.bags.bench_writer.write_bench_bag`) and ``record``
(:class:`ballscrew_twin.ros.record.BagRecorder`) all write with :class:`BagWriter`: the
``rosbags`` library's writer, except that the bag says it was recorded under the project's ROS 2
distribution (:data:`ROS_DISTRO`, see package.xml) where the library would write its own name
(``ros_distro: rosbags``): in ``metadata.yaml``, in the metadata the storage keeps (the mcap
file's metadata record, the sqlite3 ``metadata`` table) and in the sqlite3 ``schema`` table.
:func:`storage_plugin` checks the storage name they all accept, and :func:`project_typestore`
is the Jazzy type store with this package's messages.
"""

from __future__ import annotations

import sqlite3
from pathlib import Path
from typing import Any

from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from ..errors import BallscrewTwinError, ResultsError

#: Folder of the message definitions (repository layout).
MSG_DIR = Path(__file__).resolve().parents[2] / "msg_defs" / "msg"
#: The package of this project's messages.
MSG_PACKAGE = "ballscrew_twin_msgs"
#: Storage name -> the library's storage plugin.
STORAGES = {"mcap": StoragePlugin.MCAP, "sqlite3": StoragePlugin.SQLITE3}


def storage_plugin(storage: str, error: type[BallscrewTwinError]) -> Any:
    """The storage plugin of ``storage`` (``"mcap"`` or ``"sqlite3"``); ``error`` otherwise."""
    if storage not in STORAGES:
        raise error(f"storage = {storage!r} must be one of {sorted(STORAGES)}")
    return STORAGES[storage]


def project_typestore(msg_dir: str | Path = MSG_DIR) -> Any:
    """A ROS 2 Jazzy type store with this package's messages registered from their .msg text.

    Raises:
        ResultsError: ``msg_dir`` does not exist or holds no ``*.msg`` file.
    """
    folder = Path(msg_dir)
    files = sorted(folder.glob("*.msg")) if folder.is_dir() else []
    if not files:
        raise ResultsError(f"{folder}: message definitions folder does not exist or has no *.msg")
    store = get_typestore(Stores.ROS2_JAZZY)
    types: dict[str, Any] = {}
    for file in files:
        types.update(
            get_types_from_msg(file.read_text(encoding="utf-8"), f"{MSG_PACKAGE}/msg/{file.stem}")
        )
    store.register(types)
    return store


#: ROS 2 distribution the project's bags are recorded under.
ROS_DISTRO = "jazzy"
#: How the bag library labels ``ros_distro`` in the metadata it writes.
LIBRARY_LABEL = "ros_distro: rosbags"


def relabel_distro(metadata: str) -> str:
    """``metadata`` (a bag's YAML metadata text) with ``ros_distro`` set to :data:`ROS_DISTRO`.

    Raises:
        BallscrewTwinError: the text has no library label to replace.
    """
    if LIBRARY_LABEL not in metadata:
        raise BallscrewTwinError(f"bag metadata has no {LIBRARY_LABEL!r} line to relabel")
    return metadata.replace(LIBRARY_LABEL, f"ros_distro: {ROS_DISTRO}")


class BagWriter(Writer):
    """``rosbags.rosbag2.Writer`` of rosbag2 version 9 whose bags say :data:`ROS_DISTRO`; used
    as the library's writer (``open``/``close`` or ``with``). ``compressed``: an mcap bag's
    chunks are zstd-compressed (an sqlite3 bag is never compressed)."""

    def __init__(self, path: str | Path, storage_plugin: Any, compressed: bool = False) -> None:
        super().__init__(Path(path), version=9, storage_plugin=storage_plugin)
        if compressed and storage_plugin == StoragePlugin.MCAP:
            self.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)

    def open(self) -> None:
        """Open the bag; the storage will keep the relabelled metadata when closed."""
        super().open()
        storage = self.storage
        if storage is None:
            raise BallscrewTwinError(f"{self.path}: the bag's storage did not open")
        close = storage.close

        def close_relabelled(version: int, metadata: str) -> None:
            close(version, relabel_distro(metadata))

        storage.close = close_relabelled  # type: ignore[method-assign]

    def close(self) -> None:
        """Close the bag, then relabel ``metadata.yaml`` and a sqlite3 database's schema."""
        super().close()
        meta = self.path / "metadata.yaml"
        meta.write_text(relabel_distro(meta.read_text(encoding="utf-8")), encoding="utf-8")
        for db in self.path.glob("*.db3"):
            connection = sqlite3.connect(db)
            try:
                with connection:
                    connection.execute("UPDATE schema SET ros_distro = ?", (ROS_DISTRO,))
            finally:
                connection.close()
