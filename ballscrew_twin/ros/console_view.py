"""Console view of a running twin: torque, fidelity, real-time factor and health once a second.

Subscribes ``drag_torque`` (ballscrew_twin_msgs/DragTorque), ``/diagnostics`` (the twin node's
real-time and input checks) and, when some node publishes it, ``health``
(ballscrew_twin_msgs/HealthResidual; "n/a" otherwise). After ``--duration`` seconds it prints a
summary and writes a PNG plot of torque and operating point over time, then exits 0 if torque
arrived, 1 otherwise. The duration counts from the first torque message (the twin node may
take seconds to start). The plot shows the drag torque with its split between the master and
the slave nut, and marks every command the twin node rejected: the node reports rejections in
its ``input ...`` diagnostics, so a mark stands at the diagnostic that reported it, at most one
diagnostics period (1 s by default) after the command.

Run: ``python -m ballscrew_twin.ros.console_view --duration 20 [--ros-args ...]``.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import rclpy
from ballscrew_twin_msgs.msg import DragTorque, HealthResidual
from diagnostic_msgs.msg import DiagnosticArray
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from rclpy.executors import Executor, ExternalShutdownException
from rclpy.node import Node
from rclpy.utilities import remove_ros_args

from ..units import RPM, stamp_to_seconds
from .command_args import check_duration
from .diagnostics import LEVEL_NAMES, level_of
from .executors import make_executor, spin

#: Longest wait for the first torque message [s].
STARTUP_TIMEOUT = 60.0
#: Interval between two printed lines [s].
PRINT_PERIOD = 1.0
#: A health residual older than this is shown as "n/a" [s].
HEALTH_STALE = 3.0
VERDICTS = ("OK", "WARN", "FAULT", "UNKNOWN")


@dataclass
class Series:
    """Received torque samples (one per message) for the summary and the plot."""

    time: list[float] = field(default_factory=list)  # s since the first message (stamps)
    torque: list[float] = field(default_factory=list)  # N m
    nut_master: list[float] = field(default_factory=list)  # N m
    nut_slave: list[float] = field(default_factory=list)  # N m
    speed: list[float] = field(default_factory=list)  # rad/s
    temperature: list[float] = field(default_factory=list)  # deg C (DragTorque's convention)
    preload: list[float] = field(default_factory=list)  # N
    fidelity: list[str] = field(default_factory=list)


@dataclass(frozen=True)
class Rejection:
    """Commands of one input the twin node rejected, as a diagnostic reported them.

    Attributes:
        time: twin time of the reporting diagnostic [s] (same origin as :class:`Series`).
        channel: the input (``screw_speed``, ``preload``, ...).
        count: commands rejected since the previous report [-].
        reason: the last rejection's reason.
    """

    time: float
    channel: str
    count: int
    reason: str


class ConsoleView(Node):
    """Collects what the twin publishes and prints a status line once a second.

    Args:
        torque_topic, health_topic: topics to subscribe.
    """

    def __init__(
        self, torque_topic: str = "drag_torque", health_topic: str = "health", **kw: Any
    ) -> None:
        super().__init__("twin_console_view", **kw)
        #: When the first torque arrived (the view's run starts then).
        self.start: float | None = None
        self.created = time.monotonic()
        self.series = Series()
        self.latest: DragTorque | None = None
        self.real_time: dict[str, str] = {}
        self.real_time_level = "n/a"
        self.warnings: dict[str, str] = {}
        self.health: HealthResidual | None = None
        self.health_at = -math.inf
        self.rejections: list[Rejection] = []
        self._rejected_so_far: dict[str, int] = {}
        self._first_stamp: float | None = None
        self._count_at_print = 0
        self.create_subscription(DragTorque, torque_topic, self._on_torque, 100)
        self.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics, 10)
        self.create_subscription(HealthResidual, health_topic, self._on_health, 10)
        self.create_timer(PRINT_PERIOD, self.print_status)

    def elapsed(self) -> float:
        """Time since the first torque arrived [s] (0 before)."""
        return 0.0 if self.start is None else time.monotonic() - self.start

    def waited(self) -> float:
        """Time spent waiting for the first torque so far [s] (0 once it arrived)."""
        return time.monotonic() - self.created if self.start is None else 0.0

    def _on_torque(self, msg: DragTorque) -> None:
        stamp = stamp_to_seconds(msg.header.stamp)
        if self._first_stamp is None:
            self._first_stamp = stamp
            self.start = time.monotonic()
        s = self.series
        s.time.append(stamp - self._first_stamp)
        s.torque.append(msg.total)
        s.nut_master.append(msg.nut_master)
        s.nut_slave.append(msg.nut_slave)
        s.speed.append(msg.screw_speed)
        s.temperature.append(msg.temperature)
        s.preload.append(msg.preload)
        s.fidelity.append(msg.fidelity)
        self.latest = msg

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        stamp = stamp_to_seconds(msg.header.stamp)
        for status in msg.status:
            self._note_rejections(status, stamp)
            level = LEVEL_NAMES[min(level_of(status), 3)]
            if status.name.endswith(": real time"):
                self.real_time = {kv.key: kv.value for kv in status.values}
                self.real_time_level = level
            if level != "OK":
                self.warnings[status.name] = f"{level} {status.message}"
            else:
                self.warnings.pop(status.name, None)

    def _note_rejections(self, status: Any, stamp: float) -> None:
        """Record the commands an ``input ...`` status counts as rejected since its last report."""
        _, sep, channel = status.name.partition(": input ")
        if not sep:
            return
        values = {kv.key: kv.value for kv in status.values}
        try:
            rejected = int(values.get("rejected", "0"))
        except ValueError:
            return
        new = rejected - self._rejected_so_far.get(status.name, 0)
        self._rejected_so_far[status.name] = rejected
        if new > 0:
            origin = stamp if self._first_stamp is None else self._first_stamp
            reason = values.get("last rejection", "")
            self.rejections.append(Rejection(stamp - origin, channel, new, reason))

    def _on_health(self, msg: HealthResidual) -> None:
        self.health = msg
        self.health_at = time.monotonic()

    def health_text(self) -> str:
        """The latest health verdict, or "n/a" when no health monitor publishes."""
        msg = self.health
        if msg is None or time.monotonic() - self.health_at > HEALTH_STALE:
            return "n/a"
        verdict = VERDICTS[msg.verdict] if msg.verdict < len(VERDICTS) else str(msg.verdict)
        return f"{verdict} (residual {msg.normalized_residual:+.2f} sigma)"

    def print_status(self) -> None:
        """Print one status line (and the diagnostics that are not OK)."""
        count = len(self.series.torque)
        rate = (count - self._count_at_print) / PRINT_PERIOD
        self._count_at_print = count
        msg = self.latest
        if msg is None:
            print(f"t={self.elapsed():5.1f} s  waiting for drag_torque ...", flush=True)
            return
        rtf = self.real_time.get("real-time factor (step / compute) [-]", "n/a")
        on_time = self.real_time.get("on time within 1 ms [-]", "n/a")
        print(
            f"t={self.elapsed():5.1f} s  {msg.screw_speed / RPM:7.1f} rpm  "
            f"{msg.temperature:5.1f} C  {msg.preload:6.0f} N  "
            f"torque {msg.total * 1e3:8.3f} mN m  [{msg.fidelity}]  {rate:5.0f} msg/s  "
            f"rtf {rtf}  on time {on_time} ({self.real_time_level})  "
            f"health {self.health_text()}",
            flush=True,
        )
        for name, text in sorted(self.warnings.items()):
            print(f"          {name}: {text}", flush=True)
        self.warnings.clear()

    def summary(self) -> str:
        """Summary of the run (torque range, rate, models seen)."""
        s = self.series
        if not s.torque:
            return "no drag_torque message received"
        torque = np.asarray(s.torque)
        span = s.time[-1] - s.time[0] if len(s.time) > 1 else 0.0
        models = sorted(set(s.fidelity))
        rejected = sum(r.count for r in self.rejections)
        return (
            f"{len(torque)} drag_torque messages over {span:.2f} s of twin time "
            f"({len(torque) / max(span, 1e-9):.0f}/s); torque {torque.min() * 1e3:.3f} .. "
            f"{torque.max() * 1e3:.3f} mN m; models {', '.join(models)}; "
            f"{rejected} command(s) rejected; health {self.health_text()}"
        )

    def plot(self, path: Path) -> Path:
        """Torque (total and per nut), operating point and rejected commands over twin time,
        PNG at ``path``."""
        s = self.series
        fig = Figure(figsize=(9, 8), layout="constrained")
        axes = fig.subplots(4, 1, sharex=True)
        t = np.asarray(s.time)
        torque_ax = axes[0]
        for torques, label, style in (
            (s.torque, "total", "k-"),
            (s.nut_master, "master nut", "C0-"),
            (s.nut_slave, "slave nut", "C1--"),
        ):
            torque_ax.plot(t, np.asarray(torques) * 1e3, style, lw=1.0, label=label)
        rows = (
            (np.asarray(s.speed) / RPM, "speed [rpm]"),
            (np.asarray(s.temperature), "temperature [°C]"),
            (np.asarray(s.preload), "preload [N]"),
        )
        for ax, (values, label) in zip(axes[1:], rows, strict=True):
            ax.plot(t, values, lw=1.0)
            ax.set_ylabel(label)
        torque_ax.set_ylabel("drag torque [mN m]")
        middle = 0.5 * (t[0] + t[-1]) if len(t) else 0.0
        for k, rejection in enumerate(self.rejections):
            for ax in axes:
                ax.axvline(rejection.time, color="r", ls=":", lw=1.2)
            torque_ax.annotate(
                f" rejected: {rejection.reason[:40]} ",
                (rejection.time, 1.0 - 0.1 * (k % 3)),
                xycoords=("data", "axes fraction"),
                va="top",
                ha="right" if rejection.time > middle else "left",
                fontsize="x-small",
                color="r",
            )
        if self.rejections:
            torque_ax.plot([], [], "r:", label="command rejected (reported at)")
        torque_ax.legend(loc="lower right", fontsize="small")
        for ax in axes:
            ax.grid(True, alpha=0.3)
        axes[0].set_title("ballscrew twin: drag torque published by the twin node")
        axes[-1].set_xlabel("twin time [s]")
        path.parent.mkdir(parents=True, exist_ok=True)
        FigureCanvasAgg(fig)
        fig.savefig(path, dpi=110)
        return path


def main(args: list[str] | None = None) -> None:
    """``python -m ballscrew_twin.ros.console_view [--duration S] [--plot PNG] [--ros-args]``."""
    argv = sys.argv if args is None else args
    parser = argparse.ArgumentParser(prog="twin_console_view", description=__doc__)
    parser.add_argument("--duration", type=float, default=20.0, help="run length [s]")
    parser.add_argument("--plot", default="out/demo/twin_demo.png", help="PNG written at the end")
    parser.add_argument("--torque-topic", default="drag_torque")
    parser.add_argument("--health-topic", default="health", help="HealthResidual topic")
    opts = parser.parse_args(remove_ros_args(argv)[1:])
    check_duration(parser, opts.duration)
    rclpy.init(args=argv)
    node: ConsoleView | None = None
    executor: Executor | None = None
    try:
        node = ConsoleView(opts.torque_topic, opts.health_topic)
        # The events executor: this view receives every drag_torque (1 kHz) on the machine
        # the twin runs on; rclpy's SingleThreadedExecutor costs several times its CPU.
        executor = make_executor("events", node.context)
        executor.add_node(node)
        view = node
        spin(
            executor,
            until=lambda: view.elapsed() >= opts.duration or view.waited() >= STARTUP_TIMEOUT,
        )
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        received = 0
        if node is not None:
            received = len(node.series.torque)
            print(f"summary: {node.summary()}", flush=True)
            if received:
                print(f"plot: {node.plot(Path(opts.plot))}", flush=True)
            if executor is not None:
                executor.remove_node(node)
            node.destroy_node()
        if executor is not None:
            executor.shutdown()
        rclpy.try_shutdown()
    raise SystemExit(0 if received else 1)


if __name__ == "__main__":
    main()
