"""The simulation runner and its writers on a small scene (2 spheres per nut, ~1000 steps).

Measured on the scene below (before the master nut has crossed its axial play): power-balance
error 7e-7 J against 1.3e-3 J of input energy, i.e. ~6e-4 relative; the tests allow 10x that.
"""

from __future__ import annotations

import csv
import json
import math
import re
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from ballscrew_twin.bags.writer import project_typestore
from ballscrew_twin.errors import ConfigError, ResultsError, SolverError
from ballscrew_twin.models import dynamic
from ballscrew_twin.models.scenario import Scenario
from ballscrew_twin.models.simulation import simulate
from ballscrew_twin.models.simulation_result import MECHANISMS, SimulationResult
from ballscrew_twin.results import (
    CONTACT_TOPIC,
    DRAG_TOPIC,
    plot_result,
    write_bag,
    write_csv,
    write_npz,
)
from ballscrew_twin.units import SCREW_FRAME_ID

#: Relative power-balance error measured on SMALL: 5.7e-4; bound = 10x.
BALANCE_BOUND = 6e-3

SMALL: dict[str, Any] = {
    "name": "small",
    "balls_per_nut": 2,
    "temperature": 293.15,
    "preload": 20.0,
    "preload_ramp_end": 2e-4,
    "speed": 10.0,
    "speed_ramp_start": 3e-4,
    "speed_ramp_end": 6e-4,
    "duration": 1.2e-3,
    "average_window": 4e-4,
    "time_step": 1e-6,
    "jacobian_interval": 1,
    "output_interval": 1e-5,
    "contact_output_interval": 1e-4,
}


@pytest.fixture(scope="module")
def run() -> tuple[SimulationResult, list[tuple[float, float]]]:
    calls: list[tuple[float, float]] = []
    before = time.time_ns()
    result = simulate(Scenario(**SMALL), progress=lambda f, e: calls.append((f, e)))
    assert before <= result.summary["start_time_unix_ns"] <= time.time_ns()
    return result, calls


@pytest.fixture(scope="module")
def result(run: tuple[SimulationResult, list[tuple[float, float]]]) -> SimulationResult:
    return run[0]


def test_shapes_and_time_grid(result: SimulationResult) -> None:
    assert len(result.time) == 121 and len(result.contact_time) == 13
    np.testing.assert_allclose(result.time, np.arange(121) * 1e-5, atol=1e-15)
    assert result.nut_force.shape == (121, 2)
    assert result.mechanism_dissipation.shape == (121, len(MECHANISMS))
    assert result.normal_force.shape == (13, 4, 4) and result.in_contact.dtype == bool
    assert result.ball_nut.tolist() == [0, 0, 1, 1] and result.ball_index.tolist() == [0, 1, 0, 1]


def test_everything_is_finite(result: SimulationResult) -> None:
    for name, value in vars(result).items():
        if isinstance(value, np.ndarray) and value.dtype.kind == "f":
            assert np.all(np.isfinite(value)), name
    assert all(math.isfinite(v) for v in result.summary["breakdown_Nm"].values())


def test_power_balance_closes(result: SimulationResult) -> None:
    s = result.summary
    assert s["gross_input_energy_J"] > 1e-3
    assert abs(s["power_balance_error_relative"]) < BALANCE_BOUND
    scale = np.maximum(np.abs(result.input_energy), 1e-6)
    assert np.all(np.abs(result.power_balance_error) < BALANCE_BOUND * scale.max())


def test_gravitational_power_is_the_rate_of_the_gravitational_energy(
    result: SimulationResult,
) -> None:
    integral = np.concatenate(
        [
            [0.0],
            np.cumsum(
                0.5
                * np.diff(result.time)
                * (result.gravitational_power[1:] + result.gravitational_power[:-1])
            ),
        ]
    )
    change = result.gravitational_energy - result.gravitational_energy[0]
    assert np.max(np.abs(integral - change)) < 0.02 * np.max(np.abs(change))


def test_speed_follows_the_command(result: SimulationResult) -> None:
    assert result.speed_command[-1] == 10.0
    assert abs(result.screw_speed[-1] - 10.0) < 0.5
    assert result.preload_command[0] == 0.0 and result.preload_command[-1] == 20.0


def test_contact_samples_are_consistent(result: SimulationResult) -> None:
    loaded = result.normal_force > 0.0
    assert np.array_equal(loaded, result.in_contact)
    assert np.all(result.film_thickness[result.in_contact] > 0.0)
    assert np.all(result.friction_force[~result.in_contact] == 0.0)
    share = result.lubricant_share + result.dry_share
    assert np.allclose(share[result.friction_force > 0.0], 1.0)


def test_summary_follows_the_papers_definitions(result: SimulationResult) -> None:
    s = result.summary
    assert s["drag_torque_Nm"] == pytest.approx(
        s["mean_motor_torque_Nm"] - s["gravity_torque_Nm"] - s["inertia_torque_Nm"]
    )
    assert s["gravity_torque_Nm"] == pytest.approx(
        s["mean_gravitational_power_W"] / s["mean_screw_speed_rad_s"]
    )
    assert s["dissipation_drag_Nm"] == pytest.approx(
        s["mean_dissipation_W"] / s["mean_screw_speed_rad_s"]
    )
    assert s["real_time_factor"] == pytest.approx(1.2e-3 / s["wall_time_s"])
    assert s["steps"] == 1200 and s["balls_per_nut"] == 2
    json.dumps(s, allow_nan=False)


def test_inertia_term_is_the_speed_change_over_the_window(result: SimulationResult) -> None:
    """I_s (Omega_end - Omega_start) / T from the recorded speed and the parameter file."""
    from ballscrew_twin.params import load_config

    s = result.summary
    inertia = load_config().screw.screw_inertia
    span = 401 * 1e-6  # the window's 401 steps, from the state before the first one
    start = float(np.interp(1.2e-3 - span, result.time, result.screw_speed))
    expected = inertia * (result.screw_speed[-1] - start) / span
    assert s["inertia_torque_Nm"] == pytest.approx(expected, rel=1e-9)
    assert result.screw_inertia == inertia


def test_breakdown_closes_on_the_drag_through_the_energy_balance(
    result: SimulationResult,
) -> None:
    """The mechanisms, the stored energy and the preload's work sum to the drag (torque
    balance of the screw) up to a remainder: two independent routes to the same number."""
    s = result.summary
    b = s["breakdown_Nm"]
    assert list(b) == [*MECHANISMS, "stored_energy", "preload_work", "remainder"]
    assert sum(b.values()) == pytest.approx(s["drag_torque_Nm"], rel=1e-12, abs=1e-15)
    assert s["breakdown_total_Nm"] == pytest.approx(s["drag_torque_Nm"], rel=1e-12, abs=1e-15)
    scale = max(abs(v) for v in b.values())
    assert abs(b["remainder"]) < 0.05 * scale, b


def _synthetic(result: SimulationResult, speed: Any, motor: Any) -> SimulationResult:
    """``result`` with the recorded speed and motor torque replaced, nothing else moving."""
    from dataclasses import replace

    flat = np.zeros_like(result.time)
    return replace(
        result,
        screw_speed=np.asarray(speed, dtype=float),
        motor_torque=np.asarray(motor, dtype=float),
        gravitational_power=flat,
    )


def test_settling_is_detected_and_explained(result: SimulationResult) -> None:
    from ballscrew_twin.models.simulation_summary import SETTLED_DRIFT, SETTLED_SPEED, _settling

    t, command = result.time, result.speed_command
    start = 1.2e-3 - 4e-4
    flat = _settling(_synthetic(result, command, np.full_like(t, 0.02)), start)
    assert flat["settled"] and flat["not_settled_because"] == []
    assert flat["settled_since_s"] == pytest.approx(6e-4)  # the speed ramp's end
    assert flat["drag_torque_std_Nm"] == pytest.approx(0.0, abs=1e-12)
    # Speed off by twice the tolerance at the end: not settled, and said so.
    off = command * (1.0 + np.where(t > 1.1e-3, 2.0 * SETTLED_SPEED, 0.0))
    late = _settling(_synthetic(result, off, np.full_like(t, 0.02)), start)
    assert not late["settled"] and "ends" in late["not_settled_because"][0]
    # Speed back within tolerance only inside the window: settled since then, not before it.
    back = command * (1.0 + np.where((t > 6e-4) & (t < 1.0e-3), 2.0 * SETTLED_SPEED, 0.0))
    inside = _settling(_synthetic(result, back, np.full_like(t, 0.02)), start)
    assert not inside["settled"] and inside["settled_since_s"] == pytest.approx(1.0e-3)
    assert inside["drag_torque_std_window_s"][0] == pytest.approx(1.0e-3)
    # A drag drifting by 3 x the allowed fraction over the window: not settled.
    ramp = 0.02 * (1.0 + 3.0 * SETTLED_DRIFT * 2.0 * np.clip((t - start) / 4e-4, 0.0, 1.0))
    drifting = _settling(_synthetic(result, command, ramp), start)
    assert not drifting["settled"] and "halves" in drifting["not_settled_because"][0]
    # Std over the settled window: a known alternating ripple of +-1 mN m.
    ripple = 0.02 + 1e-3 * (-1.0) ** np.arange(len(t))
    rippled = _settling(_synthetic(result, command, ripple), start)
    assert rippled["drag_torque_std_Nm"] == pytest.approx(1e-3, rel=1e-2)


def test_unconverged_steps_are_located() -> None:
    from ballscrew_twin.models.simulation_summary import unconverged_summary

    scenario = Scenario(**SMALL)  # 1200 steps, window from step 800
    steps = [(5, 2e-3), (810, 4e-6)] + [(900 + i, 1e-5) for i in range(12)]
    u = unconverged_summary(steps, 14, 1200, scenario)
    assert u["count"] == 14 and u["steps"] == 1201 and u["in_window"] == 13
    assert u["largest_residual"] == 2e-3
    assert u["listed"][1] == {"step": 810, "time_s": 810e-6, "residual": 4e-6}
    assert len(u["listed"]) == 10 and u["unlisted"] == 4


def test_run_lists_its_unconverged_steps(result: SimulationResult) -> None:
    u = result.summary["unconverged"]
    assert u["count"] == result.summary["unconverged_steps"]
    assert len(u["listed"]) + u["unlisted"] == u["count"]
    assert all(st["residual"] > u["tolerance"] for st in u["listed"])


def test_scenario_outside_the_envelope_is_refused() -> None:
    from ballscrew_twin.errors import OperatingPointError

    for change, words in (
        ({"temperature": 400.0}, "temperature = 400 K is outside"),
        ({"preload": 6000.0}, "preload = 6000 N exceeds 5000 N"),
        ({"speed": 2000.0}, "|screw_speed| = 2000 rad/s exceeds"),
    ):
        with pytest.raises(OperatingPointError, match=re.escape(words)):
            simulate(Scenario(**{**SMALL, **change}))


def test_progress_is_reported_about_every_half_percent(
    run: tuple[SimulationResult, list[tuple[float, float]]],
) -> None:
    calls = run[1]
    fractions = [f for f, _ in calls]
    assert 150 <= len(calls) <= 260
    assert fractions == sorted(fractions) and fractions[-1] == 1.0
    assert all(e >= 0.0 for _, e in calls)


def test_balls_per_nut_override_is_checked() -> None:
    with pytest.raises(ConfigError, match="balls_per_nut override"):
        simulate(Scenario(**{**SMALL, "balls_per_nut": 500}))


def test_divergence_is_reported_not_hidden(monkeypatch: pytest.MonkeyPatch) -> None:
    original = dynamic.DynamicModel.step

    def poisoned(self: Any, state: Any, commands: Any) -> Any:
        new, report = original(self, state, commands)
        if state.time > 2.0e-5:
            new.screw_speed = math.nan
        return new, report

    monkeypatch.setattr(dynamic.DynamicModel, "step", poisoned)
    short = {
        **SMALL,
        "duration": 5e-5,
        "average_window": 1e-5,
        "preload_ramp_end": 1e-5,
        "speed_ramp_start": 1e-5,
        "speed_ramp_end": 2e-5,
        "contact_output_interval": 1e-5,
    }
    expected = re.escape("diverged at t = 2.1e-05 s: screw speed is nan")
    with pytest.raises(SolverError, match=expected):
        simulate(Scenario(**short), compiled_loop=False)


def test_compiled_loop_reports_divergence_like_the_python_loop(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    original = dynamic.DynamicModel.initial_state

    def poisoned(self: Any, preload: float = 0.0) -> Any:
        state = original(self, preload)
        state.ball_omega[1, 2] = math.nan
        return state

    monkeypatch.setattr(dynamic.DynamicModel, "initial_state", poisoned)
    short = {
        **SMALL,
        "duration": 5e-5,
        "average_window": 1e-5,
        "preload_ramp_end": 1e-5,
        "speed_ramp_start": 1e-5,
        "speed_ramp_end": 2e-5,
        "contact_output_interval": 1e-5,
    }
    messages = []
    for compiled_loop in (False, True):
        with pytest.raises(SolverError, match=re.escape("diverged at t = 0 s: ")) as err:
            simulate(Scenario(**short), compiled_loop=compiled_loop)
        messages.append(str(err.value))
    assert messages[0] == messages[1]


#: A short run with every fault kind (a jam starting half-way) and record intervals that are
#: not multiples of each other (10 and 15 steps): the compiled loop must retrace the Python one.
FAULTY: dict[str, Any] = {
    **SMALL,
    "balls_per_nut": 3,
    "duration": 6e-4,
    "average_window": 2e-4,
    "preload_ramp_end": 1e-4,
    "speed_ramp_start": 1.5e-4,
    "speed_ramp_end": 3.5e-4,
    "jacobian_interval": 5,
    "contact_output_interval": 1.5e-5,
    "faults": {
        "spheres": [{"nut": 1, "index": 1, "radius_change": 2e-6}],
        "spalls": [{"half_groove": "S2", "centre": 0.2, "width": 0.4, "depth": 3e-6}],
        "jams": [{"nut": 0, "index": 2, "start": 3e-4}],
    },
}


#: FAULTY at 400 N with a start phase (1 us semi-implicit steps until 0.1 ms) and then 5 us
#: steps with the sphere positions implicit, of which some do not converge and are redone as
#: 1 us semi-implicit steps (measured: 22).
FINE_START: dict[str, Any] = {
    **FAULTY,
    "preload": 400.0,
    "time_step": 5e-6,
    "implicit_positions": True,
    "fine_time_step": 1e-6,
    "fine_until": 1e-4,
}


@pytest.mark.parametrize("scenario", [FAULTY, FINE_START], ids=["uniform", "fine_start"])
def test_compiled_loop_retraces_the_python_loop(scenario: dict[str, Any]) -> None:
    reference, fast = (
        simulate(Scenario(**scenario), compiled_loop=compiled) for compiled in (False, True)
    )
    for name, value in vars(reference).items():
        if name in ("scenario", "summary"):
            continue
        other = getattr(fast, name)
        assert np.shape(other) == np.shape(value), name
        if np.asarray(value).dtype == bool or np.asarray(value).dtype.kind == "i":
            np.testing.assert_array_equal(other, value, err_msg=name)
            continue
        scale = float(np.max(np.abs(value))) if np.size(value) else 0.0
        worst = float(np.max(np.abs(other - value))) if np.size(value) else 0.0
        assert worst <= 1e-9 * scale, (name, worst, scale)
    for key, value in reference.summary.items():
        if key in ("wall_time_s", "real_time_factor", "step_cost_s", "start_time_unix_ns"):
            continue
        if key == "unconverged":  # the same steps, residuals to round-off
            assert [st["step"] for st in fast.summary[key]["listed"]] == [
                st["step"] for st in value["listed"]
            ]
        if isinstance(value, dict):
            for sub, number in value.items():
                if isinstance(number, list):
                    continue
                assert fast.summary[key][sub] == pytest.approx(number, rel=1e-9, abs=1e-300), key
        elif isinstance(value, float):
            assert fast.summary[key] == pytest.approx(value, rel=1e-9, abs=1e-300), key
        else:
            assert fast.summary[key] == value, key
    # The run did something: spheres loaded, screw turning (at 400 N the PI controller lags:
    # 3.5 of 10 rad/s at the end), the jammed sphere blocked.
    turning = 5.0 if scenario is FAULTY else 1.0
    assert reference.in_contact.any() and reference.screw_speed[-1] > turning
    assert reference.summary["dissipation_drag_Nm"] > 0.0
    if scenario is FINE_START:  # and redid steps as substeps
        assert reference.summary["fallback_steps"] > 0


# ---------------------------------------------------------------------------------- writers


def test_csv_round_trip(result: SimulationResult, tmp_path: Path) -> None:
    path = write_csv(result, tmp_path / "ts.csv")
    with path.open(encoding="utf-8") as handle:
        rows = list(csv.reader(handle))
    header, body = rows[0], np.array(rows[1:], dtype=float)
    assert header[:4] == [
        "time [s]",
        "speed_command [rad/s]",
        "preload_command [N]",
        "screw_speed [rad/s]",
    ]
    assert "drag_torque [N m]" in header and "power_balance_error [J]" in header
    assert body.shape == (121, len(header))
    np.testing.assert_array_equal(body[:, header.index("motor_torque [N m]")], result.motor_torque)
    np.testing.assert_array_equal(body[:, header.index("drag_torque [N m]")], result.drag_torque)


def test_npz_round_trip(result: SimulationResult, tmp_path: Path) -> None:
    path = write_npz(result, tmp_path / "r.npz")
    with np.load(path) as data:
        np.testing.assert_array_equal(data["screw_speed"], result.screw_speed)
        np.testing.assert_array_equal(data["normal_force"], result.normal_force)
        np.testing.assert_array_equal(data["in_contact"], result.in_contact)
        assert list(data["mechanisms"]) == list(MECHANISMS)
        echoed = json.loads(str(data["summary_json"]))
    assert echoed["summary"]["drag_torque_Nm"] == result.summary["drag_torque_Nm"]
    assert echoed["scenario"]["balls_per_nut"] == 2


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_bag_round_trip(result: SimulationResult, tmp_path: Path, storage: str) -> None:
    from rosbags.highlevel import AnyReader

    bag = write_bag(result, tmp_path / "bag", storage=storage)
    meta = yaml.safe_load((bag / "metadata.yaml").read_text(encoding="utf-8"))
    info = meta["rosbag2_bagfile_information"]
    assert info["ros_distro"] == "jazzy"
    assert info["starting_time"]["nanoseconds_since_epoch"] == result.summary["start_time_unix_ns"]
    store = project_typestore()
    drags: list[tuple[int, Any]] = []
    arrays: list[tuple[int, Any]] = []
    with AnyReader([bag], default_typestore=store) as reader:
        for conn, t_ns, raw in reader.messages():
            msg = reader.deserialize(raw, conn.msgtype)
            (drags if conn.topic == DRAG_TOPIC else arrays).append((t_ns, msg))
        topics = {c.topic: c.msgtype for c in reader.connections}
    assert topics == {
        DRAG_TOPIC: "ballscrew_twin_msgs/msg/DragTorque",
        CONTACT_TOPIC: "ballscrew_twin_msgs/msg/ContactStateArray",
    }
    assert len(drags) == len(result.time) and len(arrays) == len(result.contact_time)
    start = result.summary["start_time_unix_ns"]
    for i, (t_ns, msg) in enumerate(drags):
        assert t_ns == start + round(result.time[i] * 1e9)
        assert msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == t_ns
        assert msg.header.frame_id == SCREW_FRAME_ID
        assert msg.total == result.drag_torque[i]
        # the message carries deg C (REP 103); the scenario is at 293.15 K
        assert msg.fidelity == "dynamic" and msg.temperature == pytest.approx(20.0, abs=1e-12)
        assert msg.axial_load == 0.0
        assert msg.screw_speed == result.screw_speed[i]
    moving = int(np.argmax(np.abs(result.screw_speed) > 1.0))
    msg = drags[moving][1]
    speed = result.screw_speed[moving]
    assert msg.lubricant_shear == pytest.approx(result.mechanism_dissipation[moving, 0] / speed)
    assert msg.nut_master == pytest.approx(result.nut_dissipation[moving, 0] / speed)
    for j, (t_ns, msg) in enumerate(arrays):
        assert t_ns == start + round(result.contact_time[j] * 1e9)
        assert len(msg.contacts) == int(result.in_contact[j].sum())
        assert msg.header.frame_id == SCREW_FRAME_ID
        for c in msg.contacts:
            ball = int(
                np.flatnonzero((result.ball_nut == c.nut) & (result.ball_index == c.sphere_index))[
                    0
                ]
            )
            assert c.in_contact
            assert c.normal_force == result.normal_force[j, ball, c.half_groove]
            assert c.contact_angle == result.contact_angle[j, ball, c.half_groove]


def test_bag_errors(result: SimulationResult, tmp_path: Path) -> None:
    with pytest.raises(ResultsError, match="does not exist"):
        write_bag(result, tmp_path / "b1", msg_dir=tmp_path / "no_msgs")
    with pytest.raises(ResultsError, match="storage"):
        write_bag(result, tmp_path / "b2", storage="rosbag1")
    (tmp_path / "b3").mkdir()
    with pytest.raises(ResultsError, match="exists already"):
        write_bag(result, tmp_path / "b3")


def test_plot_is_written(result: SimulationResult, tmp_path: Path) -> None:
    path = plot_result(result, tmp_path / "p.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_power_balance_survives_the_nut_impact() -> None:
    res = simulate(Scenario(**{**SMALL, "duration": 1.5e-3, "average_window": 5e-4}))
    assert abs(res.summary["power_balance_error_relative"]) < BALANCE_BOUND


def test_compiled_loop_locates_unconverged_steps_like_the_python_loop() -> None:
    """short_check's first 0.55 ms has unconverged steps (15 with the predictor, measured; the
    first 10 listed): the compiled loop replays their record stretches step by step, and must
    count the same steps and list the same ones with the same residuals as the per-step loop,
    along the same trajectory."""
    from dataclasses import replace

    from ballscrew_twin.models.scenario import load_scenario

    short = Path(__file__).resolve().parents[2] / "config" / "scenarios" / "short_check.yaml"
    scenario = replace(load_scenario(short), duration=5.5e-4, average_window=5e-5)
    reference, fast = (simulate(scenario, compiled_loop=c) for c in (False, True))
    listed = reference.summary["unconverged"]["listed"]
    unconverged = reference.summary["unconverged"]
    assert listed and unconverged["count"] == len(listed) + unconverged["unlisted"]
    assert fast.summary["unconverged"] == reference.summary["unconverged"]
    for name in ("screw_speed", "motor_torque", "nut_position", "dissipation", "input_energy"):
        np.testing.assert_array_equal(getattr(fast, name), getattr(reference, name), name)


def test_start_phase_runs_the_fine_steps() -> None:
    """A run of 2 us steps whose first 0.4 ms are split into 1 us steps retraces, over those
    0.4 ms, the run of 1 us steps throughout: every recorded series (states, forces, energy
    integrals, power balance) to 1e-9 of its largest value. (The sample at 0.4 ms is the first
    2 us step's.)"""
    uniform = simulate(Scenario(**SMALL))
    split = simulate(
        Scenario(**{**SMALL, "time_step": 2e-6, "fine_time_step": 1e-6, "fine_until": 4e-4})
    )
    start = uniform.time < 4e-4 - 1e-12
    assert start.sum() == 40
    np.testing.assert_allclose(split.time[start], uniform.time[start], rtol=1e-12)
    for name in (
        "screw_speed",
        "motor_torque",
        "nut_force",
        "nut_position",
        "dissipation",
        "kinetic_energy",
        "elastic_energy",
        "input_energy",
        "dissipated_energy",
        "power_balance_error",
    ):
        ours, theirs = getattr(split, name)[start], getattr(uniform, name)[start]
        scale = float(np.max(np.abs(theirs)))
        assert scale > 0.0, name
        assert float(np.max(np.abs(ours - theirs))) <= 1e-9 * scale, name
