"""The steady model's solved state and solution, and the moves along solutions.

:class:`SteadyState` holds the unknowns of a solve (reusable as a warm start), :class:`BallSet`
the spheres solved, :class:`SteadySolution` a converged state with what it implies. The
functions compare two solutions (:func:`rate_change`, :func:`continues_branch`: is a warm solve
on its start's branch) and start a solve on the line through two (:func:`along_line`,
:func:`secant_start`; compiled: :func:`ballscrew_twin.kernels.steady_solver.extrapolate`).
Units: SI (m, rad/s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, TypeVar, Union

import numpy as np
from numpy.typing import NDArray

from ..physics.contact_types import ContactEvaluation
from .base import TwinOutput

if TYPE_CHECKING:
    from ..kernels.steady_solver import KernelSolution

FloatArray = NDArray[np.float64]

#: Temperatures (and speeds, loads, notes) whose derived values a model keeps (oldest dropped
#: beyond) [-].
SCENE_CACHE_SIZE = 64

Key = TypeVar("Key")
Value = TypeVar("Value")


def kept(cache: dict[Key, Value], key: Key, value: Value) -> Value:
    """Keep ``value`` under ``key`` in one of a model's caches and return it; the oldest entry
    goes first when the cache holds SCENE_CACHE_SIZE (insertion order)."""
    if key not in cache and len(cache) >= SCENE_CACHE_SIZE:
        del cache[next(iter(cache))]
    cache[key] = value
    return value


#: A step of the start-up path is rejected when any rate of a sphere over the screw speed
#: changes by more than this, relative to 1 + its size (a jump to another branch) [-].
BRANCH_JUMP = 0.05

#: Contacts of a solve: the numpy evaluation (readable backends) or the compiled solver's result.
ContactSource = Union[ContactEvaluation, "KernelSolution"]


@dataclass(frozen=True)
class BallSet:
    """The spheres solved: their nut, azimuth and how many physical spheres each stands for."""

    nut: NDArray[np.int64]  # (B,) 0 master, 1 slave
    azimuth: FloatArray  # (B,) rad
    weight: FloatArray  # (B,) physical spheres represented
    gravity: FloatArray  # (B, 3) m/s^2 in Frenet components


@dataclass
class SteadyState:
    """Solved unknowns, reusable as a warm start."""

    ball_nb: FloatArray  # (B, 2) m
    kinematics: FloatArray  # (B, 4) rad/s
    nut_offset: FloatArray  # (2,) m
    screw_speed: float  # rad/s at which it was solved
    #: returned by a warm solve of the compiled solver, polished until a step with old Jacobian
    #: blocks no longer cut its residual: as the start of its own point it needs no polishing
    polished: bool = False


@dataclass(frozen=True)
class SteadySolution:
    """A converged steady state with what it implies (``contacts``: every contact quantity at
    the solution, built on first use from ``contact_source``)."""

    output: TwinOutput
    state: SteadyState
    balls: BallSet
    contact_source: ContactSource
    screw_torque_direct: float  # N m, sum of moments of the spheres on the screw (with gravity)
    gravity_torque: float  # N m, the part of the direct torque that lifts nuts and spheres
    iterations: int
    residual: float  # max scaled residual at convergence

    @cached_property
    def contacts(self) -> ContactEvaluation:
        """Forces, moments, states and dissipation of every contact at the solution."""
        source = self.contact_source
        if isinstance(source, ContactEvaluation):
            return source
        from ..kernels.contacts import evaluation_from_buffer

        return evaluation_from_buffer(source.active, source.buffer)


def along_line(old: SteadyState, last: SteadyState, fraction: float, speed: float) -> SteadyState:
    """Start at ``speed`` [rad/s] on the line through two solutions at speeds of its sign:
    offsets [m] and rates over the speed [-] (the rolling pattern) moved beyond ``last`` by
    ``fraction`` [-] times their step from ``old``, the rates then times ``speed``. The readable
    form of :func:`~ballscrew_twin.kernels.steady_solver.extrapolate`."""
    rates = last.kinematics / last.screw_speed
    rates = rates + fraction * (rates - old.kinematics / old.screw_speed)
    return SteadyState(
        last.ball_nb + fraction * (last.ball_nb - old.ball_nb),
        rates * speed,
        last.nut_offset + fraction * (last.nut_offset - old.nut_offset),
        speed,
    )


def secant_start(previous: SteadyState, last: SteadyState, speed: float) -> SteadyState:
    """Start at ``speed`` [rad/s] on the line through two solutions at speeds of its sign, in
    log |speed| (:func:`along_line`): the fraction log(speed / last speed) / log(last speed /
    previous speed), limited to [0, 2]."""
    span = math.log(last.screw_speed / previous.screw_speed)
    fraction = min(max(math.log(speed / last.screw_speed) / span, 0.0), 2.0)
    return along_line(previous, last, fraction, speed)


def continues_branch(previous: SteadyState, solved: SteadyState) -> bool:
    """``solved``, warm-started from ``previous``, is on its branch: at standstill (one static
    equilibrium), or at a speed of the same sign with no :func:`rate_change` beyond
    :data:`BRANCH_JUMP`."""
    if solved.screw_speed == 0.0:
        return True
    if previous.screw_speed * solved.screw_speed <= 0.0:
        return False
    return rate_change(previous, solved) <= BRANCH_JUMP


def rate_change(old: SteadyState, new: SteadyState) -> float:
    """Largest change of a sphere's rate over the screw speed between two solutions at speeds
    of one sign, each relative to 1 + its old size [-] (orbital rate and angular velocity:
    about 0.5 and 6 times the screw speed when rolling)."""
    before = old.kinematics / old.screw_speed
    after = new.kinematics / new.screw_speed
    return float(np.max(np.abs(after - before) / (1.0 + np.abs(before))))
