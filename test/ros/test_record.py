"""Record on loopback: what ``replay`` publishes, ``record`` writes back, message for message."""

from __future__ import annotations

import argparse
import math
import os
import select
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest
import rclpy
import yaml
from rclpy.context import Context
from rosbags.rosbag2 import Reader

from ballscrew_twin.bags.reader import open_raw_bag
from ballscrew_twin.bags.writer import ROS_DISTRO
from ballscrew_twin.errors import RecordError
from ballscrew_twin.ros.record import BagRecorder, parse_topic
from ballscrew_twin.ros.record import run as record_run
from ballscrew_twin.ros.replay import BagPlayer

from .test_replay import TORQUES, write_test_bag

#: Longest the recorder may take to start, to subscribe, or to stop [s].
TIMEOUT = 30.0


def _wait_for_line(proc: subprocess.Popen[str], text: str) -> str:
    """Read the process's output until a line contains ``text`` (bounded by TIMEOUT)."""
    assert proc.stdout is not None
    deadline = time.monotonic() + TIMEOUT
    seen = []
    while (remaining := deadline - time.monotonic()) > 0:
        ready, _, _ = select.select([proc.stdout], [], [], remaining)
        if not ready:
            break
        line = proc.stdout.readline()
        if not line:
            break
        seen.append(line)
        if text in line:
            return line
    pytest.fail(f"no line with {text!r} from the recorder; output: {''.join(seen)!r}")


def test_record_writes_back_what_replay_publishes(tmp_path: Path, ros_context: Context) -> None:
    original = write_test_bag(tmp_path / "original")
    out = tmp_path / "recorded"
    command = [
        sys.executable,
        "-m",
        "ballscrew_twin.cli",
        "record",
        "--out",
        str(out),
        "/bench/torque",
        "/bench/temperature:sensor_msgs/msg/Temperature",
        "/clock",
    ]
    proc = subprocess.Popen(
        command,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=dict(os.environ),
        stdin=subprocess.DEVNULL,
    )
    node = rclpy.create_node("player", context=ros_context)
    try:
        _wait_for_line(proc, "recording into")
        with open_raw_bag(original) as raw:
            player = BagPlayer(node, raw, rate=4.0)
            # the recorder subscribes once it sees the publishers (QoS auto)
            assert player.wait_for_subscribers(TIMEOUT, ros_context.ok)
            deadline = time.monotonic() + TIMEOUT
            while node.count_subscribers("/clock") == 0 and time.monotonic() < deadline:
                time.sleep(0.05)
            player.play(ros_context.ok)
        # the recorder's progress line once every message has arrived
        _wait_for_line(proc, f"/bench/temperature 4, /bench/torque {TORQUES}")
        proc.send_signal(signal.SIGINT)  # Ctrl-C: the bag is closed and valid
        summary = _wait_for_line(proc, "record: wrote")
        assert proc.wait(timeout=TIMEOUT) == 0
    finally:
        node.destroy_node()
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=TIMEOUT)
    assert f"/bench/torque {TORQUES}" in summary
    with open_raw_bag(original) as a, open_raw_bag(out) as b:
        assert b.issues == []
        for topic in ("/bench/torque", "/bench/temperature"):
            assert b.topics[topic].msgtype == a.topics[topic].msgtype
            sent = [m.data for m in a.messages([topic])]
            got = [m.data for m in b.messages([topic])]
            assert got == sent  # byte for byte, in order
        clock = [m.log_time for m in b.messages(["/clock"])]
        assert clock and clock == sorted(clock)
    # mcap chunk compression (storage-internal, so metadata.yaml says none): each chunk record
    # names its compression as a length-prefixed string
    (mcap,) = out.glob("*.mcap")
    assert b"\x04\x00\x00\x00zstd" in mcap.read_bytes()
    info = yaml.safe_load((out / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["ros_distro"] == ROS_DISTRO == "jazzy"


class NoNode:
    """A recorder that never subscribes needs no ROS node."""


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_bag_says_jazzy_everywhere_it_keeps_its_metadata(tmp_path: Path, storage: str) -> None:
    out = tmp_path / "bag"
    BagRecorder(NoNode(), out, [parse_topic("/x")], storage=storage, log=print).close()
    with Reader(out) as reader:
        assert reader.ros_distro == "jazzy"
    (data,) = out.glob("*.mcap" if storage == "mcap" else "*.db3")
    if storage == "mcap":  # the metadata record outside the (compressed) chunks
        assert b"ros_distro: jazzy" in data.read_bytes()
        assert b"rosbags" not in data.read_bytes().split(b"serialized_metadata")[1]
    else:
        with sqlite3.connect(data) as con:
            assert con.execute("SELECT ros_distro FROM schema").fetchall() == [("jazzy",)]
            (stored,) = con.execute("SELECT metadata FROM metadata").fetchone()
        con.close()
        assert yaml.safe_load(stored)["ros_distro"] == "jazzy"


def test_parse_topic() -> None:
    assert parse_topic("/a/b").msgtype is None
    assert parse_topic("/a:std_msgs/msg/Float64").msgtype == "std_msgs/msg/Float64"
    with pytest.raises(RecordError, match="absolute name"):
        parse_topic("a/b")
    with pytest.raises(RecordError, match="pkg/msg/Name"):
        parse_topic("/a:Float64")


def test_record_refuses_an_existing_bag(tmp_path: Path) -> None:
    (tmp_path / "bag").mkdir()
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "ballscrew_twin.cli",
            "record",
            "--out",
            str(tmp_path / "bag"),
            "/x",
            "--duration",
            "0.1",
        ],
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
        stdin=subprocess.DEVNULL,
    )
    assert result.returncode == 2
    assert "exists already" in result.stderr


def test_a_shutdown_just_before_the_wait_still_closes_the_bag(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """SIGINT shuts the context down between the loop's ``context.ok()`` and the executor's
    wait (rclpy then raises RCLError building the wait set): a clean stop all the same."""
    from rclpy.executors import SingleThreadedExecutor

    from ballscrew_twin.cli import main

    original = SingleThreadedExecutor.spin_once

    def shut_down_then_wait(self: SingleThreadedExecutor, timeout_sec: float) -> None:
        rclpy.try_shutdown(context=self.context)  # what rclpy's SIGINT handler does
        original(self, timeout_sec=timeout_sec)

    monkeypatch.setattr(SingleThreadedExecutor, "spin_once", shut_down_then_wait)
    out = tmp_path / "bag"
    assert main(["record", "--out", str(out), "/x:std_msgs/msg/Float64"]) == 0
    assert "record: wrote" in capsys.readouterr().out
    with Reader(out) as reader:  # closed and valid
        assert (reader.message_count, reader.ros_distro) == (0, "jazzy")


@pytest.mark.parametrize("duration", [0.0, -1.0, math.nan])
def test_a_duration_that_is_not_a_time_is_refused(duration: float) -> None:
    with pytest.raises(RecordError, match=r"--duration.*allowed range \(0, inf\] s"):
        record_run(argparse.Namespace(duration=duration))
