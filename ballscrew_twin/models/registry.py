"""The package's models by name: one name for each (:class:`ModelName`), one :func:`build`.

The command line (``drag``, ``sweep``), the twin node's fidelity levels, the scene runner and
the benchmarks build their models here. Each of those interfaces keeps the spellings it
accepted before this registry (:data:`SPELLINGS`, the one place they are mapped): ``drag
--model catalog`` is Eq. 51 there, while the node's and the scenes' ``catalog`` is Eq. 52 (the
catalogue formula the paper compares against). The canonical names are accepted everywhere.

:func:`build` returns the model as its class defines it: the catalogue formula, the steady
state and the real-time model answer ``evaluate(op)``; the real-time model also steps in time;
the dynamic model integrates its own state (``initial_state``, ``step``). :func:`as_evaluating`
and :func:`as_stepping` give the interface a caller needs: every model steps in time
(:class:`~.base.TimeSteppingModel`), every one but the dynamic model evaluates an operating
point (:func:`as_evaluating` says why the dynamic one does not).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import TYPE_CHECKING, Literal, TypeAlias, cast

from ..errors import ConfigError, MapError
from ..params import TwinConfig
from .base import QuasiStaticModel, SteadyStateModel, TimeSteppingModel
from .catalog import CatalogModel
from .faults import Faults

if TYPE_CHECKING:
    from .dynamic import DynamicModel
    from .realtime import RealTimeModel
    from .steady import SteadyStateModel as SteadySolver
    from .steady_map import SteadyMap


class ModelName(StrEnum):
    """Every model of the package, by its one canonical name."""

    #: catalogue formula Eq. 51 (manufacturers' literature)
    CATALOG_LITERATURE = "catalog-literature"
    #: catalogue formula Eq. 52 (Zhou et al. 2016)
    CATALOG_ZHOU = "catalog-zhou"
    #: steady state of every loaded sphere, symmetric or full as the operating point allows
    STEADY = "steady"
    #: steady state, one sphere per nut (every sphere of a nut alike)
    STEADY_SYMMETRIC = "steady-symmetric"
    #: steady state, every sphere solved
    STEADY_FULL = "steady-full"
    #: the real-time model: the steady state tabulated for the screw, stepped in time
    REALTIME = "realtime"
    #: the dynamic multibody model (every sphere 6 DOF)
    DYNAMIC = "dynamic"


#: Where older spellings are accepted: the ``--model`` option of ``drag`` and ``sweep``, the
#: twin node's ``fidelity`` parameter, and the model names of the fidelity selection (scene
#: files, ``config/fidelity_bounds.yaml``, ``selection.json``).
Interface = Literal["cli", "node", "scene"]

#: The spellings each interface accepted before the registry, mapped to the model they meant.
SPELLINGS: dict[Interface, dict[str, ModelName]] = {
    "cli": {
        "catalog": ModelName.CATALOG_LITERATURE,
        "zhou": ModelName.CATALOG_ZHOU,
    },
    "node": {
        "catalog": ModelName.CATALOG_ZHOU,
        "quasi_static": ModelName.STEADY,
    },
    "scene": {
        "catalog": ModelName.CATALOG_ZHOU,
    },
}

#: Spheres the steady model solves (``--mode``, the node's ``steady_mode``).
SteadyMode = Literal["auto", "symmetric", "full"]
_STEADY_MODES: dict[ModelName, SteadyMode] = {
    ModelName.STEADY: "auto",
    ModelName.STEADY_SYMMETRIC: "symmetric",
    ModelName.STEADY_FULL: "full",
}


def accepted_names(interface: Interface | None = None) -> tuple[str, ...]:
    """The names ``interface`` accepts (its older spellings first), or the canonical names."""
    older = tuple(SPELLINGS[interface]) if interface is not None else ()
    return (*older, *(name.value for name in ModelName if name.value not in older))


def model_name(text: str, interface: Interface | None = None) -> ModelName:
    """The model ``text`` names: a canonical name, or a spelling ``interface`` accepts.

    Raises:
        ConfigError: an unknown name (the message lists the accepted ones).
    """
    if interface is not None and text in SPELLINGS[interface]:
        return SPELLINGS[interface][text]
    try:
        return ModelName(text)
    except ValueError:
        accepted = ", ".join(accepted_names(interface))
        raise ConfigError(f"unknown model {text!r}: use one of {accepted}") from None


def with_steady_mode(name: ModelName, mode: str) -> ModelName:
    """``name`` with the steady model's sphere ``mode`` (auto, symmetric, full) applied:
    ``steady`` becomes ``steady-symmetric`` or ``steady-full``; ``auto`` changes nothing, and
    a model other than the steady one ignores the mode (as the node's ``steady_mode`` and
    ``--mode`` always did).

    Raises:
        ConfigError: an unknown mode, or one that contradicts a steady variant.
    """
    if mode not in ("auto", "symmetric", "full"):
        raise ConfigError(f"steady mode {mode!r} must be auto, symmetric or full")
    if mode == "auto" or name not in _STEADY_MODES:
        return name
    wanted = ModelName(f"steady-{mode}")
    if name not in (ModelName.STEADY, wanted):
        raise ConfigError(f"steady mode {mode} contradicts the model {name}")
    return wanted


@dataclass(frozen=True)
class ModelOptions:
    """What a model is built with, beyond the parameter set (each model reads its own).

    Attributes:
        mu_lit: friction coefficient of the catalogue formulas [-].
        tolerance: convergence limit of the steady solve (scaled residual) [-].
        table: the real-time model's table when already in hand (None: found for the screw).
        map_path: the real-time model's table file ("": the packaged table or the user's
            cache, whichever was built for the screw).
        temperature: bulk temperature of the dynamic model [K].
        time_step: integration step of the dynamic model [s].
        faults: defects the dynamic model carries.
    """

    mu_lit: float = 0.002
    tolerance: float = 1e-10
    table: SteadyMap | None = field(default=None, compare=False)
    map_path: str = ""
    temperature: float = 293.15
    time_step: float = 1e-6
    faults: Faults = field(default_factory=Faults)


#: What :func:`build` returns.
Model: TypeAlias = "CatalogModel | SteadySolver | RealTimeModel | DynamicModel"


def build(name: ModelName | str, config: TwinConfig, options: ModelOptions | None = None) -> Model:
    """The model ``name`` (a :class:`ModelName` or its canonical spelling) of ``config``.

    The steady, real-time and dynamic models are imported here, when built: a command that
    needs only the catalogue formula does not load the compiled kernels.

    Raises:
        ConfigError: an unknown name or invalid options. MapError: no real-time table was
            built for ``config`` (the message says which tables were refused and why).
    """
    name = model_name(str(name))
    options = options if options is not None else ModelOptions()
    if name is ModelName.CATALOG_LITERATURE:
        return CatalogModel(config, mu_lit=options.mu_lit, formula="literature")
    if name is ModelName.CATALOG_ZHOU:
        return CatalogModel(config, mu_lit=options.mu_lit, formula="zhou")
    if name in _STEADY_MODES:
        from .steady import SteadyStateModel as Steady

        return Steady(config, mode=_STEADY_MODES[name], tolerance=options.tolerance)
    if name is ModelName.REALTIME:
        from .realtime import RealTimeModel

        return RealTimeModel(config, steady_map=_realtime_table(config, options))
    from .dynamic import DynamicModel

    return DynamicModel(
        config, options.temperature, time_step=options.time_step, faults=options.faults
    )


def _realtime_table(config: TwinConfig, options: ModelOptions) -> SteadyMap:
    """The table in hand, else the one :func:`~.map_store.find_map` finds for ``config``."""
    if options.table is not None:
        return options.table
    from .map_store import find_map

    search = find_map(config, options.map_path)
    if search.table is None:
        refused = "; ".join(search.refused) or "no table found"
        raise MapError(
            f"no real-time table for {config.source or config.name} ({refused}): "
            "build it with `ballscrew-twin map build --config FILE`"
        )
    return search.table


def as_evaluating(model: Model) -> SteadyStateModel:
    """``model`` as a steady-state model (``evaluate(op)``).

    Raises:
        ConfigError: the dynamic model, which has no steady ``evaluate``.
    """
    if not hasattr(model, "evaluate"):
        kind = type(model).__name__
        raise ConfigError(f"{kind} integrates its own state in time: it has no evaluate(op)")
    return cast(SteadyStateModel, model)


def as_stepping(model: Model) -> TimeSteppingModel:
    """``model`` stepped in time tick by tick: the real-time model as it is, a steady-state
    model quasi-statically (:class:`~.base.QuasiStaticModel`), the dynamic model through the
    one time loop (:class:`~.dynamic_loop.DynamicStepping`: whole steps of its time step)."""
    if hasattr(model, "reset"):
        return cast(TimeSteppingModel, model)
    if hasattr(model, "evaluate"):
        return QuasiStaticModel(cast(SteadyStateModel, model))
    from .dynamic_loop import DynamicStepping

    return DynamicStepping(model)
