"""``detect`` and ``bench-data info`` on bad input (issue 13): one clear line, never a traceback.

The bags are made by hand, so the reason each should give is known from how it was built.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from bags.test_bench_bags import (
    JOINT,
    T0,
    TEMPERATURE,
    WRENCH,
    Entry,
    T,
    _header,
    _joint,
    _wrench,
    _write,
)

from ballscrew_twin.cli import main

#: Torque and speed period of the hand-made bags [ns] (100 Hz); slow channels at 10 Hz.
FAST = 10_000_000
SLOW = 100_000_000


def _bench(
    duration: float, speed: float = 10.0, slow_from: float = 0.0, turning_until: float = 1e9
) -> list[Entry]:
    """Torque and joint states over [0, duration) s, temperature and preload over
    [slow_from, slow_from + duration) s; the screw turns at ``speed`` [rad/s] until
    ``turning_until`` [s], then stands."""
    out: list[Entry] = []
    for ns in range(0, int(duration * 1e9), FAST):
        w = speed if ns * 1e-9 < turning_until else 0.0
        out.append(("/bench/torque", WRENCH, T0 + ns, _wrench(T0 + ns, torque=0.02)))
        out.append(("/bench/joint_states", JOINT, T0 + ns, _joint(T0 + ns, w, 0.0)))
    for ns in range(int(slow_from * 1e9), int((slow_from + duration) * 1e9), SLOW):
        temp = T[TEMPERATURE](header=_header(T0 + ns), temperature=20.0, variance=0.0025)
        out.append(("/bench/temperature", TEMPERATURE, T0 + ns, temp))
        out.append(("/bench/preload", WRENCH, T0 + ns, _wrench(T0 + ns, force=1500.0)))
    return sorted(out, key=lambda e: e[2])


def _detect(bag: Path, out: Path, *extra: str) -> tuple[int, dict[str, object]]:
    code = main(["detect", str(bag), "--out", str(out), "--no-plots", *extra])
    verdict = json.loads((out / "verdict.json").read_text()) if code != 2 else {}
    return code, verdict


@pytest.mark.parametrize(
    ("bench", "reason"),
    [
        ({"duration": 2.0, "speed": 0.0}, "all blocks at standstill"),
        ({"duration": 1.0, "slow_from": 2.0}, "no overlapping channels"),
        ({"duration": 2.0}, "warm-up (5 s) longer than the 1.9"),
        ({"duration": 7.0, "turning_until": 1.0}, "the screw turns only within the warm-up"),
    ],
)
def test_nothing_comparable_says_why(
    bench: dict[str, float], reason: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bag = _write(tmp_path / "bag", _bench(**bench))
    code, verdict = _detect(bag, tmp_path / "out")
    assert code == 0
    assert verdict["verdict"] == "UNKNOWN"
    assert reason in str(verdict["unknown_reason"])
    printed = capsys.readouterr().out.splitlines()
    assert f"UNKNOWN: {verdict['unknown_reason']}" in printed


def test_a_comparable_bag_has_no_unknown_reason(tmp_path: Path) -> None:
    bag = _write(tmp_path / "bag", _bench(duration=6.0))
    code, verdict = _detect(bag, tmp_path / "out", "--warmup", "1")
    assert code in (0, 1) and verdict["verdict"] != "UNKNOWN"
    assert "unknown_reason" not in verdict


def test_a_joint_not_in_the_bag_is_one_line_naming_the_joints(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bag = _write(tmp_path / "bag", _bench(duration=1.0))
    code, _ = _detect(bag, tmp_path / "out", "--joint", "motor")
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert "joint 'motor' is not in /bench/joint_states; joints found: ['screw']" in err[0]


@pytest.mark.parametrize("command", ["detect", "bench-data info"])
def test_metadata_not_utf8_is_a_note_not_a_traceback(
    command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bag = _write(tmp_path / "bag", _bench(duration=1.0))
    meta = bag / "metadata.yaml"
    meta.write_bytes(meta.read_bytes().replace(b"ros_distro", b"ros\xe9distro", 1))
    out = ["--out", str(tmp_path / "out"), "--no-plots"] if command == "detect" else []
    code = main([*command.split(), str(bag), *out])
    assert code == 0
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err and "error" not in captured.err
    assert f"{meta}: not UTF-8 (byte 0xe9 at offset" in captured.out
    if command == "bench-data info":  # every message read: 100 torque samples over 0.99 s
        assert "mcap, 0.990 s" in captured.out and " 100 samples" in captured.out
