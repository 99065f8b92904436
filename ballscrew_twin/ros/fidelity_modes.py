"""The models the twin node can step, chosen by its ``fidelity`` parameter (no rclpy here).

Modes, from the most to the least detailed:

- ``realtime``: :class:`ballscrew_twin.models.realtime.RealTimeModel` (time-stepping, per-sphere
  states at >= 1 kHz);
- ``quasi_static``: the steady-state model of every loaded sphere
  (:class:`~ballscrew_twin.models.steady.SteadyStateModel`) as a time-stepping model, solved
  again only when the command changes (3-9 ms a solve: ticks are late after each change);
- ``catalog``: the catalogue formula Eq. 52 (microseconds; preload only, no contact states);
- ``auto``: the real-time model if it can be built here (a steady-state map built for this
  screw), else the catalogue; the node steps down to the catalogue when the model
  does not fit into the step budget or fails (see ``TwinNode``). ``auto`` never takes
  ``quasi_static``: its millisecond solves do not fit a 1 kHz step.

Each mode names a model of the registry (:mod:`ballscrew_twin.models.registry`, which maps
these spellings: ``catalog`` is Eq. 52 there, ``quasi_static`` the steady model with
``steady_mode``), built by its :func:`~ballscrew_twin.models.registry.build`. The real-time
model's table is the one in hand (``ModelSettings.table``: the node's table of its screw, see
``ros/tables.py``) or the one :func:`~ballscrew_twin.models.map_store.find_map` finds for the
screw (the ``realtime_map`` file, the packaged table, the user cache); a table built for other
parameters is never used.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..errors import BallscrewTwinError, ConfigError, FidelityError
from ..models import registry
from ..models.base import (
    OperatingPoint,
    QuasiStaticModel,
    SteadyStateModel,
    TimeSteppingModel,
    TwinOutput,
)
from ..models.registry import ModelName, ModelOptions, SteadyMode
from ..models.steady_map import SteadyMap
from ..models.validity import ValidatedModel, ValidityEnvelope
from ..params import TwinConfig

#: Values of the node's ``fidelity`` parameter.
FIDELITY_MODES: tuple[str, ...] = ("auto", "realtime", "quasi_static", "catalog")
#: Concrete modes, most detailed first: what ``auto`` tries in turn.
LADDER: tuple[str, ...] = ("realtime", "quasi_static", "catalog")


@dataclass(frozen=True)
class ModelSettings:
    """What the models are built from.

    Attributes:
        config: the screw's parameter set.
        mu_lit: friction coefficient of the catalogue formula [-].
        tolerance: convergence limit of the steady solve (scaled residual) [-].
        steady_mode: spheres the steady model solves: ``auto``, ``symmetric`` or ``full``.
        realtime_map: steady-state map file of the real-time model; "" = the packaged one or
            the user cache's for this screw.
        table: a table of this screw already in hand (used instead of searching), or None.
    """

    config: TwinConfig
    mu_lit: float = 0.002
    tolerance: float = 1e-10
    steady_mode: SteadyMode = "auto"
    realtime_map: str = ""
    table: SteadyMap | None = field(default=None, compare=False)  # arrays: no eq or hash


@dataclass(frozen=True)
class ModelChoice:
    """A built model, the concrete mode it stands for and why it was chosen."""

    model: TimeSteppingModel
    mode: str
    reason: str


class CachedQuasiStatic(QuasiStaticModel):
    """A steady model stepped in time, solved again only when the command changes.

    Exact: a quasi-static output depends on the command alone, so an unchanged command gives
    the previous output.
    """

    def __init__(self, model: SteadyStateModel) -> None:
        super().__init__(model)
        self._last: tuple[OperatingPoint, TwinOutput] | None = None

    def reset(self, op: OperatingPoint) -> None:
        """Forget the cached output."""
        super().reset(op)
        self._last = None

    def step(self, op: OperatingPoint, dt: float) -> TwinOutput:
        """The steady state of ``op``, from the cache when ``op`` is the last command."""
        if self._last is not None and self._last[0] == op:
            return self._last[1]
        out = self.model.evaluate(op)
        self._last = (op, out)
        return out


def build(mode: str, settings: ModelSettings) -> TimeSteppingModel:
    """The model of one concrete mode (``realtime``, ``quasi_static`` or ``catalog``), run only
    inside the validity envelope of the screw (a clamped input adds a ``validity:`` note)."""
    envelope = ValidityEnvelope.for_config(settings.config)
    return ValidatedModel(_build_raw(mode, settings), envelope)


def _build_raw(mode: str, settings: ModelSettings) -> TimeSteppingModel:
    """The model of one concrete mode, as the registry builds it; the steady model solved again
    only when the command changes (:class:`CachedQuasiStatic`)."""
    if mode not in LADDER:
        raise ConfigError(f"fidelity {mode!r} is not one of {', '.join(LADDER)}")
    name = registry.with_steady_mode(registry.model_name(mode, "node"), settings.steady_mode)
    options = ModelOptions(
        mu_lit=settings.mu_lit,
        tolerance=settings.tolerance,
        table=settings.table,
        map_path=settings.realtime_map,
    )
    model = registry.build(name, settings.config, options)
    if name == ModelName.REALTIME:
        return registry.as_stepping(model)
    if name == ModelName.CATALOG_ZHOU:
        return QuasiStaticModel(registry.as_evaluating(model))
    return CachedQuasiStatic(registry.as_evaluating(model))


def _try_build(mode: str, settings: ModelSettings) -> tuple[TimeSteppingModel | None, str]:
    """Build ``mode``, or return None and why it cannot be built here."""
    try:
        return build(mode, settings), ""
    except (BallscrewTwinError, ValueError, OSError) as err:  # e.g. MapError: map missing/stale
        return None, f"{type(err).__name__}: {err}"


def unavailable(mode: str, settings: ModelSettings) -> str | None:
    """Why ``mode`` cannot be built here (e.g. its map missing or stale), or None."""
    return _try_build(mode, settings)[1] or None


def choose(requested: str, settings: ModelSettings, *, below: str | None = None) -> ModelChoice:
    """Build the model for the ``fidelity`` parameter value ``requested``.

    Args:
        requested: one of :data:`FIDELITY_MODES`.
        settings: what the models are built from.
        below: for ``auto``, take only modes less detailed than this one (the node steps down
            after ``below`` could not keep up).

    Raises:
        ConfigError: unknown mode. FidelityError: an explicitly requested mode that cannot be
            built.
    """
    if requested not in FIDELITY_MODES:
        raise ConfigError(f"fidelity {requested!r} is not one of {', '.join(FIDELITY_MODES)}")
    if requested != "auto":
        model, why = _try_build(requested, settings)
        if model is None:
            raise FidelityError(f"fidelity {requested} is not available: {why}")
        return ModelChoice(model, requested, f"requested ({requested})")
    start = 0 if below is None else LADDER.index(below) + 1
    skipped: list[str] = []
    for mode in LADDER[start:]:
        if mode == "quasi_static":
            # A steady solve takes milliseconds per command change: at a 1 kHz step it cannot
            # keep up, so auto never takes it (it remains available as an explicit choice).
            skipped.append("quasi_static: a steady solve takes milliseconds per command change")
            continue
        model, why = _try_build(mode, settings)
        if model is None:
            skipped.append(f"{mode}: {why}")
            continue
        reason = "auto: most detailed model available"
        if below is not None:
            reason = f"auto: stepped down from {below}"
        if skipped:
            reason += " (" + "; ".join(skipped) + ")"
        return ModelChoice(model, mode, reason)
    raise FidelityError("no model left to step down to")  # catalog is always available
