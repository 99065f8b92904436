"""The node's model factory: what auto chooses and why, explicit modes, the quasi-static cache."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from ballscrew_twin.errors import ConfigError, FidelityError
from ballscrew_twin.models.base import OperatingPoint, TwinOutput
from ballscrew_twin.models.catalog import CatalogModel
from ballscrew_twin.params import load_config
from ballscrew_twin.ros import fidelity_modes
from ballscrew_twin.ros.fidelity_modes import CachedQuasiStatic, ModelSettings, choose

SETTINGS = ModelSettings(config=load_config(None))
NEW_SCREW = Path(__file__).resolve().parents[2] / "config" / "screw_32x10.yaml"
OP = OperatingPoint(screw_speed=10.47, temperature=293.15, preload=1500.0)


def test_auto_without_realtime_takes_catalog_and_says_why(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A screw with no real-time table (none packaged for it, an empty user cache)."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    settings = ModelSettings(config=load_config(NEW_SCREW))
    choice = choose("auto", settings)
    assert choice.mode == "catalog"
    assert "realtime" in choice.reason and "no real-time table" in choice.reason
    with pytest.raises(FidelityError, match="realtime"):
        choose("realtime", settings)


def test_stepping_down_never_goes_up() -> None:
    choice = choose("auto", SETTINGS, below="realtime")
    assert choice.mode == "catalog" and "stepped down from realtime" in choice.reason
    with pytest.raises(FidelityError, match="no model left"):
        choose("auto", SETTINGS, below="catalog")


def test_catalog_steps_like_eq52() -> None:
    model = choose("catalog", SETTINGS).model
    model.reset(OP)
    out = model.step(OP, 1e-3)
    assert out.drag_torque == CatalogModel(SETTINGS.config).evaluate(OP).drag_torque


def test_unknown_mode_rejected() -> None:
    with pytest.raises(ConfigError, match="psychic"):
        choose("psychic", SETTINGS)


class CountingModel:
    """A steady model that counts its evaluations (torque = preload, an arbitrary law)."""

    name = "counting"

    def __init__(self) -> None:
        self.calls = 0

    def evaluate(self, op: OperatingPoint) -> TwinOutput:
        self.calls += 1
        return dataclasses.replace(
            CatalogModel(SETTINGS.config).evaluate(op), drag_torque=op.preload
        )


def test_quasi_static_cache_solves_only_on_a_new_command() -> None:
    steady = CountingModel()
    model = CachedQuasiStatic(steady)
    model.reset(OP)
    first = model.step(OP, 1e-3)
    assert model.step(dataclasses.replace(OP), 1e-3) is first and steady.calls == 1
    other = dataclasses.replace(OP, preload=2000.0)
    assert model.step(other, 1e-3).drag_torque == 2000.0 and steady.calls == 2
    model.reset(OP)
    model.step(other, 1e-3)
    assert steady.calls == 3  # reset forgets the cache


def test_contact_free_ticks_through_the_validity_wrapper() -> None:
    """The node's contacts=False reaches the real-time model (no states, same torque); models
    without optional contact states ignore it."""
    realtime = fidelity_modes.build("realtime", SETTINGS)
    full = realtime.step(OP, 1e-3)
    plain = realtime.step(OP, 1e-3, contacts=False)  # type: ignore[call-arg]
    assert full.contacts is not None and plain.contacts is None
    assert plain.drag_torque == full.drag_torque and plain.nut_torque == full.nut_torque
    catalog = fidelity_modes.build("catalog", SETTINGS)
    stepped = catalog.step(OP, 1e-3, contacts=False)  # type: ignore[call-arg]
    assert stepped.drag_torque == catalog.step(OP, 1e-3).drag_torque
