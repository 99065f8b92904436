"""``ballscrew-twin bench node``: the twin node in real time, printed, never asserted.

For each tick source (the node's tick thread, or the executor's timer) and each executor
(``SingleThreadedExecutor`` and rclpy's ``EventsExecutor``), one after the other in the same
run, the twin node runs in a process of its own at ``--rate`` (1 kHz) with contact states at
``--contact-rate`` (100 Hz), while this process publishes a varying speed command at
``--command-rate`` (100 Hz; a bench streaming its encoder speed runs at 1 kHz), temperature and
preload at up to 100 Hz, and counts what arrives. First, as the machine's floor, a process
with nothing but the tick thread's sleep loop (no ROS, no model) measures how late the operating
system wakes a thread that sleeps until each tick is due. ``--duration`` is split into
``--rounds`` interleaved rounds of every variant, so that a change of the shared machine's load
hits all of them alike. Measured after a warm-up in each round, over ``--duration`` seconds in
all:

- share of ticks published on time (within 1 ms of their due time; skipped ticks count as
  late), tick latency p50/p99/max (due time to publish returned, node clock = wall time);
- CPU share of one core of the node process (all its threads), the machine's load average
  and its steal share (time the hypervisor gave this virtual machine's cores to others);
- torque and contact-state messages received per second by another process: those whose
  header stamp lies in the node's measured window (the node's clock, wall time), counted after
  the window has closed and a grace of :data:`IN_FLIGHT` s for the messages still on their
  way. A count of what arrived while the window lasted would also take in the warm-up's
  messages that a loaded machine delivers late (a test counted 246 torque/s at 200 Hz).

Model: ``--fidelity``, by default the real-time model when it is installed, otherwise the
quasi-static steady model of every sphere at a constant command (solved once, then cached), so
that the per-sphere contact states (200 rows) are published at 100 Hz as they would be by the
real-time model. Writes a PNG of the latency distributions.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import multiprocessing
import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

import numpy as np
import psutil
from tqdm import tqdm

#: One-line help of this benchmark.
DESCRIPTION = "twin node in real time: ticks on time, latency, CPU, per tick source and executor"
EXECUTORS = ("single_threaded", "events")
TICK_SOURCES = ("thread", "executor")
#: Time the node runs before measuring (imports done, discovery settled) [s].
WARMUP = 3.0
ON_TIME_NS = 1_000_000
#: What the node process sends when its measurement starts.
MEASURING = "measuring"
#: Time the commander keeps receiving after the node's window closed [s].
IN_FLIGHT = 0.5
SPEED = 10.47  # rad/s (100 rpm)


@dataclass(frozen=True)
class NodeRun:
    """What one run of the node measured (latencies in ns)."""

    executor: str  # "<tick source>/<executor>", or "sleep loop" (the floor)
    model: str
    latencies: np.ndarray
    skipped: int
    cpu_share: float  # of one core, node process
    published: int
    contacts: int
    received_torque: int
    received_contacts: int
    duration: float  # s
    load_before: tuple[float, float, float]
    steal: float  # % of all cores' time stolen by the hypervisor during the run
    commander_cpu: float = 0.0  # of one core, this process (commands, counting)


def steal_share(before: Any, after: Any) -> float:
    """Stolen share of all cores' time between two ``psutil.cpu_times()`` readings [%].

    Steal is the time a hypervisor ran something else while this virtual machine's cores had
    work (the paravirtual steal clock, exact; 0 on bare metal). The busy share of the same
    counters is not reported: they are sampled at the timer tick, which a thread waking every
    millisecond aliases (a loop busy 17 % of all cores read as 0.5 %; docs/benchmarks.md).
    """
    delta = {k: getattr(after, k) - getattr(before, k) for k in after._fields}
    # guest time is already part of user time (proc(5), /proc/stat)
    total = sum(v for k, v in delta.items() if k not in ("guest", "guest_nice"))
    return 100.0 * delta.get("steal", 0.0) / total if total > 0.0 else 0.0


class StealMeter:
    """The stolen share of all cores between ``start()`` (or creation) and ``read()``."""

    def __init__(self) -> None:
        self._start = psutil.cpu_times()

    def start(self) -> None:
        """Begin the interval now."""
        self._start = psutil.cpu_times()

    def read(self) -> float:
        """Stolen share of all cores' time since the interval began [%]."""
        return steal_share(self._start, psutil.cpu_times())


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``bench node``."""
    parser.add_argument(
        "--duration",
        type=float,
        default=60.0,
        help="measured time per variant, split into --rounds [s]",
    )
    parser.add_argument("--rate", type=float, default=1000.0, help="simulation rate [Hz]")
    parser.add_argument("--contact-rate", type=float, default=100.0, help="contact states [Hz]")
    parser.add_argument(
        "--command-rate",
        type=float,
        default=100.0,
        help="speed commands [Hz] (each a new value; temperature and preload at <= 100 Hz)",
    )
    parser.add_argument(
        "--executors", default="events,single_threaded", help="comma-separated: events,..."
    )
    parser.add_argument(
        "--tick-sources", default="thread,executor", help="comma-separated: thread,executor"
    )
    parser.add_argument(
        "--priorities",
        default="0",
        help="comma-separated SCHED_FIFO priorities of the tick thread (node parameter "
        "thread_priority; 0: normal scheduling); each is a variant of the floor and of the "
        "thread tick source",
    )
    parser.add_argument(
        "--no-floor", action="store_true", help="skip the bare sleep loop (the machine's floor)"
    )
    parser.add_argument(
        "--rounds",
        type=int,
        default=6,
        help="split --duration into this many interleaved rounds of every variant",
    )
    parser.add_argument(
        "--fidelity",
        default="",
        choices=("", "realtime", "quasi_static", "catalog"),
        help="model (default: realtime if installed, else quasi_static of every sphere)",
    )
    parser.add_argument("--plot", default="out/bench/node_latency.png", help="PNG of latencies")


def _model_parameters(requested: str) -> dict[str, Any]:
    """Node parameters of the model benchmarked (see the module docstring)."""
    from ..params import load_config
    from ..ros.fidelity_modes import ModelSettings, unavailable

    if requested:
        return {"fidelity": requested, "steady_mode": "full"}
    if unavailable("realtime", ModelSettings(config=load_config(None))) is None:
        return {"fidelity": "realtime"}
    return {"fidelity": "quasi_static", "steady_mode": "full"}


def step_costs(count: int = 2000) -> dict[tuple[bool, bool], float]:
    """Median wall time of one real-time model step on a command it has not seen [s], keyed
    by (compiled interpolation, with contact states); the compiled and the numpy reference
    model are stepped alternately, so a change of the machine's load hits both alike."""
    from ..models.base import OperatingPoint
    from ..models.realtime import RealTimeModel
    from ..params import load_config

    config = load_config(None)
    models = {compiled: RealTimeModel(config, compiled=compiled) for compiled in (True, False)}
    times: dict[tuple[bool, bool], list[float]] = {
        (compiled, contacts): [] for compiled in (True, False) for contacts in (False, True)
    }
    for i in range(count):
        # A new speed each call: an unchanged command would return the cached output.
        speed = SPEED * (1.0 + 1e-5 * i)
        op = OperatingPoint(screw_speed=speed, temperature=293.15, preload=1500.0)
        for (compiled, contacts), samples in times.items():
            model = models[compiled]
            start = time.perf_counter()
            model.step(op, 1e-3, contacts=contacts)
            samples.append(time.perf_counter() - start)
    return {key: float(np.median(samples)) for key, samples in times.items()}


def _node_process(params: dict[str, Any], measure: float, conn: Connection) -> None:
    """Child process: run the twin node, send back what it measured."""
    import rclpy
    from rclpy.context import Context
    from rclpy.parameter import Parameter

    from ..ros.executors import make_executor, spin
    from ..ros.tick_thread import prepare_process
    from ..ros.twin_node import TwinNode

    context = Context()
    rclpy.init(context=context)
    overrides = [Parameter(k, value=v) for k, v in params.items()]
    node = TwinNode(context=context, parameter_overrides=overrides)
    executor = make_executor(str(params["executor"]), context)
    executor.add_node(node)
    prepare_process(int(params.get("thread_priority", 0)))  # as twin_node's main does
    start = time.monotonic()
    spin(executor, until=lambda: time.monotonic() - start > WARMUP)
    node.ticks.latency_log = []
    start_totals = dataclasses.replace(node.ticks.totals)
    conn.send(MEASURING)  # the commander counts received messages from here
    first_ns = node.get_clock().now().nanoseconds
    cpu0, wall0 = time.process_time(), time.monotonic()
    spin(executor, until=lambda: time.monotonic() - wall0 > measure)
    cpu, wall = time.process_time() - cpu0, time.monotonic() - wall0
    last_ns = node.get_clock().now().nanoseconds
    conn.send(
        {
            "model": node.models.choice.model.name,
            "tick_source": node.tick_source,
            "latencies": np.asarray(node.ticks.latency_log, dtype=np.int64),
            "skipped": node.ticks.totals.skipped - start_totals.skipped,
            "cpu_share": cpu / wall,
            "published": node.ticks.totals.published - start_totals.published,
            "contacts": node.ticks.totals.contacts - start_totals.contacts,
            "duration": wall,
            "window_ns": (first_ns, last_ns),
        }
    )
    executor.shutdown()
    node.destroy_node()
    rclpy.try_shutdown(context=context)


def _floor_process(rate: float, measure: float, priority: int, conn: Connection) -> None:
    """Child process: the tick thread's sleep loop alone; send back its wake-up lateness."""
    from ..ros.tick_thread import TickThread, prepare_process

    prepare_process()
    period_ns = round(1e9 / rate)
    latencies: list[int] = []
    done = threading.Event()
    origin = time.time_ns()
    grid = {"k": 0}
    # The measured grid points: those due in [WARMUP, WARMUP + measure) s after the origin,
    # each counted once however late the thread wakes around the window's edges (a wake-up
    # 180 ms late at a loaded edge once counted 36 points outside a 2 s window).
    first = math.ceil(WARMUP * 1e9 / period_ns)
    last = math.ceil((WARMUP + measure) * 1e9 / period_ns) - 1
    # Process CPU time and wall time when the measurement began [s] (empty: not yet).
    mark: list[float] = []

    def run_due() -> float | None:
        now = time.time_ns()
        due_index = (now - origin) // period_ns
        if due_index >= first:
            if not mark:
                mark.extend((time.process_time(), time.monotonic()))
                conn.send(MEASURING)  # the parent measures the machine from here
            # Every grid point of the window passed since the last wake-up, as the node would
            # run it late.
            latencies.extend(
                now - (origin + k * period_ns)
                for k in range(max(grid["k"], first), min(due_index, last) + 1)
            )
        if due_index >= last:
            done.set()
            return None
        grid["k"] = due_index + 1
        return (origin + grid["k"] * period_ns - time.time_ns()) / 1e9

    thread = TickThread(run_due, lambda err: None, priority=priority)
    thread.start()
    done.wait()
    thread.stop()
    cpu, wall = time.process_time() - mark[0], time.monotonic() - mark[1]
    conn.send(
        {
            "model": f"none; {thread.scheduling}",
            "latencies": np.asarray(latencies, dtype=np.int64),
            "cpu_share": cpu / wall,
            "duration": measure,
        }
    )


def _await_result(
    proc: multiprocessing.process.BaseProcess,
    conn: Connection,
    what: str,
    total: float,
    on_measuring: Callable[[], None],
) -> Any:
    """Show progress while the child process ``proc`` (``what``) runs for about ``total`` [s];
    call ``on_measuring()`` when it sends :data:`MEASURING`; return the result it sends next.

    Raises:
        RuntimeError: the child died before sending its result.
    """
    with tqdm(total=int(total), desc=f"bench node {what}", unit="s", leave=False) as bar:
        start = time.monotonic()
        while True:
            bar.update(min(int(time.monotonic() - start), bar.total) - bar.n)
            if conn.poll(0.25):
                message = conn.recv()
                if message != MEASURING:
                    return message
                on_measuring()
            elif not proc.is_alive():
                raise RuntimeError(f"{what}: its process died with exit code {proc.exitcode}")


def _run_floor(args: argparse.Namespace, priority: int, duration: float) -> NodeRun:
    """The bare sleep loop at ``args.rate`` for ``duration`` [s] with the tick thread's
    SCHED_FIFO ``priority`` (0: normal scheduling; see the module docstring)."""
    spawn = multiprocessing.get_context("spawn")
    parent_conn, child_conn = spawn.Pipe()
    proc = spawn.Process(target=_floor_process, args=(args.rate, duration, priority, child_conn))
    load_before = os.getloadavg()
    meter = StealMeter()
    proc.start()
    result = _await_result(proc, parent_conn, "sleep loop", WARMUP + duration, meter.start)
    steal = meter.read()
    proc.join(timeout=30.0)
    return NodeRun(
        executor="sleep loop" + (f"/fifo{priority}" if priority else ""),
        model=result["model"],
        latencies=result["latencies"],
        skipped=0,
        cpu_share=float(result["cpu_share"]),
        published=len(result["latencies"]),
        contacts=0,
        received_torque=0,
        received_contacts=0,
        duration=float(result["duration"]),
        load_before=load_before,
        steal=steal,
    )


def _run_one(
    tick_source: str, executor_name: str, priority: int, args: argparse.Namespace, duration: float
) -> NodeRun:
    """Run the node with one tick source, executor and tick-thread priority for ``duration``
    [s] while commanding it and counting what arrives."""
    import rclpy
    from ballscrew_twin_msgs.msg import ContactStateArray, DragTorque
    from rclpy.context import Context
    from rclpy.experimental import EventsExecutor
    from rclpy.node import Node
    from rclpy.qos import qos_profile_sensor_data
    from sensor_msgs.msg import Temperature
    from std_msgs.msg import Float64

    from ..ros.cdr import header_stamp_ns

    params: dict[str, Any] = {
        "executor": executor_name,
        "tick_source": tick_source,
        "thread_priority": priority,
        "sim_rate_hz": args.rate,
        "contact_rate_hz": args.contact_rate,
        "initial_screw_speed": SPEED,
        **_model_parameters(args.fidelity),
    }
    vary = params["fidelity"] != "quasi_static"  # a quasi-static command stays constant
    spawn = multiprocessing.get_context("spawn")
    parent_conn, child_conn = spawn.Pipe()
    proc = spawn.Process(target=_node_process, args=(params, duration, child_conn))
    proc.start()

    context = Context()
    rclpy.init(context=context)
    node = Node("bench_node_commander", context=context)
    stamps: dict[str, list[int]] = {"torque": [], "contacts": []}

    def counter(key: str) -> Any:
        def count(raw: bytes) -> None:
            stamps[key].append(header_stamp_ns(raw))

        return count

    # raw=True: counted as bytes, not deserialised (the counter must not load the machine)
    node.create_subscription(DragTorque, "drag_torque", counter("torque"), 100, raw=True)
    node.create_subscription(ContactStateArray, "contact_states", counter("contacts"), 10, raw=True)
    qos = qos_profile_sensor_data
    speed_pub = node.create_publisher(Float64, "speed_command", qos)
    temp_pub = node.create_publisher(Temperature, "temperature", qos)
    preload_pub = node.create_publisher(Float64, "preload_command", qos)

    # Temperature and preload with every speed command up to 100 Hz, then every n-th.
    every = max(round(args.command_rate / 100.0), 1)
    calls = [0]

    def command() -> None:
        t = time.monotonic()
        speed = SPEED * (1.0 + 0.5 * math.sin(t)) if vary else SPEED
        speed_pub.publish(Float64(data=speed))
        if calls[0] % every == 0:
            temp_pub.publish(Temperature(temperature=20.0))
            preload_pub.publish(Float64(data=1500.0))
        calls[0] += 1

    node.create_timer(1.0 / args.command_rate, command)
    # The events executor: this process receives ~1100 messages a second and must not load
    # the machine the node runs on (with SingleThreadedExecutor it took ~45 % of a core).
    executor = EventsExecutor(context=context)
    executor.add_node(node)
    load_before = os.getloadavg()
    meter = StealMeter()
    name = f"{tick_source}/{executor_name}" + (f"/fifo{priority}" if priority else "")
    # This process's CPU and wall time when the node's measurement began.
    marks = {"cpu": 0.0, "wall": 0.0}
    stop = threading.Event()

    def receive() -> None:  # the messages on a thread of their own, the pipe here
        while not stop.is_set():
            executor.spin_once(timeout_sec=0.1)

    receiver = threading.Thread(target=receive, daemon=True)
    receiver.start()

    def measuring() -> None:
        meter.start()
        marks.update(cpu=time.process_time(), wall=time.monotonic())

    result = _await_result(proc, parent_conn, name, WARMUP + duration, measuring)
    steal = meter.read()
    commander_cpu = (time.process_time() - marks["cpu"]) / max(
        time.monotonic() - marks["wall"], 1e-9
    )
    time.sleep(IN_FLIGHT)
    first_ns, last_ns = result["window_ns"]
    received = {
        key: sum(1 for t in list(times) if first_ns <= t <= last_ns)
        for key, times in stamps.items()
    }
    stop.set()
    receiver.join(timeout=5.0)
    proc.join(timeout=30.0)
    executor.shutdown()
    node.destroy_node()
    rclpy.try_shutdown(context=context)
    return NodeRun(
        executor=name,
        model=f"{result['model']}; ticks: {result['tick_source']}",
        latencies=result["latencies"],
        skipped=int(result["skipped"]),
        cpu_share=float(result["cpu_share"]),
        published=int(result["published"]),
        contacts=int(result["contacts"]),
        received_torque=received["torque"],
        received_contacts=received["contacts"],
        duration=float(result["duration"]),
        load_before=load_before,
        steal=steal,
        commander_cpu=commander_cpu,
    )


def merge(runs: list[NodeRun]) -> NodeRun:
    """The rounds ``runs`` of one variant as one run (counts and times added, CPU share
    weighted by duration, load before the first round, steal weighted by duration)."""
    duration = sum(r.duration for r in runs)
    return NodeRun(
        executor=runs[0].executor,
        model=runs[0].model,
        latencies=np.concatenate([r.latencies for r in runs]),
        skipped=sum(r.skipped for r in runs),
        cpu_share=sum(r.cpu_share * r.duration for r in runs) / duration,
        published=sum(r.published for r in runs),
        contacts=sum(r.contacts for r in runs),
        received_torque=sum(r.received_torque for r in runs),
        received_contacts=sum(r.received_contacts for r in runs),
        duration=duration,
        load_before=runs[0].load_before,
        steal=sum(r.steal * r.duration for r in runs) / duration,
        commander_cpu=sum(r.commander_cpu * r.duration for r in runs) / duration,
    )


def summary(run: NodeRun) -> dict[str, float]:
    """On-time share and latency percentiles of one run (latencies in ms)."""
    lat = run.latencies.astype(np.float64) * 1e-6
    due = len(lat) + run.skipped
    on_time = float(np.count_nonzero(run.latencies <= ON_TIME_NS)) / due if due else math.nan
    return {
        "on_time": on_time,
        "p50": float(np.percentile(lat, 50)) if lat.size else math.nan,
        "p99": float(np.percentile(lat, 99)) if lat.size else math.nan,
        "p999": float(np.percentile(lat, 99.9)) if lat.size else math.nan,
        "max": float(lat.max()) if lat.size else math.nan,
    }


def _plot(runs: list[NodeRun], path: Path) -> Path:
    """Latency distributions: the share of ticks published within a latency (left) and the
    share later than it, skipped ticks counted as late (right; the goal of issue 6 is the
    point 1 ms / 0.1 %, a curve below it meets it)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(12, 5), layout="constrained")
    cdf, tail = fig.subplots(1, 2)
    for run in runs:
        lat = np.sort(run.latencies.astype(np.float64) * 1e-6)
        if not lat.size:
            continue
        (line,) = cdf.plot(lat, np.arange(1, lat.size + 1) / lat.size, label=run.executor)
        due = lat.size + run.skipped
        later = (due - np.arange(1, lat.size + 1)) / due
        keep = later > 0.0  # the last tick has none later: no point on a log axis
        tail.step(lat[keep], later[keep], where="post", color=line.get_color())
    for ax in (cdf, tail):
        ax.axvline(1.0, color="k", ls="--", lw=0.8, label="1 ms")
        ax.set_xscale("log")
        ax.set_xlabel("tick latency: due time to published [ms]")
        ax.grid(True, which="both", alpha=0.3)
    tail.axhline(1e-3, color="k", ls=":", lw=0.8, label="0.1 % (goal: below at 1 ms)")
    tail.set_yscale("log")
    cdf.set_ylabel("share of ticks published within [-]")
    tail.set_ylabel("share of ticks later (skipped ticks count) [-]")
    cdf.set_title("tick latency (sleep loop: the machine's floor)")
    tail.set_title("the tail: share of ticks later than a latency")
    cdf.legend()
    tail.legend(loc="lower left")
    path.parent.mkdir(parents=True, exist_ok=True)
    FigureCanvasAgg(fig)
    fig.savefig(path, dpi=110)
    return path


def _names(text: str, allowed: tuple[str, ...], option: str) -> list[str]:
    """The comma-separated names of ``text``, each one of ``allowed``."""
    names = [n.strip() for n in text.split(",") if n.strip()]
    if not names or any(n not in allowed for n in names):
        raise SystemExit(f"{option} must name some of {', '.join(allowed)}")
    return names


def _print_run(run: NodeRun) -> None:
    """One line of numbers of ``run``."""
    s = summary(run)
    line = (
        f"  {run.executor:<26} {len(run.latencies)} ticks, {run.skipped} skipped; on time "
        f"(<= 1 ms) {s['on_time']:.4%}; latency p50 {s['p50']:.3f} ms, p99 {s['p99']:.3f} ms, "
        f"p99.9 {s['p999']:.3f} ms, max {s['max']:.2f} ms; CPU {run.cpu_share:.1%} of one core"
    )
    if not run.executor.startswith("sleep loop"):
        line += (
            f"; received {run.received_torque / run.duration:.0f} torque/s, "
            f"{run.received_contacts / run.duration:.0f} contact arrays/s "
            f"({run.contacts / run.duration:.0f}/s published); commanding and counting "
            f"process CPU {run.commander_cpu:.1%}"
        )
    print(
        f"{line}; machine: load {run.load_before[0]:.2f} before, "
        f"{run.steal:.1f} % of all cores' time stolen by the hypervisor during\n"
        f"      ({run.model})"
    )


def run(args: argparse.Namespace) -> int:
    """Run the floor, then the node with each tick source and executor; print the numbers."""
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    executors = _names(args.executors, EXECUTORS, "--executors")
    sources = _names(args.tick_sources, TICK_SOURCES, "--tick-sources")
    if not (args.duration > 0.0 and args.rate > 0.0 and 0.0 <= args.contact_rate <= args.rate):
        raise SystemExit("need --duration > 0, --rate > 0, 0 <= --contact-rate <= --rate")
    if not 0.1 <= args.command_rate <= 10_000.0:
        raise SystemExit(f"--command-rate {args.command_rate:g} Hz: must be in [0.1, 10000] Hz")
    if args.rounds < 1:
        raise SystemExit(f"--rounds {args.rounds}: must be >= 1")
    try:
        priorities = sorted({int(p) for p in args.priorities.split(",") if p.strip()})
    except ValueError:
        raise SystemExit(f"--priorities {args.priorities!r}: comma-separated integers") from None
    if not priorities or not all(0 <= p <= 99 for p in priorities):
        raise SystemExit(f"--priorities {args.priorities!r}: each 0 (off) or 1..99")
    print(
        f"twin node at {args.rate:g} Hz, contact states at {args.contact_rate:g} Hz, speed "
        f"commands at {args.command_rate:g} Hz, "
        f"{args.duration:g} s measured per variant in {args.rounds} interleaved rounds, each "
        f"after {WARMUP:g} s warm-up; "
        f"{psutil.cpu_count()} cores, load average before {os.getloadavg()[0]:.2f}"
    )
    if _model_parameters(args.fidelity)["fidelity"] == "realtime":
        cost = step_costs()
        print(
            "  real-time model step on a new command (median of 2000, alternating): "
            f"torque only {cost[True, False] * 1e6:.1f} us compiled / "
            f"{cost[False, False] * 1e6:.1f} us numpy reference, with the contact states "
            f"{cost[True, True] * 1e6:.1f} / {cost[False, True] * 1e6:.1f} us",
            flush=True,
        )
    # (tick source or "floor", executor, priority); a priority only matters on a thread.
    variants: list[tuple[str, str, int]] = (
        [] if args.no_floor else [("floor", "", p) for p in priorities]
    )
    for source in sources:
        for prio in priorities if source == "thread" else [0]:
            variants += [(source, name, prio) for name in executors]
    # Interleaved rounds: a change of the shared machine's load hits every variant alike.
    share = args.duration / args.rounds
    rounds: dict[tuple[str, str, int], list[NodeRun]] = {v: [] for v in variants}
    for index in range(args.rounds):
        for variant in variants:
            run_ = (
                _run_floor(args, variant[2], share)
                if variant[0] == "floor"
                else _run_one(*variant, args, share)
            )
            rounds[variant].append(run_)
            if args.rounds > 1:
                s = summary(run_)
                print(
                    f"    round {index + 1}/{args.rounds} {run_.executor:<26} on time "
                    f"{s['on_time']:.3%}, p99 {s['p99']:.3f} ms, CPU {run_.cpu_share:.1%}, "
                    f"stolen {run_.steal:.1f} %",
                    flush=True,
                )
    runs = [merge(rounds[v]) for v in variants]
    print(f"  all rounds ({args.rounds} x {share:g} s per variant):")
    for run_ in runs:
        _print_run(run_)
    nodes = [r for r in runs if not r.executor.startswith("sleep loop")]
    if len(nodes) > 1:
        best = max(nodes, key=lambda r: (round(summary(r)["on_time"], 3), -r.cpu_share))
        print(f"  best: {best.executor} (highest on-time share, then lowest CPU)")
    print(f"  plot: {_plot(runs, Path(args.plot))}")
    print("  goals of issue 6: >= 99.9 % of ticks on time within 1 ms, <= 50 % of one core")
    return 0
