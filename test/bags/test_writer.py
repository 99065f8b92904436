"""Every bag writer of the project labels its bags ``ros_distro: jazzy`` through the one
:class:`~ballscrew_twin.bags.writer.BagWriter`: metadata.yaml, the storage's own metadata (the
mcap metadata record, the sqlite3 metadata table) and the sqlite3 schema table."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pytest
import yaml
from rosbags.rosbag2 import Reader, StoragePlugin
from rosbags.typesys import Stores, get_typestore

from ballscrew_twin.bags.writer import ROS_DISTRO, BagWriter, relabel_distro
from ballscrew_twin.commands.bench_data import generate_bag
from ballscrew_twin.errors import BallscrewTwinError
from ballscrew_twin.health.bench_data import SCENE_DIR

PLUGINS = {"mcap": StoragePlugin.MCAP, "sqlite3": StoragePlugin.SQLITE3}


def assert_labelled(bag: Path, storage: str) -> None:
    """The bag says jazzy wherever it keeps its metadata, and nowhere the library's name."""
    info = yaml.safe_load((bag / "metadata.yaml").read_text(encoding="utf-8"))
    assert info["rosbag2_bagfile_information"]["ros_distro"] == ROS_DISTRO == "jazzy"
    with Reader(bag) as reader:
        assert reader.ros_distro == "jazzy"
    if storage == "mcap":
        (data,) = bag.glob("*.mcap")
        record = data.read_bytes().split(b"serialized_metadata")[1]
        assert b"ros_distro: jazzy" in record and b"rosbags" not in record
    else:
        (data,) = bag.glob("*.db3")
        connection = sqlite3.connect(data)
        try:
            assert connection.execute("SELECT ros_distro FROM schema").fetchall() == [("jazzy",)]
            (stored,) = connection.execute("SELECT metadata FROM metadata").fetchone()
        finally:
            connection.close()
        assert yaml.safe_load(stored)["ros_distro"] == "jazzy"


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_the_writer_labels_every_copy_of_the_metadata(tmp_path: Path, storage: str) -> None:
    store = get_typestore(Stores.ROS2_JAZZY)
    with BagWriter(tmp_path / "bag", PLUGINS[storage]) as writer:
        connection = writer.add_connection("/x", "std_msgs/msg/Float64", typestore=store)
        writer.write(connection, 1, b"\x00\x01\x00\x00" + bytes(8))
    assert_labelled(tmp_path / "bag", storage)


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_bench_data_bags_say_jazzy(tmp_path: Path, storage: str) -> None:
    short = tmp_path / "short.yaml"
    data = yaml.safe_load((SCENE_DIR / "healthy.yaml").read_text(encoding="utf-8"))
    data["duration"] = 1.0
    short.write_text(yaml.safe_dump(data), encoding="utf-8")
    generate_bag(short, tmp_path / "bag", storage=storage)
    assert_labelled(tmp_path / "bag", storage)


def test_metadata_without_the_library_label_is_refused() -> None:
    with pytest.raises(BallscrewTwinError, match="no 'ros_distro: rosbags' line"):
        relabel_distro("rosbag2_bagfile_information:\n  version: 9\n")
