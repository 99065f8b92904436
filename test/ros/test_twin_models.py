"""The models of the twin node without ROS: a failed step stands in the catalogue, ``auto``
steps down, a parameter change applies the models built for it."""

from __future__ import annotations

import dataclasses
import math

import pytest

from ballscrew_twin.models.base import OperatingPoint, TwinOutput
from ballscrew_twin.models.catalog import CatalogModel
from ballscrew_twin.params import load_config
from ballscrew_twin.ros import fidelity_modes
from ballscrew_twin.ros.twin_models import TwinModels, describe

OP = OperatingPoint(screw_speed=10.0, temperature=293.15, preload=1500.0)
SETTINGS = fidelity_modes.ModelSettings(config=load_config(None))


class Fake:
    """A model that returns Eq. 52 under another name, raises, or returns NaN."""

    name = "fake"

    def __init__(self, how: str = "ok", optional_contacts: bool = False) -> None:
        self.how = how
        self.optional_contacts = optional_contacts
        self.catalog = CatalogModel(load_config(None))
        self.resets: list[OperatingPoint] = []
        self.contacts: list[bool] = []

    def reset(self, op: OperatingPoint) -> None:
        self.resets.append(op)

    def step(self, op: OperatingPoint, dt: float, contacts: bool = True) -> TwinOutput:
        self.contacts.append(contacts)
        if self.how == "raise":
            raise FloatingPointError("diverged")
        out = dataclasses.replace(self.catalog.evaluate(op), fidelity=self.name)
        return dataclasses.replace(out, drag_torque=math.nan) if self.how == "nan" else out


def _models(model: Fake, mode: str = "realtime") -> tuple[TwinModels, list[str], list[str]]:
    logged: list[str] = []
    warned: list[str] = []
    models = TwinModels(
        fidelity_modes.ModelChoice(model, mode, "test"),  # type: ignore[arg-type]
        fidelity_modes.build("catalog", SETTINGS),
        OP,
        lambda: SETTINGS,
        logged.append,
        lambda key, text: warned.append(f"{key}: {text}"),
    )
    return models, logged, warned


def test_a_good_step_is_the_model_s() -> None:
    model = Fake(optional_contacts=True)
    models, logged, warned = _models(model)
    assert model.resets == [OP]
    out, failed = models.step(OP, 1e-3, contacts=False, requested="auto")
    assert not failed and out.fidelity == "fake"
    assert model.contacts == [False]  # contacts skipped where the model can
    assert (models.failures, models.switches, logged, warned) == (0, 0, [], [])


@pytest.mark.parametrize("how", ["raise", "nan"])
def test_a_failed_step_under_auto_steps_down(how: str) -> None:
    models, logged, warned = _models(Fake(how))
    out, failed = models.step(OP, 1e-3, contacts=True, requested="auto")
    assert failed and out.fidelity.startswith("catalog") and math.isfinite(out.drag_torque)
    assert models.failures == 1 and models.switches == 1
    assert models.choice.mode == "catalog" and "stepped down from realtime" in models.choice.reason
    assert logged and logged[0].startswith("model fake -> ")
    assert warned[0].startswith("model: model fake ") and describe(OP) in warned[0]


def test_a_failed_step_of_an_explicit_choice_keeps_it() -> None:
    models, logged, _ = _models(Fake("raise"))
    for _ in range(3):
        out, failed = models.step(OP, 1e-3, contacts=True, requested="realtime")
        assert failed and out.fidelity.startswith("catalog")
    assert models.choice.mode == "realtime" and models.failures == 3 and logged == []


def test_review_steps_down_after_two_windows_over_the_budget() -> None:
    models, logged, _ = _models(Fake())
    for expected in ("realtime", "catalog"):
        for _ in range(100):
            models.step_down.window.add(9e-3, 0)
        models.review(OP, requested="auto", step_budget=0.5, period=1e-2)
        assert models.choice.mode == expected
    assert "took 9.000 ms per step" in models.choice.reason and len(logged) == 1
    assert models.step_down.over_budget == 0  # a new model starts afresh


def test_prepared_models_run_once_applied() -> None:
    models, _, _ = _models(Fake())
    models.apply(OP)  # nothing prepared: nothing changes
    assert models.switches == 0
    catalog = fidelity_modes.choose("catalog", SETTINGS)
    fallback = fidelity_modes.build("catalog", SETTINGS)
    models.prepare(catalog, fallback)
    models.apply(OP)
    assert models.choice is catalog and models.fallback is fallback and models.switches == 1
    models.apply(OP)  # applied once
    assert models.switches == 1
