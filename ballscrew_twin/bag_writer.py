"""The rosbag2 writer of every bag the project writes (``record``, ``simulate``, ``bench-data``).

It is the ``rosbags`` library's writer, except that the bag says it was recorded under the
project's ROS 2 distribution (:data:`ROS_DISTRO`, see package.xml) where the library would
write its own name (``ros_distro: rosbags``): in ``metadata.yaml``, in the metadata the
storage keeps (the mcap file's metadata record, the sqlite3 ``metadata`` table) and in the
sqlite3 ``schema`` table. This module imports ``rosbags`` (import it where a bag is written).
"""

from __future__ import annotations

import sqlite3
from pathlib import Path
from typing import Any

from rosbags.rosbag2 import Writer

from .errors import BallscrewTwinError

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
    as the library's writer (``open``/``close`` or ``with``)."""

    def __init__(self, path: str | Path, storage_plugin: Any) -> None:
        super().__init__(Path(path), version=9, storage_plugin=storage_plugin)

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
