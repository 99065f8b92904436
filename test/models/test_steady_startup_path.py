"""The start-up path of a cold solve resumed from the kept start of a step it shares with the
path before (steady_continuation.StartupPath): the result is the path followed from the
start-up speed by a fresh model, to the last bit, and it takes fewer Newton solves."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from ballscrew_twin.errors import SolverError
from ballscrew_twin.models.base import OperatingPoint
from ballscrew_twin.models.steady import SteadyStateModel
from ballscrew_twin.models.steady_continuation import (
    STARTUP_MAX_RATIO,
    STARTUP_SPEED,
    startup_continuation,
    static_solve,
)
from ballscrew_twin.params import default_config_path, load_config
from ballscrew_twin.units import CELSIUS_ZERO, RPM

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
    return OperatingPoint(
        screw_speed=rpm * RPM, temperature=celsius + CELSIUS_ZERO, preload=preload
    )


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
    used.forget_startup_path()
    assert used.solve(point).output.drag_torque == expected
    assert used_calls[0] == fresh_calls[0]  # the whole path from the start-up speed


def test_a_start_up_path_that_stops_is_not_climbed_again() -> None:
    """The 32 x 10 screw at 20 C and 3.9 N: the path to 12.74 rad/s (backwards) stops where no
    step up to the ratio 2 converges (measured: at 6.31 rad/s, every speed tried below 12.74);
    the path to 50 rad/s is the same up there and stops there too: raised without a solve."""
    config = load_config(default_config_path().parent / "screw_32x10.yaml")
    point = OperatingPoint(screw_speed=-50.0, temperature=293.15, preload=3.90625)
    used = SteadyStateModel(config, mode="symmetric")
    balls = used.ball_set("symmetric")
    for speed in (-9.984, -12.74):
        below = replace(point, screw_speed=speed)
        with pytest.raises(SolverError, match="start-up path stopped"):
            startup_continuation(used, below, balls, used.nut_axial_loads(below))
    fresh = SteadyStateModel(config, mode="symmetric")
    fresh_calls = counted(fresh)
    loads = fresh.nut_axial_loads(point)
    with pytest.raises(SolverError, match="start-up path stopped") as expected:
        startup_continuation(fresh, point, fresh.ball_set("symmetric"), loads)
    used_calls = counted(used)
    with pytest.raises(SolverError) as raised:
        startup_continuation(used, point, balls, loads)
    assert str(raised.value) == str(expected.value)
    assert used_calls[0] == 0 < fresh_calls[0]


def test_a_failed_static_equilibrium_is_raised_again_without_a_solve() -> None:
    """The 32 x 10 screw at 20 C and 8.98 N: the preload about balances the nut's weight, the
    static equilibrium from the Hertz start does not converge in 80 iterations (measured).
    The second cold solve of a node of that line raises the kept failure without the Newton
    solves of the first, leaves the same Jacobian blocks, and every node after it is the
    fresh model's, to the last bit."""
    config = load_config(default_config_path().parent / "screw_32x10.yaml")
    used = SteadyStateModel(config, mode="symmetric")
    balls = used.ball_set("symmetric")
    still = OperatingPoint(screw_speed=0.0, temperature=293.15, preload=8.98)
    loads = used.nut_axial_loads(still)
    with pytest.raises(SolverError, match="did not converge") as first:
        static_solve(used, still.temperature, balls, loads)
    assert used._jacobian is not None
    blocks = used._jacobian[0].copy()
    used._jacobian = None
    used_calls = counted(used)
    with pytest.raises(SolverError) as again:
        static_solve(used, still.temperature, balls, loads)
    assert str(again.value) == str(first.value)
    assert used_calls[0] == 0
    assert used._jacobian is not None and np.array_equal(used._jacobian[0], blocks)
    for rpm in (0.0, 5.0, 300.0):
        point = replace(still, screw_speed=rpm * RPM)
        fresh = SteadyStateModel(config, mode="symmetric")
        fresh_calls = counted(fresh)
        used.forget_warm_start()
        before = used_calls[0]
        results = []
        for model in (fresh, used):
            try:
                results.append(model.solve(point).output.drag_torque)
            except SolverError as err:
                results.append(str(err))
        assert results[0] == results[1]
        assert used_calls[0] - before < fresh_calls[0]
