"""Tabulated steady state: the symmetric steady-state model on a grid, interpolated.

The two nuts of a preloaded double nut are independent in the steady state (the screw turns at
the commanded speed; each nut balances its own spheres against its own axial load), and on a
vertical screw every sphere of a nut is equivalent (symmetric mode). So one table holds, for
each nut, the drag torque by mechanism and the states of one sphere's four half-groove contacts
as functions of

- the screw speed, for each sign separately (a reversal is not a mirror image: the slips differ
  by a few per cent), on nodes uniform in log |speed| between ``speed_min`` and ``speed_max``;
- the temperature, on nodes uniform in ln(T - 138 K) (:func:`~.map_grid.temperature_coordinate`);
- the nut's *equivalent preload* (the preload that loads the nut alike with no external load:
  preload + axial load for the master nut, the preload for the slave nut; see
  :func:`~.map_grid.equivalent_preloads`), on nodes uniform in the fourth root of
  (equivalent preload + 10 N) (:func:`~.map_grid.preload_coordinate`; the Hertz laws and the
  spheres' film and motion change fastest at light load).

Between the nodes each quantity is a tensor product of Catmull-Rom cubics (C1; the edge cells
use a linearly extrapolated ghost node). The nut's drag torque is interpolated along the
preload first, as it is, and then along speed and temperature as asinh(T /
:data:`TORQUE_SCALE`), which is logarithmic for torques well above the scale, so the power laws
of the film and the viscosity become nearly linear (along the preload a light nut's torque can
pass near zero, where a logarithm has no cubic to follow:
:func:`~.map_interpolation.torque_stencil`); the mechanisms are interpolated as they are and
then corrected to add up to that torque. The contact states, which the drag
torque does not depend on, are kept on every other node of each axis (a quarter of the
file). Below ``speed_min`` the torque goes linearly to zero and the contact states are blended
linearly towards the standstill solution; outside the grid the inputs are clamped;
:meth:`SteadyMap.sample` says which. Nodes where the steady solver fails, even cold with its
continuation, are filled from their nearest solved neighbour in speed (a line solved at no
speed: the nearest such line in preload) and flagged; a sample that leans on a filled node
says so.

Modules: :mod:`.map_grid` (what is tabulated, on which nodes), :mod:`.map_interpolation` (the
Catmull-Rom stencils), here the table itself (:class:`SteadyMap`, :func:`load_map`),
:mod:`.map_build` (solving the nodes) and :mod:`.map_store` (the user's cache and
:func:`~.map_store.find_map`). Build the committed table with ``ballscrew-twin map build --out
ballscrew_twin/data/steady_map.npz --force`` (progress bar; 2 worker processes by default); any
other screw's table goes to the user's cache under its parameter set's fingerprint
(:func:`config_fingerprint`). A table is only ever used for the parameter set it was built for.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import NDArray

from ..errors import MapError
from ..units import CELSIUS_ZERO, RPM
from .base import MECHANISMS
from .map_grid import (
    CONTACT_FIELDS,
    HALF_GROOVES,
    LOG_SCALES,
    NUT_NAMES,
    NUTS,
    TORQUE_SCALE,
    MapGrid,
)
from .map_interpolation import (
    SLOPE_LIMIT,
    AxisCell,
    Positions,
    QueryCells,
    axis_cell,
    folded_position,
    folded_rows,
    pad_axis,
    preload_line,
    preload_node,
    query_cells,
    stencil,
    stencil_2d,
    stencil_position,
    temperature_node,
    torque_stencil,
)

FloatArray = NDArray[np.float64]

#: Format version of the saved file; a file of another version is refused. 4: the same nodes
#: and arrays as 3, solved with the fold rule (docs/model.md 7a, "Past a fold"): a node past a
#: fold of the start-up path may hold another state than before, so a table built earlier is
#: built again; 3: temperature nodes uniform in :func:`~.map_grid.temperature_coordinate` (2:
#: uniform in temperature); 2: preload nodes uniform in :func:`~.map_grid.preload_coordinate`
#: (1: in the square root of the preload).
FORMAT_VERSION = 4
#: Speed planes :meth:`SteadyMap._speed_planes` keeps (one per block of a commissioning
#: fit's 600) [-].
PLANE_CACHE = 2048
#: The committed map of the default parameter set (package data).
DEFAULT_MAP_PATH = Path(__file__).resolve().parent.parent / "data" / "steady_map.npz"
_LOG_FIELDS = np.array([name in LOG_SCALES for name in CONTACT_FIELDS])
_LOG_SCALE_VALUES = np.array([LOG_SCALES[name] for name in CONTACT_FIELDS if name in LOG_SCALES])
#: The scales by field, 1 where the field is interpolated as it is (the compiled kernel's form).
_LOG_SCALES_FULL = np.array([LOG_SCALES.get(name, 1.0) for name in CONTACT_FIELDS])
#: Lower bound of each field after interpolation: 0 except for the contact angle.
_LOWER_BOUND = np.array([-np.inf if name == "contact_angle" else 0.0 for name in CONTACT_FIELDS])


#: One nut's interpolated torque values, contact rows and standstill rows (None: not needed).
_NutStencils = tuple[FloatArray, FloatArray, FloatArray | None]


def _nut_torques(values: FloatArray, blend: float) -> FloatArray:
    """(2, 6) torque per nut and mechanism [N m] from the interpolated (2, 1 + 6) values
    (asinh of the nut torque, then the mechanisms), scaled by the standstill ``blend`` [-]."""
    total = TORQUE_SCALE * np.sinh(values[:, :1])
    mechanisms = values[:, 1:]
    # Share the difference to the total out in proportion to each mechanism's size.
    magnitude = np.abs(mechanisms)
    size = magnitude.sum(axis=1, keepdims=True)
    share = np.divide(magnitude, size, out=np.zeros_like(magnitude), where=size > 0.0)
    return (mechanisms + (total - mechanisms.sum(axis=1, keepdims=True)) * share) * blend


@dataclass(frozen=True)
class MapSample:
    """Interpolated state of both nuts at one query.

    Attributes:
        torque: (2, 6) drag torque per nut and mechanism [N m] (it has the sign of the speed).
        contacts: (2, 4, F) contact quantities per nut and half groove, :data:`CONTACT_FIELDS`;
            None when the sample was taken without them.
        notes: clamping, standstill blending and filled nodes, in words.
    """

    torque: FloatArray
    contacts: FloatArray | None
    notes: tuple[str, ...] = field(default_factory=tuple)


@dataclass(frozen=True)
class SteadyMap:
    """The tables and their interpolation (see the module docstring).

    Attributes:
        grid: nodes of the torque table.
        torque: (2 signs, S, T, P, 2 nuts, 6) drag torque per mechanism [N m].
        contacts: (2, S', T', P', 2, 4, F) contact quantities (:data:`CONTACT_FIELDS`, SI) on
            ``grid.coarse()``.
        static: (T', P', 2, 4, F) contact quantities at standstill on ``grid.coarse()``.
        filled: (2, S, T, P) nodes filled from a neighbour because the solver failed there.
        fingerprint: :func:`config_fingerprint` of the parameter set the map was built for.
        orientation: screw orientation of that parameter set.
    """

    grid: MapGrid
    torque: NDArray[np.floating]
    contacts: NDArray[np.floating]
    static: NDArray[np.floating]
    filled: NDArray[np.bool_]
    fingerprint: str
    orientation: str
    # The tables as the interpolation reads them: "torque" (2, S, T, P, 2, 1 + 6), the nut torque
    # then its mechanisms, not padded; "contacts" and "static" with their asinh fields, padded.
    _prepared: dict[str, FloatArray] = field(default_factory=dict, compare=False, repr=False)
    _coarse: MapGrid | None = field(default=None, compare=False, repr=False)
    _any_filled: bool = field(default=False, compare=False, repr=False)
    _planes: dict[tuple[float, float, float], FloatArray] = field(
        default_factory=dict, compare=False, repr=False
    )
    _filled_window: NDArray[np.bool_] = field(
        default_factory=lambda: np.zeros((2, 1, 1, 1), dtype=bool), compare=False, repr=False
    )

    def __post_init__(self) -> None:
        self.grid.check_buildable()
        g, c = self.grid, self.grid.coarse()
        shape = (2, g.speed_nodes, g.temperature_nodes, g.preload_nodes)
        coarse = (2, c.speed_nodes, c.temperature_nodes, c.preload_nodes)
        expected = {
            "torque": (*shape, NUTS, len(MECHANISMS)),
            "contacts": (*coarse, NUTS, HALF_GROOVES, len(CONTACT_FIELDS)),
            "static": (*coarse[2:], NUTS, HALF_GROOVES, len(CONTACT_FIELDS)),
            "filled": shape,
        }
        for name, want in expected.items():
            table = getattr(self, name)
            if table.shape != want:
                raise MapError(f"steady map: {name} has shape {table.shape}, the grid needs {want}")
            if name != "filled" and not np.isfinite(table).all():
                raise MapError(f"steady map: {name} holds non-finite values")
        mechanisms = np.asarray(self.torque, dtype=np.float64)
        # Not padded: the edge cells fold the ghost node's weight (folded_position), because
        # the nut torque is transformed between the preload and the other axes.
        torque = np.concatenate([mechanisms.sum(axis=-1, keepdims=True), mechanisms], axis=-1)
        contacts = np.asarray(self.contacts, dtype=np.float64).copy()
        contacts[..., _LOG_FIELDS] = np.arcsinh(contacts[..., _LOG_FIELDS] / _LOG_SCALE_VALUES)
        contacts = contacts.reshape(*coarse, NUTS, -1)
        static = np.asarray(self.static, dtype=np.float64).reshape(*coarse[2:], NUTS, -1)
        for axis in (1, 2, 3):
            contacts = pad_axis(contacts, axis)
        for axis in (0, 1):
            static = pad_axis(static, axis)
        self._prepared.update(torque=torque, contacts=contacts, static=static)
        object.__setattr__(self, "_coarse", c)
        object.__setattr__(self, "_any_filled", bool(self.filled.any()))
        # [sign, s, t, p]: whether filled[sign, s:s+4, t:t+4, p:p+4] holds a filled node.
        ends = ((0, 0), (0, 3), (0, 3), (0, 3))
        padded_filled = np.pad(np.asarray(self.filled, dtype=bool), ends)
        window = sliding_window_view(padded_filled, (4, 4, 4), axis=(1, 2, 3))
        object.__setattr__(self, "_filled_window", window.any(axis=(-3, -2, -1)))

    @property
    def node_count(self) -> int:
        """Number of speed x temperature x preload nodes of the torque table (both signs)."""
        return int(self.filled.size)

    def _clamp_notes(
        self, speed: float, temperature: float, preloads: tuple[float, float]
    ) -> list[str]:
        g = self.grid
        notes = []
        if speed > g.speed_max:
            notes.append(
                f"speed {speed / RPM:.0f} rpm above the map's {g.speed_max / RPM:.0f} rpm: "
                "clamped to it"
            )
        if 0.0 < speed < g.speed_min:
            notes.append(
                f"speed {speed / RPM:.3g} rpm below the map's {g.speed_min / RPM:.3g} rpm: "
                "torque and contacts blended linearly to standstill"
            )
        if not g.temperature_min <= temperature <= g.temperature_max:
            notes.append(
                f"temperature {temperature - CELSIUS_ZERO:.1f} C outside the map "
                f"[{g.temperature_min - CELSIUS_ZERO:.0f}, {g.temperature_max - CELSIUS_ZERO:.0f}]"
                " C: clamped"
            )
        for name, preload in zip(NUT_NAMES, preloads, strict=True):
            if not 0.0 <= preload <= g.preload_max:
                notes.append(
                    f"{name} nut equivalent preload {preload:.0f} N outside the map "
                    f"[0, {g.preload_max:.0f}] N: clamped"
                )
        return notes

    def _filled_near(self, sign: int, cells: tuple[int, int, int]) -> bool:
        """Whether the fine stencil of the (speed, temperature, preload) ``cells`` of ``sign``
        uses a filled node (or one next to it)."""
        s, t, p = (max(cell - 1, 0) for cell in cells)
        return bool(self._filled_window[sign, s, t, p])

    def sample(
        self,
        screw_speed: float,
        temperature: float,
        preloads: tuple[float, float],
        contacts: bool = True,
        compiled: bool = True,
    ) -> MapSample:
        """Interpolate both nuts.

        Args:
            screw_speed: signed screw speed [rad/s].
            temperature: temperature [K].
            preloads: equivalent preload of the (master, slave) nut [N],
                :func:`~.map_grid.equivalent_preloads`.
            contacts: interpolate the contact states too (False: torque only, about half the
                work; ``MapSample.contacts`` is None).
            compiled: the numba kernels of ``kernels/map_sample.py`` (~10 us); False: the numpy
                reference :meth:`_interpolate_reference` (~100 us), equal to rounding.
        """
        g, c = self.grid, self._coarse
        assert c is not None
        sign = 0 if screw_speed >= 0.0 else 1
        speed = abs(screw_speed)
        notes = self._clamp_notes(speed, temperature, preloads)
        blend = min(speed / g.speed_min, 1.0)  # 1 on the map, -> 0 at standstill
        fine = query_cells(g, speed, temperature, preloads)
        coarse = query_cells(c, speed, temperature, preloads) if contacts else None
        interpolate = self._interpolate_compiled if compiled else self._interpolate_reference
        torque, states = interpolate(sign, fine, coarse, blend)
        if self._any_filled:
            for nut, (preload_cell, _) in enumerate(fine.preloads):
                if self._filled_near(sign, (fine.speed[0], fine.temperature[0], preload_cell)):
                    notes.append(
                        f"{NUT_NAMES[nut]} nut: interpolated near map nodes where the steady "
                        "solver failed (filled from the nearest solved speed or preload)"
                    )
        return MapSample(torque, states, tuple(notes))

    def total_torque(
        self, screw_speeds: FloatArray, temperature: float, preloads: tuple[float, float]
    ) -> FloatArray:
        """Total drag torque of both nuts [N m] at many speeds [rad/s] and one temperature [K]
        and pair of equivalent preloads [N] (numpy, vectorised over the speeds; no notes).

        The same tensor Catmull-Rom of the nut torque as :meth:`sample` (its total is the sum
        of ``sample(...).torque``), for a caller that follows a measured speed trajectory;
        queries beyond the map are clamped to it as there.
        """
        g = self.grid
        speeds = np.asarray(screw_speeds, dtype=np.float64)
        magnitude = np.abs(speeds)
        u = np.log(np.maximum(magnitude, g.speed_min) / g.speed_min) / math.log(
            g.speed_max / g.speed_min
        )
        u = np.clip(u * (g.speed_nodes - 1), 0.0, g.speed_nodes - 1.0)
        cells = np.minimum(u.astype(np.int64), g.speed_nodes - 2)
        starts, ws = folded_rows(cells, u - cells, g.speed_nodes)
        planes = self._speed_planes(temperature, preloads)
        total = np.zeros(len(speeds))
        sign = (speeds < 0.0).astype(np.int64)
        columns = starts[:, None] + np.arange(4)[None, :]
        for plane in planes:
            rows = plane[sign[:, None], columns]  # (N, 4)
            total += TORQUE_SCALE * np.sinh(np.sum(rows * ws, axis=1))
        blend = np.minimum(magnitude / g.speed_min, 1.0)
        return np.asarray(total * blend)

    def _speed_planes(self, temperature: float, preloads: tuple[float, float]) -> FloatArray:
        """(nut, sign, S): asinh(nut torque / TORQUE_SCALE) on every speed node at one
        ``temperature`` [K] and pair of equivalent ``preloads`` [N], interpolated along the
        preload and the temperature (:meth:`total_torque`'s first two axes). The last
        PLANE_CACHE of them are kept: a fit that varies only other unknowns asks for the
        same ones again (``ballscrew-twin commission``)."""
        key = (temperature, *preloads)
        cached = self._planes.get(key)
        if cached is not None:
            return cached
        g = self.grid
        temperature_pos = folded_position(
            axis_cell(temperature_node(g, temperature), g.temperature_nodes), g.temperature_nodes
        )
        t0 = temperature_pos.start
        planes = np.empty((NUTS, 2, g.speed_nodes))
        for nut, preload in enumerate(preloads):
            cell = axis_cell(preload_node(g, preload), g.preload_nodes)
            # (sign, S, 4, P) nut torques around the temperature cell.
            table = self._prepared["torque"][:, :, t0 : t0 + 4, :, nut, 0]
            lines = np.arcsinh(preload_line(table, 3, cell) / TORQUE_SCALE)
            planes[nut] = np.einsum("abj,j->ab", lines, temperature_pos.weights)
        if len(self._planes) >= PLANE_CACHE:
            self._planes.clear()
        self._planes[key] = planes
        return planes

    def _interpolate_reference(
        self, sign: int, fine: QueryCells, coarse: QueryCells | None, blend: float
    ) -> tuple[FloatArray, FloatArray | None]:
        """(2, 6) torques [N m] and (2, 4, F) contact states, or None without ``coarse``, of
        speed ``sign`` (0: >= 0) at the query's cells on the fine (torque) and coarse
        (contact) grids, with the standstill ``blend`` [-]: the readable numpy reference."""
        g = self.grid
        torque_table = self._prepared["torque"][sign]
        speed = folded_position(fine.speed, g.speed_nodes)
        temperature = folded_position(fine.temperature, g.temperature_nodes)
        values = np.empty((NUTS, len(MECHANISMS) + 1))
        if coarse is None:
            stencils: dict[AxisCell, FloatArray] = {}
            for nut, cell in enumerate(fine.preloads):
                if cell not in stencils:  # one stencil when the nuts' loads agree
                    stencils[cell] = torque_stencil(torque_table, speed, temperature, cell)
                values[nut] = stencils[cell][nut]
            return _nut_torques(values, blend), None
        coarse_speed = stencil_position(coarse.speed)
        coarse_temperature = stencil_position(coarse.temperature)
        rows = np.empty((NUTS, HALF_GROOVES * len(CONTACT_FIELDS)))
        still = np.empty_like(rows)
        solved: dict[tuple[AxisCell, AxisCell], _NutStencils] = {}
        for nut, cells in enumerate(zip(fine.preloads, coarse.preloads, strict=True)):
            if cells not in solved:  # both nuts at once; one stencil when the loads agree
                coarse_pos = Positions(coarse_speed, coarse_temperature, stencil_position(cells[1]))
                solved[cells] = (
                    torque_stencil(torque_table, speed, temperature, cells[0]),
                    stencil(self._prepared["contacts"][sign], coarse_pos),
                    stencil_2d(self._prepared["static"], coarse_pos) if blend < 1.0 else None,
                )
            nut_values, nut_rows, nut_still = solved[cells]
            values[nut], rows[nut] = nut_values[nut], nut_rows[nut]
            if nut_still is not None:
                still[nut] = nut_still[nut]
        torque = _nut_torques(values, blend)
        states = rows.reshape(NUTS, HALF_GROOVES, len(CONTACT_FIELDS))
        states[..., _LOG_FIELDS] = _LOG_SCALE_VALUES * np.sinh(states[..., _LOG_FIELDS])
        if blend < 1.0:
            states = states * blend + still.reshape(states.shape) * (1.0 - blend)
        np.maximum(states, _LOWER_BOUND, out=states)
        return torque, states

    def _interpolate_compiled(
        self, sign: int, fine: QueryCells, coarse: QueryCells | None, blend: float
    ) -> tuple[FloatArray, FloatArray | None]:
        """As :meth:`_interpolate_reference`, by the kernels of ``kernels/map_sample.py``."""
        from ..kernels import map_sample

        cells = np.array([cell for cell, _ in fine.preloads], dtype=np.int64)
        fractions = np.array([fraction for _, fraction in fine.preloads])
        torque = map_sample.nut_torques(
            self._prepared["torque"][sign],
            fine.speed,
            fine.temperature,
            cells,
            fractions,
            blend,
            TORQUE_SCALE,
            SLOPE_LIMIT,
        )
        if coarse is None:
            return torque, None
        cells = np.array([cell for cell, _ in coarse.preloads], dtype=np.int64)
        fractions = np.array([fraction for _, fraction in coarse.preloads])
        states = map_sample.contact_states(
            self._prepared["contacts"][sign],
            self._prepared["static"],
            coarse.speed,
            coarse.temperature,
            cells,
            fractions,
            blend,
            _LOG_FIELDS,
            _LOG_SCALES_FULL,
            _LOWER_BOUND,
        )
        return torque, states

    # ------------------------------------------------------------------ files

    def save(self, path: str | Path) -> None:
        """Write the map as a compressed ``.npz`` file."""
        np.savez_compressed(
            Path(path),
            format_version=np.array(FORMAT_VERSION),
            grid=self.grid.as_array(),
            torque=np.asarray(self.torque, dtype=np.float32),
            contacts=np.asarray(self.contacts, dtype=np.float32),
            static=np.asarray(self.static, dtype=np.float32),
            filled=self.filled,
            fingerprint=np.array(self.fingerprint),
            orientation=np.array(self.orientation),
            contact_fields=np.array(CONTACT_FIELDS),
            mechanisms=np.array(MECHANISMS),
        )


def load_map(path: str | Path | None = None) -> SteadyMap:
    """Read a map written by :meth:`SteadyMap.save` (default: the committed one).

    Raises:
        MapError: the file is missing, unreadable, of another format version, tabulates other
            quantities or holds inconsistent tables.
    """
    file = Path(path) if path is not None else DEFAULT_MAP_PATH
    try:
        with np.load(file, allow_pickle=False) as data:
            version = int(data["format_version"])
            if version != FORMAT_VERSION:
                raise MapError(f"{file}: format_version = {version}, expected {FORMAT_VERSION}")
            fields_ = tuple(str(x) for x in data["contact_fields"])
            mechanisms = tuple(str(x) for x in data["mechanisms"])
            if fields_ != CONTACT_FIELDS or mechanisms != tuple(MECHANISMS):
                raise MapError(f"{file}: tabulates other quantities than this version reads")
            return SteadyMap(
                grid=MapGrid.from_array(data["grid"]),
                torque=np.asarray(data["torque"]),
                contacts=np.asarray(data["contacts"]),
                static=np.asarray(data["static"]),
                filled=np.asarray(data["filled"], dtype=bool),
                fingerprint=str(data["fingerprint"]),
                orientation=str(data["orientation"]),
            )
    except MapError as err:
        if str(file) in str(err):
            raise
        raise MapError(f"{file}: {err}") from err
    except (OSError, KeyError, ValueError, TypeError, EOFError) as err:
        raise MapError(f"{file}: not a readable steady map ({err})") from err
