"""``ballscrew-twin launch FILE``: start several nodes from a YAML launch file, stop them cleanly.

The ROS launch system is not available from PyPI; this is the small part of it the project
needs. A launch file lists processes::

    stop_timeout: 5.0                 # s a process gets to exit after SIGINT, then SIGKILL
    nodes:
      - name: twin                    # prefix of its output lines
        executable: twin_node         # console script (the environment's bin/, then PATH) ...
        params_file: ../twin_node.yaml  # -> --ros-args --params-file (relative to this file)
        ros_args: [-p, "sim_rate_hz:=1000.0"]
      - name: view
        module: ballscrew_twin.ros.console_view   # ... or a module run with this Python
        args: [--duration, "${DEMO_DURATION:-20}"]
        env: {RCUTILS_LOGGING_BUFFERED_STREAM: "1"}
        required: true                # its exit ends the launch

``${NAME}`` and ``${NAME:-default}`` in ``args``, ``ros_args`` and ``env`` values are taken
from the environment. Every output line is forwarded with a ``[name]`` prefix. Ctrl-C or
SIGTERM stops all processes (SIGINT, then SIGKILL after ``stop_timeout``), in reverse order.
The launch ends when a ``required`` process exits or all have exited; the exit code is 0 when
every process exited cleanly, 1 when one died (non-zero exit) or had to be killed, 2 when the
launch file is invalid.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import FrameType
from typing import IO, Any

from ..errors import ConfigError
from ..params import check_number, limits, read_yaml

#: Default time a process gets to exit after SIGINT before it is killed [s].
STOP_TIMEOUT = 5.0
#: Allowed stop timeouts [s].
STOP_TIMEOUT_LIMITS = limits("s", 0.0, 600.0, lo_open=True)
#: Polling interval of the supervising loop [s].
POLL = 0.05
#: Exit codes of a process that stopped because it was asked to (SIGINT/SIGTERM).
CLEAN_STOP_CODES = (0, -signal.SIGINT, -signal.SIGTERM, 128 + signal.SIGINT)
_VARIABLE = re.compile(r"\$\{([A-Za-z_][A-Za-z0-9_]*)(?::-([^}]*))?\}")


def expand(text: str, env: Mapping[str, str]) -> str:
    """Replace ``${NAME}`` / ``${NAME:-default}`` in ``text`` from ``env``.

    Raises:
        ConfigError: a variable without default is not set.
    """

    def replace(match: re.Match[str]) -> str:
        name, default = match.group(1), match.group(2)
        if name in env:
            return env[name]
        if default is None:
            raise ConfigError(f"environment variable {name} is not set (use ${{{name}:-value}})")
        return default

    return _VARIABLE.sub(replace, text)


@dataclass(frozen=True)
class LaunchNode:
    """One process of a launch file.

    Attributes:
        name: prefix of its output lines, unique in the file.
        command: argument vector, program first.
        env: extra environment variables.
        required: its exit ends the launch.
    """

    name: str
    command: tuple[str, ...]
    env: tuple[tuple[str, str], ...] = field(default_factory=tuple)
    required: bool = False


@dataclass(frozen=True)
class LaunchFile:
    """A parsed launch file: its processes and the stop timeout [s]."""

    nodes: tuple[LaunchNode, ...]
    stop_timeout: float = STOP_TIMEOUT


def _strings(value: Any, where: str) -> list[str]:
    """A list of strings (numbers are accepted and converted)."""
    if value is None:
        return []
    if not isinstance(value, list) or not all(isinstance(v, str | int | float) for v in value):
        raise ConfigError(f"{where} must be a list of strings, got {value!r}")
    return [str(v) for v in value]


def resolve_executable(name: str) -> str:
    """Path of a program: as given if it contains a slash, else the environment's bin/ or PATH."""
    if os.sep in name:
        return name
    local = Path(sys.executable).parent / name
    if local.is_file():
        return str(local)
    found = shutil.which(name)
    if found is None:
        raise ConfigError(f"executable {name!r} not found in {local.parent} or on PATH")
    return found


def _node(entry: Any, where: str, base: Path, env: Mapping[str, str]) -> LaunchNode:
    """One ``nodes`` entry of a launch file (errors name ``where``)."""
    try:
        return _parse_node(entry, where, base, env)
    except ConfigError as err:
        if str(err).startswith(where):
            raise
        raise ConfigError(f"{where}: {err}") from err


def _parse_node(entry: Any, where: str, base: Path, env: Mapping[str, str]) -> LaunchNode:
    """One ``nodes`` entry of a launch file."""
    known = {"name", "executable", "module", "args", "params_file", "ros_args", "env", "required"}
    if not isinstance(entry, dict):
        raise ConfigError(f"{where} must be a mapping, got {entry!r}")
    unknown = set(entry) - known
    if unknown:
        raise ConfigError(f"{where}: unknown keys {sorted(unknown)} (known: {sorted(known)})")
    name = entry.get("name")
    if not isinstance(name, str) or not name:
        raise ConfigError(f"{where}.name must be a non-empty string, got {name!r}")
    executable, module = entry.get("executable"), entry.get("module")
    if (executable is None) == (module is None):
        raise ConfigError(f"{where}: give exactly one of 'executable' and 'module'")
    if executable is not None:
        command = [resolve_executable(str(executable))]
    else:
        command = [sys.executable, "-m", str(module)]
    command += [expand(a, env) for a in _strings(entry.get("args"), f"{where}.args")]
    ros = [expand(a, env) for a in _strings(entry.get("ros_args"), f"{where}.ros_args")]
    params_file = entry.get("params_file")
    if params_file is not None:
        path = (base / expand(str(params_file), env)).resolve()
        if not path.is_file():
            raise ConfigError(f"{where}.params_file: {path} does not exist")
        ros = ["--params-file", str(path), *ros]
    if ros:
        command += ["--ros-args", *ros]
    extra = entry.get("env") or {}
    if not isinstance(extra, dict):
        raise ConfigError(f"{where}.env must be a mapping, got {extra!r}")
    required = entry.get("required", False)
    if not isinstance(required, bool):
        raise ConfigError(f"{where}.required must be true or false, got {required!r}")
    return LaunchNode(
        name=name,
        command=tuple(command),
        env=tuple((str(k), expand(str(v), env)) for k, v in extra.items()),
        required=required,
    )


def load_launch_file(path: str | Path, env: Mapping[str, str] | None = None) -> LaunchFile:
    """Read and check a launch file; paths in it are relative to its directory.

    Raises:
        ConfigError: naming the file and the entry that is wrong.
    """
    file = Path(path)
    data = read_yaml(file, "launch file")
    environment = os.environ if env is None else env
    if not isinstance(data, dict) or not isinstance(data.get("nodes"), list) or not data["nodes"]:
        raise ConfigError(f"{file}: needs a non-empty list 'nodes'")
    unknown = set(data) - {"nodes", "stop_timeout"}
    if unknown:
        raise ConfigError(f"{file}: unknown keys {sorted(unknown)}")
    timeout = check_number(
        data.get("stop_timeout", STOP_TIMEOUT),
        STOP_TIMEOUT_LIMITS,
        f"{file}: stop_timeout",
        text=False,
    )
    base = file.resolve().parent
    nodes = tuple(
        _node(entry, f"{file}: nodes[{i}]", base, environment)
        for i, entry in enumerate(data["nodes"])
    )
    names = [n.name for n in nodes]
    if len(set(names)) != len(names):
        raise ConfigError(f"{file}: node names must be unique, got {names}")
    return LaunchFile(nodes=nodes, stop_timeout=float(timeout))


class Launcher:
    """Runs the processes of a :class:`LaunchFile` and supervises them.

    Args:
        launch: what to run.
        out: where the prefixed output lines go.
    """

    def __init__(self, launch: LaunchFile, out: IO[str] | None = None) -> None:
        self.launch = launch
        self.out = out if out is not None else sys.stdout
        self.processes: dict[str, subprocess.Popen[str]] = {}
        self._lock = threading.Lock()
        self._threads: list[threading.Thread] = []
        self._stop_requested = threading.Event()
        self.failures: list[str] = []

    def say(self, name: str, line: str) -> None:
        """Write one prefixed line."""
        with self._lock:
            self.out.write(f"[{name}] {line.rstrip()}\n")
            self.out.flush()

    def _forward(self, name: str, stream: IO[str]) -> None:
        for line in stream:
            self.say(name, line)

    def start(self) -> None:
        """Start every process, in file order (each in a session of its own)."""
        for node in self.launch.nodes:
            env = dict(os.environ)
            env.update(node.env)
            env.setdefault("PYTHONUNBUFFERED", "1")
            env.setdefault("RCUTILS_LOGGING_BUFFERED_STREAM", "1")
            proc = subprocess.Popen(
                node.command,
                stdout=subprocess.PIPE,
                stderr=subprocess.STDOUT,
                stdin=subprocess.DEVNULL,
                text=True,
                env=env,
                start_new_session=True,  # a terminal's Ctrl-C reaches the launcher only
            )
            self.processes[node.name] = proc
            assert proc.stdout is not None
            thread = threading.Thread(target=self._forward, args=(node.name, proc.stdout))
            thread.daemon = True
            thread.start()
            self._threads.append(thread)
            self.say("launch", f"started {node.name} (pid {proc.pid}): {' '.join(node.command)}")

    def request_stop(self, signum: int = signal.SIGINT, _frame: FrameType | None = None) -> None:
        """Ask the supervising loop to stop everything (signal handler)."""
        self._stop_requested.set()

    def supervise(self) -> int:
        """Wait until a required process exits, all exit, one dies or a stop is requested;
        then stop the rest. Returns the launch's exit code."""
        required = {n.name for n in self.launch.nodes if n.required}
        reported: set[str] = set()
        while not self._stop_requested.is_set():
            finished = False
            for name, proc in self.processes.items():
                code = proc.poll()
                if code is None or name in reported:
                    continue
                reported.add(name)
                if code != 0:
                    self.failures.append(f"{name} died with exit code {code}")
                    self.say("launch", f"{name} died with exit code {code}: stopping the rest")
                    finished = True
                else:
                    self.say("launch", f"{name} finished")
                    finished = finished or name in required
            if finished or len(reported) == len(self.processes):
                break
            time.sleep(POLL)
        else:
            self.say("launch", "stop requested: stopping all processes")
        self.stop(exclude=reported)
        for thread in self._threads:
            thread.join(timeout=1.0)
        return 1 if self.failures else 0

    def stop(self, exclude: set[str] | None = None) -> None:
        """Stop the running processes, newest first: SIGINT, then SIGKILL after the timeout."""
        skip = exclude or set()
        running = [(n, p) for n, p in reversed(self.processes.items()) if p.poll() is None]
        for _, proc in running:
            proc.send_signal(signal.SIGINT)
        deadline = time.monotonic() + self.launch.stop_timeout
        for name, proc in running:
            try:
                code = proc.wait(timeout=max(deadline - time.monotonic(), 0.0))
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
                self.failures.append(f"{name} did not stop within {self.launch.stop_timeout:g} s")
                self.say(
                    "launch", f"{name} killed: no exit {self.launch.stop_timeout:g} s after SIGINT"
                )
                continue
            if name in skip:
                continue
            if code in CLEAN_STOP_CODES:
                self.say("launch", f"{name} stopped")
            else:
                self.failures.append(f"{name} exited with code {code} when stopped")
                self.say("launch", f"{name} exited with code {code} when stopped")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``launch``."""
    parser.add_argument("file", help="launch file (YAML), e.g. config/launch/demo.yaml")
    parser.add_argument(
        "--stop-timeout", type=float, default=None, help="override the file's stop_timeout [s]"
    )


def run(args: argparse.Namespace) -> int:
    """Run the launch file until it ends or Ctrl-C/SIGTERM; 0 clean, 1 a process failed."""
    launch = load_launch_file(args.file)
    if args.stop_timeout is not None:
        check_number(args.stop_timeout, STOP_TIMEOUT_LIMITS, "--stop-timeout", text=False)
        launch = LaunchFile(nodes=launch.nodes, stop_timeout=args.stop_timeout)
    launcher = Launcher(launch)
    previous = {s: signal.signal(s, launcher.request_stop) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        launcher.start()
        code = launcher.supervise()
    finally:
        launcher.stop()
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    for failure in launcher.failures:
        print(f"ballscrew-twin launch: {failure}", file=sys.stderr)
    return code
