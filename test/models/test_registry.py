"""The model registry: every name builds its model, the older spellings of each interface map
to the model they always meant, and an unknown name is refused naming the accepted ones."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from ballscrew_twin.errors import ConfigError, MapError
from ballscrew_twin.models import registry
from ballscrew_twin.models.base import OperatingPoint, QuasiStaticModel
from ballscrew_twin.models.catalog import CatalogModel
from ballscrew_twin.models.dynamic import DynamicModel
from ballscrew_twin.models.dynamic_loop import DynamicStepping
from ballscrew_twin.models.faults import Faults, SphereDefect
from ballscrew_twin.models.realtime import RealTimeModel
from ballscrew_twin.models.registry import ModelName, ModelOptions
from ballscrew_twin.models.steady import SteadyStateModel
from ballscrew_twin.params import load_config

CONFIG = load_config(None)
NEW_SCREW = Path(__file__).resolve().parents[2] / "config" / "screw_32x10.yaml"
OP = OperatingPoint(screw_speed=10.47, temperature=293.15, preload=1500.0)

#: What each name must build: its class and the attributes that tell the variants apart.
EXPECTED: dict[ModelName, tuple[type, dict[str, object]]] = {
    ModelName.CATALOG_LITERATURE: (CatalogModel, {"formula": "literature", "mu_lit": 0.002}),
    ModelName.CATALOG_ZHOU: (CatalogModel, {"formula": "zhou", "mu_lit": 0.002}),
    ModelName.STEADY: (SteadyStateModel, {"mode": "auto", "tolerance": 1e-10}),
    ModelName.STEADY_SYMMETRIC: (SteadyStateModel, {"mode": "symmetric"}),
    ModelName.STEADY_FULL: (SteadyStateModel, {"mode": "full"}),
    ModelName.REALTIME: (RealTimeModel, {"name": "realtime_map"}),
    ModelName.DYNAMIC: (DynamicModel, {"temperature": 293.15, "time_step": 1e-6}),
}


def test_every_name_has_its_expectation() -> None:
    assert set(EXPECTED) == set(ModelName)


@pytest.mark.parametrize("name", list(ModelName))
def test_every_name_builds_its_model(name: ModelName) -> None:
    model = registry.build(name, CONFIG)
    kind, attributes = EXPECTED[name]
    assert type(model) is kind
    for attribute, value in attributes.items():
        assert getattr(model, attribute) == value, attribute
    assert type(registry.build(name.value, CONFIG)) is kind  # the canonical spelling too


def test_options_reach_the_model() -> None:
    catalog = registry.build(ModelName.CATALOG_ZHOU, CONFIG, ModelOptions(mu_lit=0.004))
    assert isinstance(catalog, CatalogModel) and catalog.mu_lit == 0.004
    steady = registry.build(ModelName.STEADY_FULL, CONFIG, ModelOptions(tolerance=1e-8))
    assert isinstance(steady, SteadyStateModel) and steady.tolerance == 1e-8
    faults = Faults(spheres=(SphereDefect(nut=0, index=1, radius_change=1e-6),))
    options = ModelOptions(temperature=313.15, time_step=2e-6, faults=faults)
    dynamic = registry.build(ModelName.DYNAMIC, CONFIG, options)
    assert isinstance(dynamic, DynamicModel)
    assert (dynamic.temperature, dynamic.time_step, dynamic.faults) == (313.15, 2e-6, faults)
    table = registry.build(ModelName.REALTIME, CONFIG)
    assert isinstance(table, RealTimeModel)
    again = registry.build(ModelName.REALTIME, CONFIG, ModelOptions(table=table.map))
    assert isinstance(again, RealTimeModel) and again.map is table.map


def test_the_catalog_models_are_the_catalogue_formulas() -> None:
    for name, formula in ((ModelName.CATALOG_LITERATURE, "literature"), ("catalog-zhou", "zhou")):
        built = registry.as_evaluating(registry.build(name, CONFIG)).evaluate(OP)
        direct = CatalogModel(CONFIG, formula=formula).evaluate(OP)  # type: ignore[arg-type]
        assert built.drag_torque == direct.drag_torque


@pytest.mark.parametrize(
    ("interface", "spelling", "name"),
    [
        ("cli", "catalog", ModelName.CATALOG_LITERATURE),
        ("cli", "zhou", ModelName.CATALOG_ZHOU),
        ("cli", "steady", ModelName.STEADY),
        ("node", "catalog", ModelName.CATALOG_ZHOU),
        ("node", "quasi_static", ModelName.STEADY),
        ("node", "realtime", ModelName.REALTIME),
        ("scene", "catalog", ModelName.CATALOG_ZHOU),
        ("scene", "steady-symmetric", ModelName.STEADY_SYMMETRIC),
        ("scene", "steady-full", ModelName.STEADY_FULL),
        ("scene", "realtime", ModelName.REALTIME),
        ("scene", "dynamic", ModelName.DYNAMIC),
    ],
)
def test_older_spellings_mean_what_they_meant(
    interface: registry.Interface, spelling: str, name: ModelName
) -> None:
    assert registry.model_name(spelling, interface) is name
    assert spelling in registry.accepted_names(interface)


def test_canonical_names_are_accepted_by_every_interface() -> None:
    for interface in registry.SPELLINGS:
        for name in ModelName:
            assert registry.model_name(name.value, interface) is name


@pytest.mark.parametrize("interface", [None, "cli", "node", "scene"])
def test_an_unknown_name_is_refused_naming_the_accepted_ones(
    interface: registry.Interface | None,
) -> None:
    with pytest.raises(ConfigError, match="unknown model 'fast'") as refused:
        registry.model_name("fast", interface)
    for accepted in registry.accepted_names(interface):
        assert accepted in str(refused.value)
    with pytest.raises(ConfigError, match="unknown model 'fast'"):
        registry.build("fast", CONFIG)
    # the older spellings are those of their interface only
    with pytest.raises(ConfigError, match="unknown model 'zhou'"):
        registry.model_name("zhou", "node")
    with pytest.raises(ConfigError, match="unknown model 'quasi_static'"):
        registry.model_name("quasi_static")


def test_the_steady_mode_selects_the_steady_variant() -> None:
    assert registry.with_steady_mode(ModelName.STEADY, "auto") is ModelName.STEADY
    assert registry.with_steady_mode(ModelName.STEADY, "full") is ModelName.STEADY_FULL
    assert registry.with_steady_mode(ModelName.STEADY, "symmetric") is ModelName.STEADY_SYMMETRIC
    full = ModelName.STEADY_FULL
    assert registry.with_steady_mode(full, "full") is full
    assert registry.with_steady_mode(ModelName.CATALOG_ZHOU, "full") is ModelName.CATALOG_ZHOU
    with pytest.raises(ConfigError, match="contradicts"):
        registry.with_steady_mode(full, "symmetric")
    with pytest.raises(ConfigError, match="auto, symmetric or full"):
        registry.with_steady_mode(ModelName.STEADY, "half")


def test_interfaces_of_the_built_models() -> None:
    realtime = registry.build(ModelName.REALTIME, CONFIG)
    assert registry.as_stepping(realtime) is realtime
    catalog = registry.build(ModelName.CATALOG_ZHOU, CONFIG)
    stepping = registry.as_stepping(catalog)
    assert isinstance(stepping, QuasiStaticModel) and stepping.model is catalog
    stepping.reset(OP)
    assert math.isfinite(stepping.step(OP, 1e-3).drag_torque)
    dynamic = registry.build(ModelName.DYNAMIC, CONFIG)
    with pytest.raises(ConfigError, match="no evaluate"):
        registry.as_evaluating(dynamic)
    stepping = registry.as_stepping(dynamic)  # through the one time loop
    assert isinstance(stepping, DynamicStepping) and stepping.model is dynamic


def test_a_screw_without_a_table_has_no_realtime_model(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    with pytest.raises(MapError, match=r"no real-time table .* map build"):
        registry.build(ModelName.REALTIME, load_config(NEW_SCREW))
