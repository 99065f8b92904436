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
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import ConfigError
from ..physics.geometry import HALF_GROOVE_NAMES, IS_NUT

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, kw_only=True)
class SphereDefect:
    """A sphere whose radius differs from nominal (wear, wrong grade, debris on it)."""

    nut: int  # 0 master, 1 slave
    index: int  # sphere of that nut, 0 .. balls_per_nut - 1
    radius_change: float  # m, positive: oversized


@dataclass(frozen=True, kw_only=True)
class RacewaySpall:
    """A local hollow in one half groove (fatigue spall, pit)."""

    half_groove: str  # S1, S2, N1 or N2
    centre: float  # rad, helix parameter of its centre on the grooved body
    width: float  # rad, extent along the thread
    depth: float  # m, largest depth


@dataclass(frozen=True, kw_only=True)
class SphereJam:
    """A sphere whose rotation is blocked from ``start`` on."""

    nut: int  # 0 master, 1 slave
    index: int  # sphere of that nut, 0 .. balls_per_nut - 1
    start: float  # s, simulated time at which the rotation is blocked


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


def _number(item: dict[str, Any], key: str, lo: float, hi: float, unit: str, where: str) -> float:
    """A finite number within [lo, hi] from ``item[key]``."""
    if key not in item:
        raise ConfigError(f"{where}.{key}: missing")
    try:
        value = float(item[key])
    except (TypeError, ValueError):
        raise ConfigError(
            f"{where}.{key}: expected a number in {unit}, got {item[key]!r}"
        ) from None
    if not (math.isfinite(value) and lo <= value <= hi):
        raise ConfigError(f"{where}.{key} = {item[key]!r} is outside [{lo:g}, {hi:g}] {unit}")
    return value


def _fields(item: Any, allowed: Sequence[str], where: str) -> dict[str, Any]:
    if not isinstance(item, dict):
        raise ConfigError(f"{where}: expected a mapping, got {type(item).__name__}")
    unknown = sorted(set(item) - set(allowed))
    if unknown:
        raise ConfigError(f"{where}: unknown key(s) {unknown}; allowed: {list(allowed)}")
    return item


def _sphere_of(item: dict[str, Any], balls_per_nut: int, path: str) -> tuple[int, int]:
    """The (nut, index) a fault entry names: whole numbers, nut 0..1, index 0..Z-1."""
    nut = _number(item, "nut", 0, 1, "-", path)
    index = _number(item, "index", 0, balls_per_nut - 1, "-", path)
    if nut != int(nut) or index != int(index):
        raise ConfigError(f"{path}: nut and index must be whole numbers")
    return int(nut), int(index)


def faults_from_mapping(data: Any, balls_per_nut: int, where: str) -> Faults:
    """Validate ``{spheres: [...], spalls: [...], jams: [...]}`` (all optional) into
    :class:`Faults`."""
    if data is None:
        return Faults()
    data = _fields(data, ("spheres", "spalls", "jams"), where)
    spheres = []
    for k, item in enumerate(data.get("spheres") or []):
        path = f"{where}.spheres[{k}]"
        item = _fields(item, ("nut", "index", "radius_change"), path)
        nut, index = _sphere_of(item, balls_per_nut, path)
        change = _number(item, "radius_change", -5e-5, 5e-5, "m", path)
        spheres.append(SphereDefect(nut=nut, index=index, radius_change=change))
    spalls = []
    for k, item in enumerate(data.get("spalls") or []):
        path = f"{where}.spalls[{k}]"
        item = _fields(item, ("half_groove", "centre", "width", "depth"), path)
        groove = item.get("half_groove")
        if groove not in HALF_GROOVE_NAMES:
            raise ConfigError(f"{path}.half_groove: {groove!r} is not one of {HALF_GROOVE_NAMES}")
        spalls.append(
            RacewaySpall(
                half_groove=str(groove),
                centre=_number(item, "centre", -1e4, 1e4, "rad", path),
                width=_number(item, "width", 1e-4, 2.0 * math.pi, "rad", path),
                depth=_number(item, "depth", 0.0, 1e-4, "m", path),
            )
        )
    jams = []
    for k, item in enumerate(data.get("jams") or []):
        path = f"{where}.jams[{k}]"
        item = _fields(item, ("nut", "index", "start"), path)
        nut, index = _sphere_of(item, balls_per_nut, path)
        start = _number(item, "start", 0.0, 100.0, "s", path)
        jams.append(SphereJam(nut=nut, index=index, start=start))
    return Faults(spheres=tuple(spheres), spalls=tuple(spalls), jams=tuple(jams))
