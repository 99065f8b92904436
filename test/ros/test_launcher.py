"""The process launcher: starts processes, forwards their output, stops them cleanly."""

from __future__ import annotations

import argparse
import io
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import pytest

from ballscrew_twin.errors import ConfigError
from ballscrew_twin.ros.launcher import (
    Launcher,
    LaunchFile,
    LaunchNode,
    expand,
    load_launch_file,
    run,
)

#: A process that prints "ready", then waits; on SIGINT it prints "bye" and exits 0 (or the
#: code given as its argument, or never, with "stubborn"). With a second argument, a file: a
#: waiting process creates it once its SIGINT handler is in place, a dying one ("dieN") waits
#: for it before it exits, so that the launcher never stops a process still starting up (a
#: SIGINT before the handler ends it with the default action: a race on a loaded machine).
SLEEPER = textwrap.dedent("""
    import os, signal, sys, time
    mode = sys.argv[1] if len(sys.argv) > 1 else "0"
    flag = sys.argv[2] if len(sys.argv) > 2 else ""
    def stop(*_):
        print("bye", flush=True)
        sys.exit(int(mode))
    signal.signal(signal.SIGINT, signal.SIG_IGN if mode == "stubborn" else stop)
    print("ready", flush=True)
    if mode.startswith("die"):
        while flag and not os.path.exists(flag):
            time.sleep(0.01)
        sys.exit(int(mode[3:]))
    if flag:
        open(flag, "w").close()
    while True:
        time.sleep(0.05)
""")
TIMEOUT = 30.0


def _node(name: str, *args: str, required: bool = False) -> LaunchNode:
    return LaunchNode(name=name, command=(sys.executable, "-c", SLEEPER, *args), required=required)


class Output(io.StringIO):
    """Thread-safe enough for polling: the launcher writes under its own lock."""

    def wait_for(self, text: str, count: int = 1) -> None:
        deadline = time.monotonic() + TIMEOUT
        while self.getvalue().count(text) < count:
            assert time.monotonic() < deadline, f"{text!r} x{count} not in {self.getvalue()!r}"
            time.sleep(0.02)


def _run(
    nodes: tuple[LaunchNode, ...], *, stop_after_ready: bool, stop_timeout: float = 5.0
) -> tuple[int, Launcher, Output]:
    out = Output()
    launcher = Launcher(LaunchFile(nodes=nodes, stop_timeout=stop_timeout), out=out)
    launcher.start()
    try:
        if stop_after_ready:
            out.wait_for("] ready", len(nodes))
            threading.Timer(0.0, launcher.request_stop).start()
        code = launcher.supervise()
    finally:
        launcher.stop()
    return code, launcher, out


def test_starts_two_and_stops_them_cleanly() -> None:
    code, launcher, out = _run((_node("a"), _node("b")), stop_after_ready=True)
    assert code == 0, out.getvalue()
    text = out.getvalue()
    assert "[a] ready" in text and "[b] ready" in text  # forwarded with a prefix
    assert "[a] bye" in text and "[b] bye" in text  # both got SIGINT and exited themselves
    assert all(p.returncode == 0 for p in launcher.processes.values())


def test_a_dying_node_stops_the_rest_and_fails_the_launch(tmp_path: Path) -> None:
    flag = str(tmp_path / "ok-ready")
    code, launcher, out = _run(
        (_node("ok", "0", flag), _node("bad", "die3", flag)), stop_after_ready=False
    )
    assert code == 1
    assert "bad died with exit code 3" in out.getvalue()
    assert launcher.processes["ok"].returncode == 0  # stopped, not killed


def test_required_node_ending_ends_the_launch(tmp_path: Path) -> None:
    flag = str(tmp_path / "server-ready")
    code, launcher, _ = _run(
        (_node("server", "0", flag), _node("client", "die0", flag, required=True)),
        stop_after_ready=False,
    )
    assert code == 0
    assert launcher.processes["server"].returncode == 0


def test_stubborn_node_is_killed_after_the_timeout() -> None:
    code, launcher, _ = _run(
        (_node("stubborn", "stubborn"),), stop_after_ready=True, stop_timeout=0.5
    )
    assert code == 1
    assert launcher.processes["stubborn"].returncode == -signal.SIGKILL
    assert "did not stop" in " ".join(launcher.failures)


def test_launch_file_parsing(tmp_path: Path) -> None:
    params = tmp_path / "params.yaml"
    params.write_text("x:\n  ros__parameters: {}\n")
    file = tmp_path / "launch.yaml"
    file.write_text(
        textwrap.dedent(f"""
        stop_timeout: 2.5
        nodes:
          - name: one
            executable: {sys.executable}
            args: [--duration, "${{DUR:-7}}"]
            params_file: params.yaml
            ros_args: [-p, "a:=${{VALUE}}"]
            env: {{FOO: "${{VALUE}}"}}
          - name: two
            module: ballscrew_twin.ros.console_view
            required: true
    """)
    )
    launch = load_launch_file(file, env={"VALUE": "5"})
    one, two = launch.nodes
    assert launch.stop_timeout == 2.5
    assert one.command == (
        sys.executable,
        "--duration",
        "7",
        "--ros-args",
        "--params-file",
        str(params.resolve()),
        "-p",
        "a:=5",
    )
    assert one.env == (("FOO", "5"),) and not one.required
    assert two.command == (sys.executable, "-m", "ballscrew_twin.ros.console_view")
    assert two.required


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ("nodes: []", "non-empty list"),
        ("nodes: [{name: a}]", "exactly one of"),
        ("nodes: [{name: a, module: m, colour: red}]", "unknown keys"),
        ("nodes: [{name: a, module: m}, {name: a, module: m}]", "unique"),
        ("nodes: [{name: a, executable: no-such-program-here}]", "not found"),
        ("nodes: [{name: a, module: m, params_file: missing.yaml}]", "does not exist"),
        ("stop_timeout: -1\nnodes: [{name: a, module: m}]", "stop_timeout"),
        ("nodes: [{name: a, module: m, args: ['${UNSET_VARIABLE_X}']}]", "UNSET_VARIABLE_X"),
    ],
)
def test_bad_launch_files_name_the_problem(tmp_path: Path, body: str, message: str) -> None:
    file = tmp_path / "bad.yaml"
    file.write_text(body)
    with pytest.raises(ConfigError, match=message) as err:
        load_launch_file(file, env={})
    assert str(file) in str(err.value)


@pytest.mark.parametrize(
    ("timeout", "message"),
    [
        ("-1", "stop_timeout = -1 is outside the allowed range (0, 600] s (must not be negative)"),
        ("0", "stop_timeout = 0 is outside the allowed range (0, 600] s"),
        ("900", "stop_timeout = 900 is outside the allowed range (0, 600] s"),
        (".nan", "stop_timeout: nan is not a finite number (allowed range (0, 600] s)"),
        ("'5'", "stop_timeout: expected a number in s within (0, 600], got '5'"),
        ("true", "stop_timeout: expected a number in s within (0, 600], got True"),
    ],
)
def test_a_stop_timeout_out_of_range_is_refused_naming_it(
    tmp_path: Path, timeout: str, message: str
) -> None:
    """The launch file's and the command line's stop timeout go through the package's one
    number check: the refusal names the entry or option, the value, the unit and the range."""
    file = tmp_path / "launch.yaml"
    file.write_text(f"stop_timeout: {timeout}\nnodes: [{{name: a, module: m}}]\n")
    with pytest.raises(ConfigError) as err:
        load_launch_file(file, env={})
    assert str(err.value).startswith(f"{file}: {message}"), str(err.value)
    file.write_text("nodes: [{name: a, module: m}]\n")
    assert load_launch_file(file, env={}).stop_timeout == 5.0  # the default
    with pytest.raises(ConfigError) as err:
        run(argparse.Namespace(file=str(file), stop_timeout=-2.0))
    assert str(err.value) == (
        "--stop-timeout = -2.0 is outside the allowed range (0, 600] s (must not be negative)"
    )


def test_expand() -> None:
    assert expand("${A}-${B:-x}-$C", {"A": "1"}) == "1-x-$C"


def test_cli_stops_on_sigterm(tmp_path: Path) -> None:
    sleeper = tmp_path / "sleeper.py"
    sleeper.write_text(SLEEPER)
    file = tmp_path / "launch.yaml"
    file.write_text(
        textwrap.dedent(f"""
        nodes:
          - {{name: a, executable: {sys.executable}, args: [{sleeper}]}}
          - {{name: b, executable: {sys.executable}, args: [{sleeper}]}}
    """)
    )
    script = Path(sys.executable).parent / "ballscrew-twin"
    proc = subprocess.Popen(
        [str(script), "launch", str(file)],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        stdin=subprocess.DEVNULL,
        env=dict(os.environ),
    )
    try:
        assert proc.stdout is not None
        ready = 0
        deadline = time.monotonic() + TIMEOUT
        while ready < 2 and time.monotonic() < deadline:
            line = proc.stdout.readline()
            if not line:
                break
            ready += "] ready" in line
        assert ready == 2
        proc.send_signal(signal.SIGTERM)
        rest = proc.communicate(timeout=TIMEOUT)[0]
        assert proc.returncode == 0, rest
        assert "[a] bye" in rest and "[b] bye" in rest
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
