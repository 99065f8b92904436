"""Record on loopback: what ``replay`` publishes, ``record`` writes back, message for message."""

from __future__ import annotations

import os
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import rclpy
from rclpy.context import Context

from ballscrew_twin.health.bags import open_raw_bag
from ballscrew_twin.ros.record import RecordError, parse_topic
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
