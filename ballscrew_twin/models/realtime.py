"""Real-time model for the node: the tabulated steady state, stepped quasi-statically.

Each step returns the steady state of the step's command, interpolated from a
:class:`~.steady_map.SteadyMap` of the symmetric steady-state model (tens of microseconds
instead of milliseconds of Newton iterations). It follows speed ramps, reversals through zero
speed, temperature drift and preload changes as a sequence of steady states and carries no
transient state: the dynamic model's own transients after a change (sphere rattle, nut
settling, controller overshoot; tens of milliseconds on the scenes of issue 4) are not
reproduced. How far that and the interpolation are from the steady and the dynamic model is
measured by ``ballscrew-twin bench accuracy`` (docs/benchmarks.md, "Work-precision").

On a vertical screw every sphere of a nut is equivalent, so the per-sphere contact states are
the map's per-nut states repeated over the nut's spheres. The external axial load enters
through each nut's equivalent preload (:func:`~.map_grid.equivalent_preloads`). Commands
outside the map are clamped to it and every clamping is named in ``notes``.

Cost per step: a caller that does not need the contact states on a tick (the node publishes
them at a tenth of its step rate) passes ``contacts=False`` and gets ``contacts=None`` and
only the torque interpolated. The output depends on the command alone, so an unchanged command
returns the previous output without interpolating again (~1.3 us); a new command costs ~30 us
(torque) or ~85 us (with the 200 contact rows), the interpolation compiled
(``kernels/map_sample.py``; the numpy reference took ~110 / ~160 us).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..errors import ConfigError, MapError
from ..params import TwinConfig, config_fingerprint
from .base import MECHANISMS, ContactStates, FloatArray, OperatingPoint, TorqueBreakdown, TwinOutput
from .map_grid import CONTACT_FIELDS, HALF_GROOVES, NUTS, equivalent_preloads
from .steady_map import SteadyMap, load_map

_FIELD = {name: j for j, name in enumerate(CONTACT_FIELDS)}
#: Tabulated 0/1 contact flag read back as "in contact" above this value [-].
IN_CONTACT_THRESHOLD = 0.5
#: Shares that cannot exceed one (clamped after interpolation).
_UNIT_SHARES = ("load_share", "lubricant_share")


class RealTimeModel:
    """Quasi-static stepping of the tabulated symmetric steady state (``TimeSteppingModel``).

    Args:
        config: parameter set; it must be the one the map was built for.
        steady_map: the map (default: the committed ``ballscrew_twin/data/steady_map.npz``).
        compiled: interpolate with the compiled kernels (default); False: the numpy reference
            (the same numbers to rounding, ~3x the time; for comparisons).

    Raises:
        MapError: the map is missing or corrupt, or was built for other physical parameters
            (rebuild it with ``ballscrew-twin map build``).
    """

    def __init__(
        self, config: TwinConfig, steady_map: SteadyMap | None = None, compiled: bool = True
    ) -> None:
        table = steady_map if steady_map is not None else load_map()
        if table.fingerprint != config_fingerprint(config):
            raise MapError(
                f"steady map built for other parameters than {config.name!r} "
                "(fingerprints differ): build its table with 'ballscrew-twin map build "
                "--config YOUR.yaml'"
            )
        self.config = config
        self.map = table
        self.compiled = compiled
        self.name = "realtime_map"
        count = config.screw.balls_per_nut
        self._balls_per_nut = count
        self._sphere = np.repeat(np.arange(NUTS * count), HALF_GROOVES)
        self._nut = np.repeat(np.arange(NUTS), count * HALF_GROOVES)
        self._half_groove = np.tile(np.arange(HALF_GROOVES), NUTS * count)
        for index in (self._sphere, self._nut, self._half_groove):
            index.flags.writeable = False  # shared by every output
        notes = [f"real-time map of the symmetric steady state ({count} spheres per nut alike)"]
        if config.screw.orientation != "vertical":
            notes.append(
                "horizontal screw: gravity differs from sphere to sphere, which the symmetric "
                "map does not resolve (error measured by bench accuracy)"
            )
        self._notes = tuple(notes)
        #: Last command and its output without / with contact states (None: not computed).
        self._last: tuple[OperatingPoint, TwinOutput | None, TwinOutput | None] | None = None
        # Load the compiled interpolation now rather than on the first step, which would stall
        # a real-time caller (0.4 s from numba's cache, ~4 s when it compiles on a first run).
        grid = table.grid
        table.sample(grid.speed_min, grid.temperature_min, (0.0, 0.0), True, compiled)

    #: ``step`` and ``evaluate`` take ``contacts=False`` (read by ``ValidatedModel``).
    optional_contacts = True

    def reset(self, op: OperatingPoint) -> None:
        """Check ``op``; the model keeps no transient state to forget."""
        op.validate()

    def step(self, op: OperatingPoint, dt: float, contacts: bool = True) -> TwinOutput:
        """The tabulated steady state of ``op`` after a tick of ``dt`` [s] (finite, > 0).

        ``contacts=False``: the output's ``contacts`` is None (torques unchanged, less work).
        """
        if not (math.isfinite(dt) and dt > 0.0):
            raise ConfigError(f"dt = {dt!r} s must be a finite number > 0")
        return self.evaluate(op, contacts)

    def evaluate(self, op: OperatingPoint, contacts: bool = True) -> TwinOutput:
        """The tabulated steady state of ``op`` (also a ``SteadyStateModel``); ``contacts=False``
        leaves the contact states out (None). A repeated command returns the cached output."""
        last = self._last
        if last is None or last[0] != op:  # NaN never equals: a bad op is always validated
            op.validate()
            last = (op, None, None)
        plain, full = last[1], last[2]
        if contacts:
            if full is None:
                full = self._interpolate(op, contacts=True)
            out = full
        else:
            if plain is None:
                plain = (
                    replace(full, contacts=None)
                    if full is not None
                    else self._interpolate(op, contacts=False)
                )
            out = plain
        self._last = (op, plain, full)
        return out

    def _interpolate(self, op: OperatingPoint, contacts: bool) -> TwinOutput:
        """Interpolate the map at a validated ``op``."""
        sample = self.map.sample(
            op.screw_speed,
            op.temperature,
            equivalent_preloads(op),
            contacts=contacts,
            compiled=self.compiled,
        )
        per_nut = sample.torque.sum(axis=1)
        by_mechanism = sample.torque.sum(axis=0).tolist()
        breakdown = TorqueBreakdown(**dict(zip(MECHANISMS, by_mechanism, strict=True)))
        return TwinOutput(
            drag_torque=float(per_nut.sum()),
            nut_torque=(float(per_nut[0]), float(per_nut[1])),
            breakdown=breakdown,
            fidelity="realtime-map",
            operating_point=op,
            contacts=None if sample.contacts is None else self._contact_states(sample.contacts),
            notes=(*self._notes, *sample.notes),
        )

    def _contact_states(self, per_nut: FloatArray) -> ContactStates:
        """Repeat the (2, 4, F) per-nut states over every sphere of each nut."""
        by_field = np.repeat(per_nut.transpose(2, 0, 1)[:, :, None, :], self._balls_per_nut, axis=2)
        columns = by_field.reshape(len(CONTACT_FIELDS), -1)  # (F, rows), each row contiguous
        for name in _UNIT_SHARES:
            np.minimum(columns[_FIELD[name]], 1.0, out=columns[_FIELD[name]])
        friction = columns[_FIELD["friction_force"]]
        lubricant = columns[_FIELD["lubricant_share"]]

        def column(name: str) -> FloatArray:
            return columns[_FIELD[name]]

        return ContactStates(
            sphere=self._sphere,
            nut=self._nut,
            half_groove=self._half_groove,
            in_contact=column("in_contact") > IN_CONTACT_THRESHOLD,
            normal_force=column("normal_force"),
            friction_force=friction,
            contact_angle=column("contact_angle"),
            approach=column("approach"),
            stiffness=column("stiffness"),
            max_pressure=column("max_pressure"),
            semi_axis_x=column("semi_axis_x"),
            semi_axis_y=column("semi_axis_y"),
            film_thickness=column("film_thickness"),
            tallian_parameter=column("tallian_parameter"),
            load_share=column("load_share"),
            shear_stress=column("shear_stress"),
            lubricant_share=lubricant,
            dry_share=np.where(friction > 0.0, 1.0 - lubricant, 0.0),
            slip_speed=column("slip_speed"),
        )
