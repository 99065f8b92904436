"""The interface every fidelity level shares: operating point in, :class:`TwinOutput` out."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Any, Protocol, TypeVar

import numpy as np
from numpy.typing import NDArray

from ..errors import OperatingPointError

FloatArray = NDArray[np.float64]
_Frozen = TypeVar("_Frozen")


@dataclass(frozen=True, kw_only=True)
class OperatingPoint:
    """Commanded operating condition of the screw.

    Attributes:
        screw_speed: screw angular speed about its axis [rad/s]; the sign is the direction.
        temperature: bulk temperature of screw, nut, spheres and lubricant [K].
        preload: preload force between the two nuts [N], >= 0.
        axial_load: external axial load on the nut assembly along +z [N].
    """

    screw_speed: float
    temperature: float
    preload: float
    axial_load: float = 0.0

    def validate(self) -> None:
        """Raise :class:`OperatingPointError` naming the first invalid quantity."""
        isfinite = math.isfinite
        if not (
            isfinite(self.screw_speed)
            and isfinite(self.temperature)
            and isfinite(self.preload)
            and isfinite(self.axial_load)
        ):
            for name in ("screw_speed", "temperature", "preload", "axial_load"):
                value = getattr(self, name)
                if not isfinite(value):
                    raise OperatingPointError(f"{name} = {value!r} is not a finite number")
        if self.temperature <= 138.0:
            raise OperatingPointError(
                f"temperature = {self.temperature} K is at or below 138 K, where the Roelands "
                "law is undefined (temperatures are in kelvin, not degrees Celsius)"
            )
        if self.preload < 0.0:
            raise OperatingPointError(f"preload = {self.preload} N must be >= 0")


@dataclass(frozen=True, kw_only=True)
class TorqueBreakdown:
    """Drag torque on the screw split by mechanism [N m].

    For models that resolve mechanisms the fields sum to the drag torque; the catalogue model
    resolves none and leaves them all zero.
    """

    lubricant_shear: float = 0.0
    dry_contact: float = 0.0
    rolling_resistance: float = 0.0
    hysteresis: float = 0.0
    curvature: float = 0.0
    spin: float = 0.0

    @property
    def total(self) -> float:
        """Sum of all mechanisms [N m]."""
        return float(sum(getattr(self, f.name) for f in fields(self)))


@dataclass(frozen=True, kw_only=True)
class ContactStates:
    """State of every sphere/half-groove contact, arrays of equal length (one row a contact).

    Half grooves are numbered 0..3 = S1, S2, N1, N2; nuts 0 = master (upper), 1 = slave.
    """

    sphere: NDArray[np.int64]
    nut: NDArray[np.int64]
    half_groove: NDArray[np.int64]
    in_contact: NDArray[np.bool_]
    normal_force: FloatArray  # N
    friction_force: FloatArray  # N, magnitude of the sliding traction F_t (Eq. 36)
    contact_angle: FloatArray  # rad (Eq. 8)
    approach: FloatArray  # m, interpenetration delta (Eq. 17)
    stiffness: FloatArray  # N m^-1.5, K_H
    max_pressure: FloatArray  # Pa
    semi_axis_x: FloatArray  # m, rolling direction
    semi_axis_y: FloatArray  # m, transverse
    film_thickness: FloatArray  # m, total central film h_Tc (Eq. 33)
    tallian_parameter: FloatArray  # - (Eq. 38)
    load_share: FloatArray  # -, asperity share f(Lambda) (Eq. 37)
    shear_stress: FloatArray  # Pa, lubricant shear stress (Eq. 35)
    lubricant_share: FloatArray  # -, lubricant part of F_t / F_t
    dry_share: FloatArray  # -, dry part of F_t / F_t
    slip_speed: FloatArray  # m/s, |v_t| at the contact centre (Eq. 12)


class _RowContactStates(ContactStates):
    """:class:`ContactStates` whose float fields are the rows of one (fields, contacts) array,
    made views of their rows when one of them is first read (built by
    :func:`contact_states_from_rows`).

    Everything else is the dataclass's: ``fields``, ``replace`` (which builds it with every
    field set), ``repr`` and pickling read the fields through ``getattr`` like any caller.
    """

    def __getattr__(self, name: str) -> Any:
        # Called only for an attribute not set: before the first read of a float field. Setting
        # the views is idempotent, so two threads reading at once both get them.
        values = vars(self)
        names = values.get("_row_names")
        if names is None or name not in names:
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")
        values.update(zip(names, values["_rows"], strict=True))
        return values[name]


def contact_states_from_rows(
    sphere: NDArray[np.int64],
    nut: NDArray[np.int64],
    half_groove: NDArray[np.int64],
    in_contact: NDArray[np.bool_],
    rows: FloatArray,
    row_names: tuple[str, ...],
) -> ContactStates:
    """:class:`ContactStates` of a model that lays the float fields out as one array.

    Args:
        sphere, nut, half_groove, in_contact: the fields of the same names (C,).
        rows: (F, C) array, row k the field ``row_names[k]`` in its unit (see
            :class:`ContactStates`); not copied.
        row_names: every float field of :class:`ContactStates`, in the order of ``rows``.

    Returns:
        The states, the float fields views of their rows made when the first of them is read
        (a caller that reads none, e.g. a tick that publishes no contact states, makes none).
    """
    states = object.__new__(_RowContactStates)
    # A frozen dataclass refuses attribute assignment; its instance dictionary is the
    # documented storage of the fields (what the generated __init__ fills).
    vars(states).update(
        sphere=sphere,
        nut=nut,
        half_groove=half_groove,
        in_contact=in_contact,
        _rows=rows,
        _row_names=row_names,
    )
    return states


@dataclass(frozen=True, kw_only=True)
class TwinOutput:
    """What a model returns for one operating point.

    Attributes:
        drag_torque: torque the drive must apply to the screw to hold its speed [N m]; it has
            the sign of the speed (positive drag opposes positive rotation).
        nut_torque: share of ``drag_torque`` from the master and slave nut spheres [N m].
        breakdown: the same torque split by mechanism.
        fidelity: name of the model that produced it.
        contacts: per-contact states, when the model resolves them.
        notes: what the model skipped or clamped, and why.
    """

    drag_torque: float
    nut_torque: tuple[float, float]
    breakdown: TorqueBreakdown
    fidelity: str
    operating_point: OperatingPoint
    contacts: ContactStates | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)


def filled(cls: type[_Frozen], **values: Any) -> _Frozen:
    """An instance of the frozen dataclass ``cls`` with ``values``, which must name every field
    (defaults are not applied), equal to ``cls(**values)``.

    The generated ``__init__`` of a frozen dataclass sets each field by ``object.__setattr__``
    (~0.1 us a field); this fills the instance dictionary, where those calls store the fields,
    at once. For the outputs of a model called at 1 kHz, whose values are its own.
    """
    instance = object.__new__(cls)
    vars(instance).update(values)
    return instance


#: The mechanisms of the drag-torque breakdown (the fields of :class:`TorqueBreakdown`).
MECHANISMS: tuple[str, ...] = tuple(f.name for f in fields(TorqueBreakdown))
#: Every dissipation the contact laws report: the mechanisms and the normal damping of
#: Eqs. 18-19 (zero in a steady state, so not part of a steady breakdown).
DISSIPATION_KEYS: tuple[str, ...] = (*MECHANISMS, "normal_damping")


class SteadyStateModel(Protocol):
    """Anything that maps an operating point to a drag torque."""

    name: str

    def evaluate(self, op: OperatingPoint) -> TwinOutput:
        """Drag torque and (if resolved) contact states at ``op``."""
        ...


class TimeSteppingModel(Protocol):
    """A model stepped in time by the node: the commands of each tick in, one output out.

    Every fidelity level offers this interface (catalogue and steady state quasi-statically,
    the real-time model, the dynamic model through :class:`~.dynamic_loop.DynamicStepping`;
    :func:`~.registry.as_stepping`), so the node can switch between them at run time.
    """

    name: str

    def reset(self, op: OperatingPoint) -> None:
        """Forget the past and start in the steady state of ``op``."""
        ...

    def step(self, op: OperatingPoint, dt: float) -> TwinOutput:
        """Advance by ``dt`` [s] under the commanded ``op``; return the state at the step's end."""
        ...


class QuasiStaticModel:
    """A steady-state model used as a time-stepping one: each tick is the steady state of its
    command (no memory, no transient). Exact for slow commands; the error in transients is what
    the accuracy benchmark measures.
    """

    def __init__(self, model: SteadyStateModel) -> None:
        self.model = model
        self.name = f"quasi_static_{model.name}"

    def reset(self, op: OperatingPoint) -> None:
        """Nothing to forget: the model has no state."""
        op.validate()

    def step(self, op: OperatingPoint, dt: float) -> TwinOutput:
        """The steady state of ``op`` (``dt`` [s] is not used)."""
        return self.model.evaluate(op)
