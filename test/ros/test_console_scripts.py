"""The installed console scripts start, accept --ros-args and stop cleanly."""

from __future__ import annotations

import os
import select
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(sys.executable).parent
#: Longest a started process may take to log its start-up or to exit [s].
TIMEOUT = 30.0


def _script(name: str) -> str:
    path = BIN / name
    if path.exists():
        return str(path)
    found = shutil.which(name)
    if found is None:
        pytest.fail(f"console script {name} not installed (run `make setup`)")
    return found


def _env() -> dict[str, str]:
    env = dict(os.environ)  # ROS_DOMAIN_ID / discovery range set by test/conftest.py
    env["RCUTILS_LOGGING_BUFFERED_STREAM"] = "1"
    return env


def _finished(args: list[str]) -> subprocess.CompletedProcess[str]:
    """``args`` run to their end with no input, on this test's ROS domain; output captured."""
    return subprocess.run(
        args,
        capture_output=True,
        text=True,
        env=_env(),
        timeout=TIMEOUT,
        stdin=subprocess.DEVNULL,
    )


@pytest.mark.parametrize(
    "name", ["twin_node", "health_node", "twin_demo_commander", "ballscrew-twin"]
)
def test_scripts_on_venv_path(name: str) -> None:
    assert Path(_script(name)).is_file()


@pytest.mark.parametrize(
    ("name", "said"), [("twin_node", "model"), ("health_node", "monitoring /bench/torque")]
)
def test_node_runs_with_params_file_and_stops_on_sigint(name: str, said: str) -> None:
    params = str(ROOT / f"config/{name}.yaml")
    proc = subprocess.Popen(
        [_script(name), "--ros-args", "--params-file", params],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=_env(),
        stdin=subprocess.DEVNULL,
    )
    try:
        assert proc.stdout is not None
        deadline = time.monotonic() + TIMEOUT
        started = ""
        while (remaining := deadline - time.monotonic()) > 0:
            # Wait for output with a deadline, so a silent, hung process cannot block the test.
            ready, _, _ = select.select([proc.stdout], [], [], remaining)
            if not ready:
                break
            line = proc.stdout.readline()
            if not line:
                break
            if "publishing" in line:
                started = line
                break
        assert said in started, f"no start-up line from {name}: {started!r}"
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=TIMEOUT) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=TIMEOUT)


@pytest.mark.parametrize("command", [["twin_node"], ["ballscrew-twin", "node"]])
def test_node_refuses_out_of_range_parameter(command: list[str]) -> None:
    result = _finished(
        [_script(command[0]), *command[1:], "--ros-args", "-p", "sim_rate_hz:=5000.0"]
    )
    assert result.returncode == 1
    assert "sim_rate_hz" in result.stderr


@pytest.mark.parametrize(
    ("parameter", "named"),
    [("torque_type:=Twist", "torque_type"), ("stale_after:=100.0", "stale_after")],
)
def test_health_node_refuses_a_bad_parameter(parameter: str, named: str) -> None:
    result = _finished([_script("health_node"), "--ros-args", "-p", parameter])
    assert result.returncode == 1
    assert named in result.stderr and "Traceback" not in result.stderr


def test_node_refuses_unreadable_params_file(tmp_path: Path) -> None:
    result = _finished(
        [_script("ballscrew-twin"), "node", "--params-file", str(tmp_path / "missing.yaml")]
    )
    assert result.returncode == 1
    assert "missing.yaml" in result.stderr and "Traceback" not in result.stderr


def test_node_command_passes_ros_arguments_on() -> None:
    import argparse

    from ballscrew_twin.ros import node_command
    from ballscrew_twin.ros.command_args import ros_argv

    parser = argparse.ArgumentParser()
    node_command.add_arguments(parser)
    args = parser.parse_args(["--params-file", "p.yaml", "--ros-args", "-p", "a:=1"])
    assert ros_argv("prog", args) == ["prog", "--ros-args", "--params-file", "p.yaml", "-p", "a:=1"]
    assert ros_argv("prog", parser.parse_args([])) == ["prog"]
