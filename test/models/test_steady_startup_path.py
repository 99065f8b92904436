"""The start-up path of a cold solve resumed from the kept start of a step it shares with the
path before (steady_continuation.StartupPath): the result is the path followed from the
start-up speed by a fresh model, to the last bit, and it takes fewer Newton solves."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballscrew_twin.models.base import OperatingPoint
from ballscrew_twin.models.steady import SteadyStateModel
from ballscrew_twin.models.steady_continuation import (
    STARTUP_MAX_RATIO,
    STARTUP_SPEED,
    forget_startup_path,
)
from ballscrew_twin.params import load_config

RPM = 2 * math.pi / 60

#: Cold solves in this order on one model: rising speeds of one line (as the table build
#: solves them), a lower speed of it, another temperature, then the line again and the other
#: speed sign; -20 C and 50 N are in the multi-valued light-preload region.
POINTS = (
    (300.0, -20.0, 50.0),
    (1000.0, -20.0, 50.0),
    (2600.0, -20.0, 50.0),
    (600.0, -20.0, 50.0),
    (1.5, -20.0, 50.0),
    (2600.0, 20.0, 50.0),
    (3900.0, -20.0, 50.0),
    (-2600.0, -20.0, 50.0),
)


@pytest.fixture(scope="module")
def config():  # type: ignore[no-untyped-def]
    return load_config()


def op(rpm: float, celsius: float, preload: float) -> OperatingPoint:
    return OperatingPoint(screw_speed=rpm * RPM, temperature=celsius + 273.15, preload=preload)


def counted(model: SteadyStateModel) -> list[int]:
    """Count the Newton solves of ``model`` (wraps its bound method)."""
    calls = [0]
    newton = model._newton

    def wrapped(*args, **kwargs):  # type: ignore[no-untyped-def]
        calls[0] += 1
        return newton(*args, **kwargs)

    model._newton = wrapped  # type: ignore[method-assign]
    return calls


def test_a_resumed_start_up_path_is_the_path_from_the_start_up_speed(config) -> None:  # type: ignore[no-untyped-def]
    used = SteadyStateModel(config, mode="symmetric")
    used_calls = counted(used)
    saved = 0
    for rpm, celsius, preload in POINTS:
        point = op(rpm, celsius, preload)
        fresh = SteadyStateModel(config, mode="symmetric")
        fresh_calls = counted(fresh)
        expected = fresh.solve(point)
        used.forget_warm_start()
        before = used_calls[0]
        solved = used.solve(point)
        for name in ("ball_nb", "kinematics", "nut_offset"):
            assert np.array_equal(getattr(solved.state, name), getattr(expected.state, name))
        assert solved.output.drag_torque == expected.output.drag_torque
        assert solved.iterations == expected.iterations
        saved += fresh_calls[0] - (used_calls[0] - before)
    # The second and third points and the line after the other temperature resume their
    # paths (steps from below half their speed are shared), so they solve less.
    assert abs(POINTS[1][0]) * RPM > 4 * STARTUP_MAX_RATIO * STARTUP_SPEED
    assert saved > 0


def test_a_forgotten_start_up_path_is_climbed_again(config) -> None:  # type: ignore[no-untyped-def]
    point = op(*POINTS[1])
    fresh = SteadyStateModel(config, mode="symmetric")
    fresh_calls = counted(fresh)
    expected = fresh.solve(point).output.drag_torque
    used = SteadyStateModel(config, mode="symmetric")
    used.solve(op(*POINTS[0]))
    used_calls = counted(used)
    used.forget_warm_start()
    forget_startup_path(used)
    assert used.solve(point).output.drag_torque == expected
    assert used_calls[0] == fresh_calls[0]  # the whole path from the start-up speed
