"""Defects the dynamic model can carry: a defective sphere, a raceway spall, a sphere jam.

Both act on the interpenetration of the contacts they touch (the approach of Eq. 17): an
oversized sphere of radius r_b + dr interferes by dr more with every half groove; a spall is a
hollow of depth d in one half groove, so a sphere passing over it loses up to d of approach.
The spall's profile along the thread is d cos^2(pi (theta - theta_0) / w) for
|theta - theta_0| < w / 2 (smooth entry and exit), theta the helix parameter of the contact on
the grooved body: the screw's own for S1/S2, the nut's own for N1/N2 (a nut point at nut
parameter theta_n meets the spheres at screw parameter theta_n - phi, phi the screw angle).
The radius change does not alter the sphere's mass or contact curvatures (second order).

A jammed sphere (debris wedged against it, a damaged sphere stuck in the nut) has its rotation
blocked from a given time on: its angular velocity is held at zero in the inertial frame, i.e.
relative to the nut, which does not turn. It then slides on every groove instead of rolling; the
blocking moment does no work (zero angular velocity), so the power balance is untouched except
for the sphere's rotational energy, lost at the instant the jam begins.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import ConfigError
from ..params import check_number, from_mapping, limits, quantity, validate_fields
from ..physics.geometry import HALF_GROOVE_NAMES, IS_NUT

FloatArray = NDArray[np.float64]


#: Largest change of a sphere's radius a fault may give [m].
MAX_RADIUS_CHANGE = 5e-5
#: Most spheres a nut may hold (the parameter sets' limit of balls_per_nut) [-].
MAX_SPHERES = 500


def _nut() -> Any:
    return quantity("-", 0, 1, "nut of the sphere: 0 master, 1 slave", integer=True)


def _index() -> Any:
    return quantity(
        "-", 0, MAX_SPHERES - 1, "sphere of that nut, 0 .. balls_per_nut - 1", integer=True
    )


@dataclass(frozen=True, kw_only=True)
class SphereDefect:
    """A sphere whose radius differs from nominal (wear, wrong grade, debris on it)."""

    nut: int = _nut()
    index: int = _index()
    radius_change: float = quantity(
        "m", -MAX_RADIUS_CHANGE, MAX_RADIUS_CHANGE, "change of the radius, positive: oversized"
    )

    def __post_init__(self) -> None:
        """Every number within its field's range (params.validate_fields)."""
        validate_fields(self, "sphere defect")


@dataclass(frozen=True, kw_only=True)
class RacewaySpall:
    """A local hollow in one half groove (fatigue spall, pit)."""

    half_groove: str  # S1, S2, N1 or N2
    centre: float = quantity("rad", -1e4, 1e4, "helix parameter of its centre on the grooved body")
    width: float = quantity("rad", 1e-4, 2.0 * math.pi, "extent along the thread")
    depth: float = quantity("m", 0.0, 1e-4, "largest depth")

    def __post_init__(self) -> None:
        """A half groove by its name, every number within its field's range."""
        if self.half_groove not in HALF_GROOVE_NAMES:
            raise ConfigError(
                f"half_groove: {self.half_groove!r} is not one of {HALF_GROOVE_NAMES}"
            )
        validate_fields(self, "raceway spall")


@dataclass(frozen=True, kw_only=True)
class SphereJam:
    """A sphere whose rotation is blocked from ``start`` on."""

    nut: int = _nut()
    index: int = _index()
    start: float = quantity("s", 0.0, 100.0, "simulated time at which the rotation is blocked")

    def __post_init__(self) -> None:
        """Every number within its field's range (params.validate_fields)."""
        validate_fields(self, "sphere jam")


#: The kinds of fault a scene's ``faults`` mapping may list.
FAULT_KINDS = ("spheres", "spalls", "jams")


@dataclass(frozen=True)
class Faults:
    """All defects of one scene."""

    spheres: tuple[SphereDefect, ...] = ()
    spalls: tuple[RacewaySpall, ...] = ()
    jams: tuple[SphereJam, ...] = ()

    def jammed(
        self, time: float, ball_nut: NDArray[np.int64], ball_index: NDArray[np.int64]
    ) -> NDArray[np.bool_]:
        """(B,) True for the spheres whose rotation is blocked at ``time`` [s]."""
        blocked = np.zeros(len(ball_nut), dtype=bool)
        for jam in self.jams:
            if time >= jam.start:
                blocked |= (ball_nut == jam.nut) & (ball_index == jam.index)
        return blocked

    def approach_offsets(
        self,
        helix_parameter: FloatArray,
        screw_angle: float,
        ball_nut: NDArray[np.int64],
        ball_index: NDArray[np.int64],
    ) -> FloatArray | None:
        """(B, 4) change of each contact's approach [m], or None without defects.

        Args:
            helix_parameter: (B,) helix parameter of each sphere in the screw frame [rad].
            screw_angle: phi, screw rotation since the start [rad].
            ball_nut: (B,) nut of each sphere.
            ball_index: (B,) index of each sphere within its nut.
        """
        if not self.spheres and not self.spalls:
            return None
        offset = np.zeros((len(helix_parameter), 4))
        for defect in self.spheres:
            rows = (ball_nut == defect.nut) & (ball_index == defect.index)
            offset[rows] += defect.radius_change
        for spall in self.spalls:
            column = HALF_GROOVE_NAMES.index(spall.half_groove)
            theta = helix_parameter + (screw_angle if IS_NUT[column] else 0.0)
            x = (theta - spall.centre) / spall.width
            inside = np.abs(x) < 0.5
            offset[:, column] -= np.where(inside, spall.depth * np.cos(math.pi * x) ** 2, 0.0)
        return offset

    def compiled_arrays(
        self, count: int, ball_nut: NDArray[np.int64], ball_index: NDArray[np.int64]
    ) -> tuple[FloatArray, FloatArray]:
        """The defects as the compiled step takes them (kernels/dynamic_step.py).

        Returns:
            (B, 4) approach offsets of the defective spheres [m], and (S, 4) spalls: half-groove
            column (0..3), centre [rad], width [rad], depth [m].
        """
        sphere = np.zeros((count, 4))
        for defect in self.spheres:
            rows = (ball_nut == defect.nut) & (ball_index == defect.index)
            sphere[rows] += defect.radius_change
        spalls = np.array(
            [
                [HALF_GROOVE_NAMES.index(s.half_groove), s.centre, s.width, s.depth]
                for s in self.spalls
            ],
            dtype=np.float64,
        ).reshape(-1, 4)
        return sphere, spalls


def _sphere_of(fault: SphereDefect | SphereJam, balls_per_nut: int, path: str) -> None:
    """The sphere a fault entry names must exist: index 0 .. balls_per_nut - 1."""
    check_number(
        fault.index, limits("-", 0, balls_per_nut - 1, integer=True), f"{path}.index", text=False
    )


def _entries(data: Mapping[str, Any], key: str) -> list[Any]:
    """The list of faults under ``key`` (absent or null: none)."""
    return list(data.get(key) or [])


def faults_from_mapping(data: Any, balls_per_nut: int, where: str) -> Faults:
    """Validate ``{spheres: [...], spalls: [...], jams: [...]}`` (all optional) into
    :class:`Faults`: every entry by :func:`~ballscrew_twin.params.from_mapping` (unknown and
    missing keys, each number against its field's unit and range, a spall's half groove by
    name), and the sphere an entry names must be one of the ``balls_per_nut`` of its nut."""
    if data is None:
        return Faults()
    if not isinstance(data, dict):
        raise ConfigError(f"{where}: expected a mapping, got {type(data).__name__}")
    unknown = sorted(str(key) for key in set(data) - set(FAULT_KINDS))
    if unknown:
        raise ConfigError(f"{where}: unknown key(s) {unknown}; allowed: {list(FAULT_KINDS)}")
    spheres = []
    for k, item in enumerate(_entries(data, "spheres")):
        path = f"{where}.spheres[{k}]"
        defect = from_mapping(SphereDefect, item, path)
        _sphere_of(defect, balls_per_nut, path)
        spheres.append(defect)
    spalls = []
    for k, item in enumerate(_entries(data, "spalls")):
        path = f"{where}.spalls[{k}]"
        spalls.append(from_mapping(RacewaySpall, item, path))
    jams = []
    for k, item in enumerate(_entries(data, "jams")):
        path = f"{where}.jams[{k}]"
        jam = from_mapping(SphereJam, item, path)
        _sphere_of(jam, balls_per_nut, path)
        jams.append(jam)
    return Faults(spheres=tuple(spheres), spalls=tuple(spalls), jams=tuple(jams))
