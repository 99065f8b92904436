"""The committed sample bags, replayed by ``ballscrew-twin replay --wait-subscribers`` at 1x to
5x into the health node (use_sim_time, loopback), give the offline verdict of ``detect``.

Tolerance of the alarm time: the node and ``detect`` are fed the same samples with the same
stamps, and a block's result depends only on its samples and on the slow signals around it;
an alarm is stamped with the last torque sample of the block that raised it. So the alarm
times agree exactly as long as no block is closed on the aligner's timeout (a slow signal
delivered more than ``max_wait`` of bag time after the torque, its last value held instead).
The test checks that no live block was closed so, and compares the alarm times to 1 us: the
rounding of the stamps (about 1.7e9 s held in a float64: 0.24 us) and nothing more.

The replay ends before the node has read everything: DDS delivers the messages into the node's
input queues at once, and the node then works through them at its own pace. On a loaded
machine that takes tens of seconds (at 5x with three busy-looping processes beside it, 833 of
4000 torque messages were processed when the replay ended and the last one 19 s later, none
lost, in order, never more than 0.13 s between two). The replay exits only once the node's
DDS layer has acknowledged every message (``--drain``): when it exited at once, a node starved
of CPU lost the last 5 % (3800 of 4000 torque messages at 5x, two test runs and a benchmark on
the 2 cores). So the test waits for as long as the node makes progress, not for a fixed time
after the replay's end. Meanwhile /clock stands still and
the node's watchdog may publish its UNKNOWN (STALE) message among the verdicts; the test tells
those apart and checks every block's verdict.

The last flakiness had another cause: a health node that an earlier test had left alive (made,
never destroyed, its context only shut down) was a fourth, best-effort subscriber of the bag's
topics in this process. With it there, this test's reliable subscribers stopped receiving at
some time of the replay (5-40 % of the messages missing, none arriving in the next 20 s) while
the replay's drain reported every message acknowledged: 4 of 8 cases failed in two runs with
such a node made on purpose, 0 of 8 once the fixture destroyed it. The ROS fixtures now destroy
every node a test leaves, and this test first checks that no other node subscribes to the
bag's topics, naming any it finds.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
from ballscrew_twin_msgs.msg import HealthResidual
from geometry_msgs.msg import WrenchStamped
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy

from ballscrew_twin.bags.bench import read_bench_bag
from ballscrew_twin.health.monitor_settings import MonitorSettings
from ballscrew_twin.health.offline import (
    CHANNELS,
    overall_verdict,
    recording_channels,
    run_monitor,
    summary,
)
from ballscrew_twin.health.residuals import TwinPredictor, shared_predictor
from ballscrew_twin.health.verdicts import UNKNOWN, VERDICT_NAMES
from ballscrew_twin.params import load_config
from ballscrew_twin.ros.health_node import HealthNode

from .conftest import SpinUntil

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = ROOT / "data" / "samples"
#: Agreement of the alarm times [s] (see the module docstring).
ALARM_TOLERANCE = 1e-6
#: Longest wait for the replay to find its subscribers, and for a whole replay [s].
WAIT = "20"
REPLAY_TIMEOUT = 180.0
#: After the replay has ended, the longest time in which the node takes no input and no torque
#: message reaches the test's witness, before the test counts what arrived [s]: the node works
#: through its queues at its own pace (see above).
PROGRESS_TIMEOUT = 20.0
#: Input queues of the node, deeper than a sample bag's torque topic (4000 messages): a node
#: starved of CPU by a loaded test machine falls behind but loses nothing.
QUEUE_DEPTH = 10_000


def _replay(bag: Path, rate: float) -> subprocess.Popen[str]:
    """``ballscrew-twin replay`` of ``bag`` at ``rate`` (environment: this run's ROS domain)."""
    script = Path(sys.executable).parent / "ballscrew-twin"
    return subprocess.Popen(
        [str(script), "replay", str(bag), "--rate", str(rate), "--wait-subscribers", WAIT],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=dict(os.environ),
        stdin=subprocess.DEVNULL,
    )


@pytest.fixture(scope="module")
def predictor() -> TwinPredictor:
    """One twin cache for all the bags (the shipped screw, default settings)."""
    return shared_predictor(load_config(None), MonitorSettings().residual)


@pytest.mark.parametrize(
    ("name", "rate"),
    [
        ("preload_loss", 1.0),
        ("lubricant_degradation", 2.5),
        ("raceway_defect", 5.0),
        ("healthy", 5.0),
    ],
)
def test_replayed_sample_gives_the_offline_verdict(
    name: str,
    rate: float,
    predictor: TwinPredictor,
    executor: SingleThreadedExecutor,
    spin_until: SpinUntil,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    bag = SAMPLES / name
    recording = read_bench_bag(bag, required=CHANNELS)
    torque_count = len(recording.series("torque"))
    start = recording.start_ns * 1e-9
    offline = run_monitor(
        recording_channels(recording), predictor.config, MonitorSettings(), start, predictor
    )
    expected = summary(offline, recording.truth)
    node = HealthNode(
        context=executor.context,
        parameter_overrides=[
            Parameter("use_sim_time", value=True),
            Parameter("queue_depth", value=QUEUE_DEPTH),
            # the replayer publishes reliably: a reliable subscription gets every message
            # (best effort lost 2.4 % of the torque at 5x in one of two full runs, idle machine)
            Parameter("reliable_inputs", value=True),
        ],
    )
    node.monitor.predictor = predictor  # warm cache: the same values, no solver stall
    stale_at: list[int] = []  # places on the health topic of the watchdog's messages
    publish_stale = node._publish_stale

    def spy_stale() -> None:
        stale_at.append(node.published)
        publish_stale()

    monkeypatch.setattr(node, "_publish_stale", spy_stale)
    executor.add_node(node)
    heard: list[HealthResidual] = []
    listener = Node("listener", context=executor.context)
    listener.create_subscription(HealthResidual, "health", heard.append, 1000)
    # a witness of what DDS delivers to this process, beside what the node handles
    witnessed: list[int] = []
    listener.create_subscription(
        WrenchStamped,
        node.get_parameter("torque_topic").value,
        lambda _: witnessed.append(1),
        QoSProfile(depth=QUEUE_DEPTH, reliability=ReliabilityPolicy.RELIABLE),
    )
    executor.add_node(listener)
    # nobody else listens: a foreign subscriber (a node another test left alive) has made
    # this test's reliable subscribers lose messages the replay counted as acknowledged
    own = {node.get_name(), listener.get_name()}
    topics = [node.get_parameter(f"{k}_topic").value for k in CHANNELS]

    def others() -> set[str]:
        infos = (i for t in topics for i in listener.get_subscriptions_info_by_topic(t))
        return {i.node_name for i in infos} - own

    assert spin_until(executor, lambda: not others(), timeout=10.0), (
        f"other nodes subscribe to the bag's topics: {sorted(others())}"
    )
    # started once the node subscribes: its --wait-subscribers waits for DDS, not for this
    # test's own work (the offline run took over 20 s on a loaded machine, the first case)
    proc = _replay(bag, rate)
    try:
        now = time.monotonic()
        deadline, progress, handled = now + REPLAY_TIMEOUT, now, (0, 0)
        while now < deadline and (proc.poll() is None or node.received["torque"] < torque_count):
            executor.spin_once(timeout_sec=0.01)
            now = time.monotonic()
            # progress: any input the node has taken (a block closes, and may be classified
            # at length, in whichever input's callback completes it) or any delivery
            latest = (sum(node.received.values()), len(witnessed))
            if latest != handled:
                progress, handled = now, latest
            elif proc.poll() is not None and now - progress > PROGRESS_TIMEOUT:
                break  # the replay ended and nothing more arrives
        idle = time.monotonic() - progress
        output = proc.communicate(timeout=10.0)[0] if proc.poll() is not None else ""
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=10.0)
    assert proc.returncode == 0, output
    assert "not every topic has a subscriber" not in output
    assert "not every reliable subscriber acknowledged" not in output, output
    assert "subscriber(s) at the start" not in output, output
    assert node.received["torque"] == torque_count, (
        node.received,
        f"delivered to this process: {len(witnessed)}",
        f"idle {idle:.1f} s",
        output,
    )
    assert node.dropped == 0 and node.restarts == 0

    assert spin_until(executor, lambda: len(heard) == node.published)
    live = node.monitor
    assert not [s for s in live.samples if "held" in s.note], "a block was closed on a timeout"
    assert VERDICT_NAMES[overall_verdict(live, live.samples)] == expected["verdict"]
    assert all(heard[i].verdict == UNKNOWN for i in stale_at)
    blocks = [msg for i, msg in enumerate(heard) if i not in stale_at]
    assert blocks
    assert [msg.verdict for msg in blocks] == [s.verdict for s in live.samples]
    if expected["alarm"] is None:
        assert live.alarm is None
        return
    assert live.alarm is not None
    assert live.alarm.classification.fault_class == expected["fault_class"] == name
    assert blocks[-1].fault_class == expected["fault_class"]
    assert live.alarm.time - start == pytest.approx(
        expected["alarm"]["time_s"], abs=ALARM_TOLERANCE
    )
