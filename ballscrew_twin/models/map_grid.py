"""What the steady map tabulates and on which nodes: its layout, :class:`MapGrid`, :func:`grid_for`.

The table holds, per speed sign, speed, temperature and equivalent-preload node and per nut, the
drag torque by mechanism and the states of one sphere's four half-groove contacts
(:data:`CONTACT_FIELDS`); :mod:`.steady_map` reads it, :mod:`.map_build` fills it. SI units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from ..errors import MapError
from ..params import TwinConfig
from ..physics.lubricant import ROELANDS_T_INF
from ..units import CELSIUS_ZERO, RPM
from .base import OperatingPoint

FloatArray = NDArray[np.float64]

#: Torque scale of the asinh transform of the nut torque [N m] (linear below, log above).
TORQUE_SCALE = 1e-6
#: Contact quantities tabulated per half groove (names of :class:`~.base.ContactStates`);
#: ``in_contact`` is tabulated as 0/1 and read back as "interpolated value > 0.5".
CONTACT_FIELDS: tuple[str, ...] = (
    "normal_force",
    "friction_force",
    "contact_angle",
    "approach",
    "stiffness",
    "max_pressure",
    "semi_axis_x",
    "semi_axis_y",
    "film_thickness",
    "tallian_parameter",
    "load_share",
    "shear_stress",
    "lubricant_share",
    "slip_speed",
    "in_contact",
)
#: Contact fields that follow power laws of speed, viscosity and load (the film and what it
#: drives): interpolated as asinh(value / scale), logarithmic well above the scale (SI units).
LOG_SCALES: dict[str, float] = {
    "friction_force": 1e-9,
    "film_thickness": 1e-12,
    "tallian_parameter": 1e-6,
    "shear_stress": 1e-3,
    "slip_speed": 1e-9,
}
HALF_GROOVES = 4
NUTS = 2
NUT_NAMES = ("master", "slave")
#: Node counts (speed, temperature, preload) of the preview table of a new screw: built in
#: seconds, it serves while the full table is built (its error is measured by ``bench screw``).
PREVIEW_NODES = (9, 7, 9)
#: The preload nodes are uniform in :func:`preload_coordinate`, (preload + PRELOAD_OFFSET) **
#: (1 / PRELOAD_ROOT): dense at 5-100 N, where the spheres' start-up state changes fastest with
#: the preload (docs/model.md 7a; with the 41 nodes of :class:`MapGrid` 10 below 100 N: 0, 4.0,
#: 9.0, 15.3, 23.0, 32.3, 43.6, 56.9, 72.5, 90.8 N, against 5 of 33 uniform in sqrt(preload)),
#: without the lines below 4 N that a plain fourth root adds and whose nodes mostly fail, each
#: running every fallback of the steady solver (docs/benchmarks.md, issue 14). Root [-].
PRELOAD_ROOT = 4
#: Offset of the preload coordinate [N] (see :data:`PRELOAD_ROOT`).
PRELOAD_OFFSET = 10.0
#: How far a table's speed nodes reach above the screw's critical speed (at most to the packaged
#: 6000 rpm) [-]. Two cells of the 49-node speed axis span a factor of about 1.6, so the cell that
#: holds the critical speed reads an interior Catmull-Rom stencil, not the end cell's
#: extrapolated ghost node: the 32 mm screw's drag steepens below its 4000 rpm (31.0 mN m at
#: 3095 rpm, 46.8 at 4243 rpm at 88 C / 1496 N), and a table ending at 4000 rpm was 2.9 % off
#: at 3725 rpm, one reaching to 6000 rpm 0.84 % (docs/benchmarks.md, issue 14). A critical speed
#: of about 4700-6000 rpm still lies in the top cell below 6000 rpm, with its one-sided stencil.
SPEED_REACH = 1.6
#: The temperature nodes are uniform in :func:`temperature_coordinate`, ln(T - TEMPERATURE_POLE):
#: dense where the lubricant is cold. Roelands' viscosity law (Eq. 24) makes ln(eta) + 9.67
#: proportional to (T - 138 K)^-S0, which bends fastest near its pole; in ln(T - 138 K) the film
#: laws that follow the viscosity are nearly straight lines. With 29 nodes over -40..100 C the
#: nodes are 3.1 K apart at -40 C and 7.5 K at 100 C (5 K each when uniform in T, which left the
#: 32 mm screw's drag 4.4 % off at -37.4 C: docs/benchmarks.md, issue 14) [K].
TEMPERATURE_POLE = ROELANDS_T_INF


def preload_coordinate(preload: float) -> float:
    """The coordinate [N^(1/4)] in which the preload nodes are uniform, 0 at 0 N, of a preload
    [N] >= 0."""
    return float((preload + PRELOAD_OFFSET) ** (1.0 / PRELOAD_ROOT) - _COORDINATE_ZERO)


def preload_at(coordinate: FloatArray) -> FloatArray:
    """The preloads [N] of :func:`preload_coordinate` values >= 0 (its inverse; 0 N exactly at
    0, not a rounding error below it)."""
    return np.maximum((coordinate + _COORDINATE_ZERO) ** PRELOAD_ROOT - PRELOAD_OFFSET, 0.0)


_COORDINATE_ZERO = PRELOAD_OFFSET ** (1.0 / PRELOAD_ROOT)


def temperature_coordinate(temperature: float) -> float:
    """The coordinate [-] in which the temperature nodes are uniform, ln((T - 138 K) / 1 K), of a
    temperature T [K] > 138 K (see :data:`TEMPERATURE_POLE`)."""
    return math.log(temperature - TEMPERATURE_POLE)


def equivalent_preloads(op: OperatingPoint) -> tuple[float, float]:
    """Preload [N] that loads the (master, slave) nut as ``op`` does, with no external load.

    The external axial load acts on the master nut only (``SteadyStateModel.nut_axial_loads``),
    so the master nut carries preload + axial load and the slave nut the preload.
    """
    return op.preload + op.axial_load, op.preload


@dataclass(frozen=True)
class MapGrid:
    """Nodes of the map (odd node counts for a map: the contact table keeps every other node).

    Attributes:
        speed_min: lowest tabulated |screw speed| [rad/s] (> 0).
        speed_max: highest tabulated |screw speed| [rad/s].
        speed_nodes: nodes per speed sign, uniform in log |speed|.
        temperature_min: lowest temperature [K].
        temperature_max: highest temperature [K].
        temperature_nodes: nodes uniform in :func:`temperature_coordinate`.
        preload_max: highest equivalent preload [N] (the lowest is 0 N).
        preload_nodes: nodes uniform in :func:`preload_coordinate` (41: with 33 the drag
            of the paper screw at 3900 rpm, 53-60 C, 56-60 N was up to 1.4 % off, its curve
            over the preload bending between the nodes at 46.7 and 64.4 N).
    """

    speed_min: float = 0.05 * RPM
    speed_max: float = 6000.0 * RPM
    speed_nodes: int = 49
    temperature_min: float = CELSIUS_ZERO - 40.0
    temperature_max: float = CELSIUS_ZERO + 100.0
    temperature_nodes: int = 29
    preload_max: float = 4000.0
    preload_nodes: int = 41

    def __post_init__(self) -> None:
        cold, hot = self.temperature_min, self.temperature_max
        checks = (
            ("speed_min", 0.0 < self.speed_min < self.speed_max, "rad/s, 0 < speed_min < max"),
            ("temperature_min", TEMPERATURE_POLE < cold < hot, "K, 138 K < temperature_min < max"),
            ("preload_max", self.preload_max > 0.0, "N, > 0"),
        )
        for name, ok, unit in checks:
            if not ok:
                raise MapError(f"map grid: {name} = {getattr(self, name)!r} is invalid ({unit})")
        for name in ("speed_nodes", "temperature_nodes", "preload_nodes"):
            if getattr(self, name) < 2:
                raise MapError(f"map grid: {name} = {getattr(self, name)} must be >= 2")

    def check_buildable(self) -> None:
        """Raise :class:`MapError` unless every node count is odd and >= 5 (see :meth:`coarse`)."""
        for name in ("speed_nodes", "temperature_nodes", "preload_nodes"):
            count = getattr(self, name)
            if count < 5 or count % 2 == 0:
                raise MapError(f"map grid: {name} = {count} must be odd and >= 5")

    @property
    def speeds(self) -> FloatArray:
        """|Speed| nodes [rad/s], ascending."""
        low, high = math.log(self.speed_min), math.log(self.speed_max)
        return np.exp(np.linspace(low, high, self.speed_nodes))

    @property
    def temperatures(self) -> FloatArray:
        """Temperature nodes [K], uniform in :func:`temperature_coordinate`."""
        low = temperature_coordinate(self.temperature_min)
        high = temperature_coordinate(self.temperature_max)
        return TEMPERATURE_POLE + np.exp(np.linspace(low, high, self.temperature_nodes))

    @property
    def preloads(self) -> FloatArray:
        """Equivalent-preload nodes [N], uniform in :func:`preload_coordinate`."""
        top = preload_coordinate(self.preload_max)
        return preload_at(np.linspace(0.0, top, self.preload_nodes))

    def coarse(self) -> MapGrid:
        """Every other node of each axis (the grid of the contact table)."""
        return replace(
            self,
            speed_nodes=self.speed_nodes // 2 + 1,
            temperature_nodes=self.temperature_nodes // 2 + 1,
            preload_nodes=self.preload_nodes // 2 + 1,
        )

    def as_array(self) -> FloatArray:
        """The grid as 8 numbers (for saving)."""
        return np.array(
            [
                self.speed_min,
                self.speed_max,
                self.speed_nodes,
                self.temperature_min,
                self.temperature_max,
                self.temperature_nodes,
                self.preload_max,
                self.preload_nodes,
            ],
            dtype=np.float64,
        )

    @classmethod
    def from_array(cls, values: FloatArray) -> MapGrid:
        """Inverse of :meth:`as_array`."""
        v = [float(x) for x in values]
        if len(v) != 8:
            raise MapError(f"map grid: {len(v)} numbers, expected 8")
        return cls(v[0], v[1], int(v[2]), v[3], v[4], int(v[5]), v[6], int(v[7]))


def grid_for(config: TwinConfig, preview: bool = False) -> MapGrid:
    """The grid of ``config``'s table: the packaged table's nodes, with the speed range ending at
    :data:`SPEED_REACH` times the screw's critical speed when that is below 6000 rpm. The
    validity envelope clamps any command faster than the critical speed, but the nodes above it
    hold the upper end of the stencils of the cells below it. ``preview``: the
    :data:`PREVIEW_NODES` grid over the same ranges."""
    grid = MapGrid()
    # params.py keeps the critical speed >= 1 rad/s, far above the lowest node (0.05 rpm).
    grid = replace(grid, speed_max=min(grid.speed_max, SPEED_REACH * config.screw.critical_speed))
    if preview:
        speed, temperature, preload = PREVIEW_NODES
        grid = replace(
            grid, speed_nodes=speed, temperature_nodes=temperature, preload_nodes=preload
        )
    return grid
