"""``bench node`` end to end, briefly: the floor and a node run are measured and printed, every
tick and message is accounted for, the plot is written. Timings are printed, never asserted."""

from __future__ import annotations

import re
from collections import namedtuple
from pathlib import Path

import pytest

from ballscrew_twin.benchmarks.node import StealMeter, steal_share
from ballscrew_twin.cli import main
from ballscrew_twin.params import load_config
from ballscrew_twin.ros.fidelity_modes import ModelSettings, unavailable


def test_short_run_accounts_for_every_tick_and_message(
    tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    plot = tmp_path / "latency.png"
    # The model the benchmark runs by default; the quasi-static one where the map is missing.
    model = (
        "realtime"
        if unavailable("realtime", ModelSettings(load_config(None))) is None
        else ("quasi_static")
    )
    argv = [
        "bench",
        "node",
        "--duration",
        "2",
        "--rate",
        "200",
        "--contact-rate",
        "20",
        "--fidelity",
        model,
        "--tick-sources",
        "thread",
        "--executors",
        "events",
        "--rounds",
        "2",
        "--plot",
        str(plot),
    ]
    assert main(argv) == 0
    out = capfd.readouterr().out
    floor = re.search(r"sleep loop +(\d+) ticks, 0 skipped; on time \(<= 1 ms\) ([\d.]+)%", out)
    assert floor is not None, out
    # every grid point of the 2 s window once, however late the thread woke at its edges
    assert int(floor.group(1)) == 2 * 200
    assert out.count("round 2/2") == 2
    # Every variant reports the steal share of its measured time.
    assert len(re.findall(r"([\d.]+) % of all cores' time stolen", out)) == 2
    node = re.search(
        r"thread/events +(\d+) ticks, (\d+) skipped; on time .* received (\d+) torque/s, "
        r"(\d+) contact arrays/s \((\d+)/s published\)",
        out,
    )
    assert node is not None, out
    ticks, skipped, torque_rate, contact_rate, published = map(int, node.groups())
    assert 2 * 200 * 0.9 <= ticks + skipped <= 2 * 200 * 1.1
    # Another process received what was published (as CDR bytes) at the configured rates.
    assert 150 <= torque_rate <= 220 and 15 <= contact_rate <= 22 and 15 <= published <= 22
    assert "ticks: thread (" in out and model.split("_")[0] in out
    if model == "realtime":  # the model's step cost, compiled against the numpy reference
        costs = re.search(r"torque only ([\d.]+) us compiled / ([\d.]+) us numpy reference", out)
        assert costs is not None, out
        assert min(float(costs.group(1)), float(costs.group(2))) > 0.0
    assert plot.stat().st_size > 10_000


def test_steal_share_is_steal_over_all_but_guest_time() -> None:
    """The share is computed from the deltas; guest time (already in user) is not added."""
    fields = ("user", "nice", "system", "idle", "iowait", "steal", "guest", "guest_nice")
    times = namedtuple("times", fields)
    before = times(100.0, 0.0, 10.0, 500.0, 1.0, 2.0, 50.0, 0.0)
    # deltas: user 30 (guest 20 of it), system 5, idle 55, iowait 2, steal 8 -> total 100
    after = times(130.0, 0.0, 15.0, 555.0, 3.0, 10.0, 70.0, 0.0)
    assert steal_share(before, after) == pytest.approx(8.0)
    assert steal_share(before, before) == 0.0
    # Live counters: a share of all cores' time.
    meter = StealMeter()
    sum(range(100_000))
    assert 0.0 <= meter.read() <= 100.0
