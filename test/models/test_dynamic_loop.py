"""The one time loop of the dynamic model and the dynamic model as a time-stepping model.

Oracles: the model's own ``step`` called by hand (the loop and the adapter must retrace it), the
start-phase schedule written out, and standstill (no speed, no drag).
"""

from __future__ import annotations

import dataclasses
import math
import re
from typing import Any

import numpy as np
import pytest

from ballscrew_twin.errors import OperatingPointError, SolverError
from ballscrew_twin.models import registry
from ballscrew_twin.models.base import MECHANISMS, OperatingPoint
from ballscrew_twin.models.dynamic import DynamicModel
from ballscrew_twin.models.dynamic_loop import DynamicStepping, ModelStep, StepPlan, TimeLoop
from ballscrew_twin.models.dynamic_state import Commands, DynamicState
from ballscrew_twin.models.registry import ModelName, ModelOptions
from ballscrew_twin.params import load_config

BASE = load_config()
#: Two spheres per nut: fast.
CONFIG = dataclasses.replace(BASE, screw=dataclasses.replace(BASE.screw, balls_per_nut=2))
#: 10 rad/s, 20 C, 60 N (the paper's load of one sphere of 25, 1500 N / 25).
OP = OperatingPoint(screw_speed=10.0, temperature=293.15, preload=60.0)
TIME_STEP = 1e-6
TICK_STEPS = 20


def stepping() -> DynamicStepping:
    model = registry.build(ModelName.DYNAMIC, CONFIG, ModelOptions(time_step=TIME_STEP))
    adapter = registry.as_stepping(model)
    assert isinstance(adapter, DynamicStepping) and adapter.model is model
    return adapter


def test_ticks_retrace_the_models_own_steps() -> None:
    adapter = stepping()
    adapter.reset(OP)
    outputs = [adapter.step(OP, TICK_STEPS * TIME_STEP) for _ in range(3)]
    # The oracle: a model of its own stepped by hand under the held command.
    model = DynamicModel(CONFIG, OP.temperature, time_step=TIME_STEP)
    state = model.initial_state(OP.preload)
    commands = Commands(screw_speed=OP.screw_speed, preload=OP.preload)
    for tick, out in enumerate(outputs):
        for _ in range(TICK_STEPS):
            start = state
            state, report = model.step(state, commands)
        ev = report.contacts
        power = sum(float(np.sum(ev.dissipation[m])) for m in MECHANISMS)
        assert start.time == pytest.approx((tick + 1) * TICK_STEPS * TIME_STEP - TIME_STEP)
        assert out.drag_torque == pytest.approx(power / start.screw_speed, rel=1e-12)
        assert sum(out.nut_torque) == pytest.approx(out.drag_torque, rel=1e-12)
        assert out.breakdown.total == pytest.approx(out.drag_torque, rel=1e-12)
        assert out.contacts is not None
        force = np.where(ev.active, ev.hertz.stiffness * np.maximum(ev.approach, 0.0) ** 1.5, 0)
        np.testing.assert_array_equal(out.contacts.normal_force, force.reshape(-1))
        np.testing.assert_array_equal(out.contacts.in_contact, ev.active.reshape(-1))
        assert out.fidelity == "dynamic" and out.notes == ()
    assert outputs[-1].drag_torque > 0.0  # the screw turns and the contacts dissipate
    # A reset forgets the run: the first tick again.
    adapter.reset(OP)
    assert adapter.step(OP, TICK_STEPS * TIME_STEP).drag_torque == outputs[0].drag_torque


def test_standstill_has_no_drag_and_what_is_held_fixed_is_noted() -> None:
    adapter = stepping()
    warm = OperatingPoint(screw_speed=0.0, temperature=313.15, preload=60.0, axial_load=100.0)
    out = adapter.step(warm, TIME_STEP)  # without reset: starts at rest at the command
    assert out.drag_torque == 0.0 and out.nut_torque == (0.0, 0.0)
    assert out.breakdown.total == 0.0
    assert any("293.15 K" in note and "313.15 K" in note for note in out.notes)
    assert any("axial load 100 N" in note for note in out.notes)


@pytest.mark.parametrize("dt", [0.0, 1.5e-6, -1e-6])
def test_a_tick_is_whole_steps_of_the_model(dt: float) -> None:
    adapter = stepping()
    adapter.reset(OP)
    with pytest.raises(OperatingPointError, match="whole number"):
        adapter.step(OP, dt)


def test_the_loop_runs_the_start_phase_in_substeps_and_the_last_step_for_its_report() -> None:
    model = DynamicModel(CONFIG, OP.temperature, time_step=TIME_STEP)
    plan = StepPlan(time_step=TIME_STEP, fine_time_step=5e-7, fine_steps=2, substeps=2)
    plan.start(model)
    visits: list[tuple[int, int, float, float]] = []
    done: list[int] = []

    def visit(step: ModelStep) -> None:
        visits.append((step.k, step.j, step.length, step.state.time))

    loop = TimeLoop(
        model,
        model.initial_state(OP.preload),
        plan,
        lambda t: Commands(0.0, 0.0),
        visit,
        done.append,
    )
    loop.run(3, final_report=True)
    expected = [
        (0, 0, 5e-7, 0.0),
        (0, 1, 5e-7, 5e-7),
        (1, 0, 5e-7, 1e-6),
        (1, 1, 5e-7, 1.5e-6),
        (2, 0, 1e-6, 2e-6),
        (3, 0, 1e-6, 3e-6),
    ]
    assert [v[:3] for v in visits] == [e[:3] for e in expected]
    assert [v[3] for v in visits] == pytest.approx([e[3] for e in expected], abs=1e-18)
    assert done == [1, 2, 3]
    assert loop.state.time == pytest.approx(3e-6, abs=1e-18)  # the last step left no trace
    assert model.time_step == TIME_STEP  # switched at the end of the start phase


def test_a_diverging_step_is_reported_not_returned(monkeypatch: pytest.MonkeyPatch) -> None:
    original = DynamicModel.step

    def poisoned(self: DynamicModel, state: DynamicState, commands: Commands) -> Any:
        new, report = original(self, state, commands)
        if state.time > 2.5e-6:
            new.screw_speed = math.nan
        return new, report

    monkeypatch.setattr(DynamicModel, "step", poisoned)
    adapter = stepping()
    adapter.reset(OP)
    with pytest.raises(SolverError, match=re.escape("diverged at t = 4e-06 s: screw speed is nan")):
        adapter.step(OP, 5 * TIME_STEP)
