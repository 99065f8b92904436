"""The dynamic model reaches the steady model's state: the two are independent solutions of the
same contact laws (time integration of Newton-Euler vs. a quasi-static Newton solve).

One sphere per nut, 100 N, 100 rpm, 20 C; 9 ms simulated (~40 s). Measured: every mechanism of
the dynamic breakdown (mean dissipation / speed over the last 3 ms) within 2.1 % of the steady
one (hysteresis, curvature, spin within 0.1 %), the power balance within 4.2e-4 of the input
energy. The motor torque itself needs longer to settle (docs/model.md section 10:
config/scenarios/steady_check.yaml gives -0.4 % after 40 ms).
"""

import dataclasses

import pytest

from ballscrew_twin.models.base import MECHANISMS, OperatingPoint
from ballscrew_twin.models.scenario import load_scenario
from ballscrew_twin.models.simulation import build_config, simulate
from ballscrew_twin.models.steady import SteadyStateModel
from ballscrew_twin.params import default_config_path

SCENE = default_config_path().parent / "scenarios" / "steady_check.yaml"


def test_dynamic_breakdown_reaches_the_steady_one() -> None:
    scenario = dataclasses.replace(
        load_scenario(SCENE),
        balls_per_nut=1,
        preload=100.0,
        preload_ramp_end=2e-3,
        speed_ramp_start=2e-3,
        speed_ramp_end=4e-3,
        duration=9e-3,
        average_window=3e-3,
    )
    result = simulate(scenario)
    steady = SteadyStateModel(build_config(scenario)).evaluate(
        OperatingPoint(
            screw_speed=scenario.speed, temperature=scenario.temperature, preload=scenario.preload
        )
    )
    dynamic = result.summary["breakdown_Nm"]
    for name in MECHANISMS:
        assert dynamic[name] == pytest.approx(getattr(steady.breakdown, name), rel=0.05), name
    assert abs(result.summary["power_balance_error_relative"]) < 4e-3
