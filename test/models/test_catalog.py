"""Catalogue formulas (Eqs. 51-52) against the values computed independently in MODEL_NOTES."""

import math

import pytest

from ballscrew_twin.errors import OperatingPointError
from ballscrew_twin.models.base import OperatingPoint
from ballscrew_twin.models.catalog import CatalogModel, drag_torque_literature, drag_torque_zhou
from ballscrew_twin.params import load_config

# MODEL_NOTES computed its values with Table A.1's printed helix angle (5.679 deg); they are
# printed to 0.1 N mm, hence the half-unit tolerance of 0.05e-3 N m.
HELIX = math.radians(5.679)


@pytest.mark.parametrize(
    ("preload", "eq51", "eq52"),
    [(500, 16.2e-3, 6.39e-3), (1500, 48.5e-3, 19.2e-3), (3000, 97.0e-3, 38.3e-3)],
)
def test_published_sanity_values(preload: float, eq51: float, eq52: float) -> None:
    assert drag_torque_literature(preload, 5e-3, HELIX, 0.002) == pytest.approx(eq51, abs=0.05e-3)
    zhou = drag_torque_zhou(preload, 0.002, math.radians(45), 8e-3, 1.5875e-3, HELIX)
    assert zhou == pytest.approx(eq52, abs=0.05e-3)


def test_zero_friction_gives_zero_torque() -> None:
    assert drag_torque_literature(3000, 5e-3, HELIX, 0.0) == pytest.approx(0.0, abs=1e-15)


def test_model_sign_follows_speed_and_zero_speed_is_zero() -> None:
    model = CatalogModel(load_config())
    fwd = model.evaluate(OperatingPoint(screw_speed=10.0, temperature=293.15, preload=1000.0))
    rev = model.evaluate(OperatingPoint(screw_speed=-10.0, temperature=293.15, preload=1000.0))
    still = model.evaluate(OperatingPoint(screw_speed=0.0, temperature=293.15, preload=1000.0))
    assert fwd.drag_torque > 0.0
    assert rev.drag_torque == pytest.approx(-fwd.drag_torque)
    assert still.drag_torque == 0.0
    assert sum(fwd.nut_torque) == pytest.approx(fwd.drag_torque)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"screw_speed": math.nan, "temperature": 293.15, "preload": 1.0},
        {"screw_speed": 1.0, "temperature": 20.0, "preload": 1.0},  # Celsius given as kelvin
        {"screw_speed": 1.0, "temperature": 293.15, "preload": -5.0},
        {"screw_speed": 1.0, "temperature": math.inf, "preload": 1.0},
    ],
)
def test_bad_operating_points_are_rejected_with_names(kwargs: dict[str, float]) -> None:
    with pytest.raises(OperatingPointError) as err:
        CatalogModel(load_config()).evaluate(OperatingPoint(**kwargs))
    bad = next(k for k in ("screw_speed", "temperature", "preload") if str(err.value).startswith(k))
    assert bad in kwargs
