"""Residuals: measured drive torque minus the twin's prediction at the measured operating point.

The bench streams arrive at different rates: the torque fast (typically 1 kHz), speed, preload
and temperature slower. Torque samples are grouped into blocks of fixed length on the absolute
time axis (``floor(t / block_duration)``); a block is compared with the twin when it is closed
and every slow signal has a sample at or after its end, so the slow signals are *interpolated*
linearly at the torque stamps, never extrapolated. If a slow signal is late by more than
``max_wait`` [s] of torque time, its last value is held instead (stated in the result). The
rule uses stamps only, so a live node that receives messages in stamp order and an offline run
over the same bag see the same blocks and the same numbers (no look-ahead in either).

Normalisation: the block mean of ``n`` torque samples has the standard deviation
``sqrt(sigma_s^2 / n + sigma_m^2)``, ``sigma_s`` the torque-sensor noise of one sample [N m]
(given, or learnt from the first blocks) and ``sigma_m`` the model error at the operating
point: ``model_error_relative * |T_pred| + model_error_absolute`` [N m] (1 sigma; the default
is the size of the accuracy benchmark's error of the quasi-static twin; replace by the bound
stated for the real-time model when it is used).

Predictions come from a :class:`TwinPredictor`: the model from :func:`make_twin_model` (one
line to switch), evaluated on a quantised operating point and cached, so a steady solve
(milliseconds) is paid once per grid cell, not per sample.
"""

from __future__ import annotations

import functools
import math
from collections import deque
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import (
    ConfigError,
    MapError,
    OperatingPointError,
    SampleError,
    StampOrderError,
)
from ..models.base import OperatingPoint, SteadyStateModel
from ..params import TwinConfig, limits, not_negative, positive, validate_fields

FloatArray = NDArray[np.float64]

#: Relative preload step of the finite-difference sensitivity d T / d F_pr [-].
PRELOAD_PROBE = 0.05
#: Relative speed step of the finite-difference sensitivity d T / d omega [-].
SPEED_PROBE = 0.05
#: Temperature step of the finite-difference sensitivity d T / d theta [K].
TEMPERATURE_PROBE = 2.0


def make_twin_model(config: TwinConfig) -> SteadyStateModel:
    """The twin the health monitor compares with (switch to the real-time model here).

    The quasi-static steady-state model of Bertolino et al. (2021) for now; the steady state is
    what a bench at constant speed measures after the transients.
    """
    from ..models.steady import SteadyStateModel as Steady

    return Steady(config)


def thinner_lubricant(config: TwinConfig, loss: float) -> TwinConfig:
    """``config`` with both viscosity points scaled by ``1 - loss`` [-] (viscosity loss)."""
    lub = config.lubricant
    return replace(
        config,
        lubricant=replace(
            lub,
            viscosity_reference=lub.viscosity_reference * (1.0 - loss),
            viscosity_second=lub.viscosity_second * (1.0 - loss),
        ),
    )


def debris(config: TwinConfig, rise: float) -> TwinConfig:
    """``config`` with the dry (boundary) friction coefficient mu_dry (Eq. 36) and both RMS
    roughnesses (Eq. 38) scaled by ``1 + rise`` [-]: particles between the surfaces, the usual
    start of a jam (the fault model of :mod:`.fault_profiles`)."""
    contact = config.contact
    screw = config.screw
    return replace(
        config,
        contact=replace(
            contact, dry_friction_coefficient=contact.dry_friction_coefficient * (1.0 + rise)
        ),
        screw=replace(
            screw,
            ball_roughness=screw.ball_roughness * (1.0 + rise),
            groove_roughness=screw.groove_roughness * (1.0 + rise),
        ),
    )


#: Fault changes of the twin: class -> (config change taking the severity [-], severities at
#: which the changed twin is evaluated [-]; the classifier interpolates between them, because
#: the torque's response is far from linear: at 23.8 C, 760 N, 30 rad/s a 30 % viscosity loss
#: barely moves the torque where a 60 % loss raises it, docs/model.md section 15).
FAULT_CHANGES: dict[str, tuple[Any, tuple[float, ...]]] = {
    "lubricant_degradation": (thinner_lubricant, (0.1, 0.2, 0.3, 0.45, 0.6, 0.75, 0.9)),
    "jam_onset": (debris, (0.25, 0.5, 1.0, 2.0, 4.0, 8.0)),
}


@dataclass(frozen=True, kw_only=True)
class ResidualSettings:
    """How torque samples are grouped, aligned and normalised.

    Attributes:
        block_duration: length of one comparison block [s].
        max_wait: how long (torque time) a block waits for a late slow signal before its last
            value is held [s].
        sensor_noise: standard deviation of one torque sample [N m]; None: learnt during the
            warm-up from the scatter of the samples within each block.
        model_error_relative: model error relative to the predicted torque, 1 sigma [-].
        model_error_absolute: model error floor, 1 sigma [N m].
        model_noise_relative: the part of the model error that changes from block to block
            (operating-point grid of the cache, interpolation), relative to the torque [-]; the
            rest is systematic and tracked by the Kalman filter (:mod:`.tracker`).
        speed_step: relative step of the speed grid of the prediction cache [-].
        temperature_step: temperature step of the prediction cache [K].
        preload_step: preload step of the prediction cache [N].
        min_speed: below this |speed| the drag torque is not compared (standstill) [rad/s].
        gate_speed: a block with any sample below this |speed| is not compared: near
            standstill the unit's breakaway (Stribeck) friction is not in the twin [rad/s].
        gate_angle: nor one with a sample within this screw rotation since the last
            reversal: the friction's presliding lag (a few Dahl angles) is not in the quasi-
            static twin [rad].
        slow_smoothing: causal moving average of temperature and preload [s]: both change
            slowly, their sensor noise would otherwise go into the prediction.
        partial_share: a block some of whose samples fail the gate is compared on its
            longest run of samples that pass, when that run holds at least this share of the
            block's samples (1: only whole blocks are compared) [-]. A sine of 2.5 Hz and up
            reverses in every 0.1 s block; with 0.5, the default since round 27 of issue 13,
            its strokes between the reversals are compared (with
            ``MonitorSettings.cusum_min_weight`` < 1; docs/model.md section 15).
    """

    block_duration: float = field(default=0.1, metadata=positive("s"))
    max_wait: float = field(default=0.25, metadata=not_negative("s"))
    sensor_noise: float | None = field(default=None, metadata=positive("N m"))
    model_error_relative: float = field(default=0.03, metadata=not_negative("-"))
    model_error_absolute: float = field(default=1.0e-4, metadata=not_negative("N m"))
    model_noise_relative: float = field(default=0.002, metadata=not_negative("-"))
    speed_step: float = field(default=0.01, metadata=positive("-"))
    temperature_step: float = field(default=0.5, metadata=positive("K"))
    preload_step: float = field(default=10.0, metadata=positive("N"))
    min_speed: float = field(default=0.5, metadata=not_negative("rad/s"))
    gate_speed: float = field(default=2.0, metadata=not_negative("rad/s"))
    gate_angle: float = field(default=2.0, metadata=not_negative("rad"))
    slow_smoothing: float = field(default=1.0, metadata=not_negative("s"))
    partial_share: float = field(
        default=0.5,
        metadata=limits("-", 0.0, 1.0, lo_open=True, hint="a share of a block's samples"),
    )

    def __post_init__(self) -> None:
        """Reject non-finite, negative or zero values where they make no sense, through the
        package's one number check (:func:`~ballscrew_twin.params.validate_fields`: the
        message names the setting, its value, its unit and its range)."""
        validate_fields(self, "health settings", ": ")

    def model_error(self, predicted: float) -> float:
        """1-sigma model error at a predicted torque [N m]."""
        return self.model_error_relative * abs(predicted) + self.model_error_absolute


@dataclass(frozen=True)
class Prediction:
    """The twin at one grid point of the cache, with its local slopes.

    Attributes:
        torque: predicted drag torque at the grid point [N m], with the sign of the speed.
        speed_sensitivity: d torque / d screw speed [N m s / rad].
        temperature_sensitivity: d torque / d temperature [N m / K].
        preload_sensitivity: d torque / d preload [N m / N].
        operating_point: the grid point evaluated.
    """

    torque: float
    speed_sensitivity: float
    temperature_sensitivity: float
    preload_sensitivity: float
    operating_point: OperatingPoint

    def at(self, op: OperatingPoint) -> float:
        """Torque at ``op`` near the grid point, first order (linear in each input) [N m]."""
        grid = self.operating_point
        return (
            self.torque
            + self.speed_sensitivity * (op.screw_speed - grid.screw_speed)
            + self.temperature_sensitivity * (op.temperature - grid.temperature)
            + self.preload_sensitivity * (op.preload - grid.preload)
        )


class TwinPredictor:
    """Cached predictions of the twin on a quantised operating-point grid.

    Args:
        config: the screw's parameter set.
        settings: grid steps (``speed_step``, ``temperature_step``, ``preload_step``).
        model_factory: builds the twin from a config (default :func:`make_twin_model`).
    """

    def __init__(
        self,
        config: TwinConfig,
        settings: ResidualSettings,
        model_factory: Any = make_twin_model,
    ) -> None:
        self.config = config
        self.settings = settings
        self._factory = model_factory
        self.model: SteadyStateModel = model_factory(config)
        self._changed: dict[tuple[str, float], SteadyStateModel] = {}
        self._cache: dict[tuple[int, int, int, int], Prediction] = {}
        self._change_cache: dict[tuple[str, float, tuple[int, int, int, int]], float] = {}

    def _key(self, op: OperatingPoint) -> tuple[int, int, int, int]:
        s = self.settings
        sign = 1 if op.screw_speed >= 0.0 else -1
        speed = max(abs(op.screw_speed), 1e-9)
        return (
            sign,
            round(math.log(speed) / math.log1p(s.speed_step)),
            round(op.temperature / s.temperature_step),
            round(op.preload / s.preload_step),
        )

    def _grid_point(self, key: tuple[int, int, int, int]) -> OperatingPoint:
        s = self.settings
        return OperatingPoint(
            screw_speed=key[0] * math.exp(key[1] * math.log1p(s.speed_step)),
            temperature=key[2] * s.temperature_step,
            preload=key[3] * s.preload_step,
        )

    def _torque(self, model: SteadyStateModel, op: OperatingPoint) -> float:
        value = float(model.evaluate(op).drag_torque)
        if not math.isfinite(value):
            raise OperatingPointError(f"the twin returned a non-finite torque at {op}")
        return value

    def predict(self, op: OperatingPoint) -> Prediction:
        """Torque and its slopes at the grid point nearest to ``op`` (``.at(op)`` corrects
        for the distance to the grid point).

        Raises:
            OperatingPointError: ``op`` is invalid (NaN, temperature in deg C, ...).
        """
        op.validate()
        key = self._key(op)
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        grid = self._grid_point(key)
        torque = self._torque(self.model, grid)

        def slope(changed: OperatingPoint, delta: float) -> float:
            return (self._torque(self.model, changed) - torque) / delta

        dw = SPEED_PROBE * grid.screw_speed
        df = -PRELOAD_PROBE * max(grid.preload, self.settings.preload_step)
        df = max(df, -grid.preload)
        prediction = Prediction(
            torque,
            slope(replace(grid, screw_speed=grid.screw_speed + dw), dw),
            slope(
                replace(grid, temperature=grid.temperature + TEMPERATURE_PROBE), TEMPERATURE_PROBE
            ),
            slope(replace(grid, preload=grid.preload + df), df) if df < 0.0 else 0.0,
            grid,
        )
        self._cache[key] = prediction
        return prediction

    def fault_change(self, name: str, op: OperatingPoint, severity: float) -> float:
        """Torque change [N m] at ``op`` of the twin changed by fault ``name`` as
        :data:`FAULT_CHANGES` says (``lubricant_degradation``: relative viscosity loss;
        ``jam_onset``: relative rise of mu_dry and roughness) at ``severity`` [-], one of that
        class's evaluated severities: ``T(severity) - T``."""
        change_config, _ = FAULT_CHANGES[name]
        key = self._key(op)
        hit = self._change_cache.get((name, severity, key))
        if hit is not None:
            return hit
        if (name, severity) not in self._changed:
            self._changed[(name, severity)] = self._factory(change_config(self.config, severity))
        grid = self._grid_point(key)
        change = self._torque(self._changed[(name, severity)], grid) - self.predict(grid).torque
        self._change_cache[(name, severity, key)] = change
        return change


class UnitTwin:
    """The real-time map of the twin (:class:`~ballscrew_twin.models.realtime.RealTimeModel`),
    adjusted to a commissioned unit and evaluated along a measured trajectory.

    The unit's drag torque is ``T_map(w, T + dT, k_F F) exp(R(w, T + dT, k_F F; k))``: k_F the
    preload scale, dT the temperature shift (a thermometer offset, or a lubricant whose
    torque-temperature curve lies a few kelvin off; a scale of the viscosity alone is *not* a
    shift in temperature in this model, whose density, Roelands indices and thermal film
    reduction all move with the temperature: measured in docs/model.md section 16), and R the
    steady model's response to the unit's own mu_dry and tau_0 scales k
    (:mod:`~ballscrew_twin.models.friction_response`; 0 with both scales 1); the sensor's gain
    and bias and the inertia are applied by the caller (:mod:`.monitor`). All the speeds of a
    call are interpolated at once
    (:meth:`~ballscrew_twin.models.steady_map.SteadyMap.total_torque`).

    Args:
        config: the nominal parameter set (the one the map was built for).
        preload_scale: k_F [-].
        temperature_shift: dT [K].
        friction_scales: (mu_dry, tau_0) over nominal [-].

    Raises:
        MapError: no map for ``config``, or scales other than 1 and no friction response table
            for it.
    """

    def __init__(
        self,
        config: TwinConfig,
        preload_scale: float = 1.0,
        temperature_shift: float = 0.0,
        friction_scales: tuple[float, float] = (1.0, 1.0),
    ) -> None:
        from ..models.friction_response import find_response
        from ..models.realtime import RealTimeModel

        self.config = config
        self.model = RealTimeModel(config)
        self.response = find_response(config)
        self.preload_scale = preload_scale
        self.temperature_shift = temperature_shift
        self.log_scales = self._log_scales(friction_scales)

    def _log_scales(self, friction_scales: tuple[float, float]) -> FloatArray:
        """ln k [-], checked against the response table's presence."""
        log_scales = np.log(np.asarray(friction_scales, dtype=np.float64))
        if np.any(log_scales != 0.0) and self.response is None:
            raise MapError(
                f"friction scales {friction_scales} need the friction response table of "
                f"{self.config.name!r}: build it with `ballscrew-twin map response`"
            )
        return log_scales

    def adjusted(
        self,
        preload_scale: float,
        temperature_shift: float,
        friction_scales: tuple[float, float] = (1.0, 1.0),
    ) -> UnitTwin:
        """A twin of other scales sharing this one's map and response table."""
        other = UnitTwin.__new__(UnitTwin)
        other.__dict__.update(self.__dict__)
        other.preload_scale = preload_scale
        other.temperature_shift = temperature_shift
        other.log_scales = other._log_scales(friction_scales)
        return other

    def drag(
        self,
        speed: FloatArray,
        temperature: float,
        preload: float,
        *,
        preload_factor: float = 1.0,
    ) -> FloatArray:
        """Drag torque [N m] at each ``speed`` [rad/s], one ``temperature`` [K] and measured
        ``preload`` [N], the preload times ``preload_factor`` [-] (a preload loss)."""
        load = max(self.preload_scale * preload_factor * preload, 0.0)
        speeds = np.asarray(speed, dtype=np.float64)
        unit_temperature = temperature + self.temperature_shift
        torque = self.model.map.total_torque(speeds, unit_temperature, (load, load))
        if self.response is None or not np.any(self.log_scales):
            return torque
        factor = self.response.log_factor(speeds, unit_temperature, load, self.log_scales)
        return np.asarray(torque * np.exp(factor))


@functools.lru_cache(maxsize=4)
def shared_predictor(config: TwinConfig, settings: ResidualSettings) -> TwinPredictor:
    """One :class:`TwinPredictor` (with the default twin) per screw and residual settings in
    this process, so that runs over many recordings pay each grid cell's solve once."""
    return TwinPredictor(config, settings)


@dataclass
class SlowSignal:
    """Recent samples of one slowly sampled signal (stamps [s], values in SI units)."""

    name: str
    unit: str
    smoothing: float = 0.0  # s, length of the causal moving average (0: none)
    horizon: float = 30.0  # s of history kept
    stamps: deque[float] = field(default_factory=deque)
    values: deque[float] = field(default_factory=deque)

    def add(self, stamp: float, value: float) -> None:
        """Append a sample; non-finite (:class:`SampleError`) or out-of-order
        (:class:`StampOrderError`) samples raise."""
        if not (math.isfinite(stamp) and math.isfinite(value)):
            raise SampleError(
                f"{self.name}: sample ({stamp!r} s, {value!r} {self.unit}) not finite"
            )
        if self.stamps and stamp < self.stamps[-1]:
            raise StampOrderError(
                f"{self.name}: stamp {stamp:.6f} s is earlier than the last one "
                f"{self.stamps[-1]:.6f} s (clock jump?)"
            )
        self.stamps.append(stamp)
        self.values.append(value)
        while len(self.stamps) > 2 and self.stamps[1] < stamp - self.horizon:
            self.stamps.popleft()
            self.values.popleft()

    def curvature_near(self, times: FloatArray) -> FloatArray:
        """|v[k+1] - 2 v[k] + v[k-1]| at the sample k nearest each of ``times`` [s] (0 where
        a neighbour is missing): the size of the error of a straight line between samples,
        in the signal's unit."""
        stamps = np.fromiter(self.stamps, float)
        values = np.fromiter(self.values, float)
        out = np.zeros(len(times))
        if len(stamps) < 3:
            return out
        k = np.clip(np.searchsorted(stamps, times), 1, len(stamps) - 2)
        out[:] = np.abs(values[k + 1] - 2.0 * values[k] + values[k - 1])
        return out

    @property
    def latest(self) -> float:
        """Stamp of the newest sample [s], -inf without samples."""
        return self.stamps[-1] if self.stamps else -math.inf

    def at(self, times: FloatArray) -> FloatArray:
        """Linear interpolation at ``times`` [s]; the last value is held beyond the newest
        sample and the first before the oldest (never extrapolated). With ``smoothing`` > 0
        the interpolated signal is first averaged over the ``smoothing`` seconds before each
        time (causal moving average of the samples in that span, plus the interpolated end)."""
        stamps = np.fromiter(self.stamps, float)
        values = np.fromiter(self.values, float)
        now = np.interp(times, stamps, values)
        if self.smoothing <= 0.0:
            return now
        out = np.empty_like(now)
        for i, t in enumerate(times):
            inside = values[(stamps > t - self.smoothing) & (stamps < t)]
            out[i] = (float(np.sum(inside)) + now[i]) / (len(inside) + 1)
        return out


@dataclass(frozen=True)
class Block:
    """One block of torque samples with the slow signals at its stamps.

    Attributes:
        index: ``floor(t / block_duration)`` of its samples.
        stamps: torque stamps [s].
        torque: measured torque [N m].
        speed: screw speed at the stamps [rad/s].
        temperature: temperature at the block's mid time [K].
        preload: measured preload at the block's mid time [N].
        held: names of slow signals whose last value was held (late beyond ``max_wait``).
        speed_edges: speed half a torque interval before the first and after the last stamp
            [rad/s]: their difference over the block's span is the block mean of dw/dt.
        edge_curvature: second difference of the speed samples nearest those edges [rad/s]
            (how far a straight line between speed samples may be off there).
    """

    index: int
    stamps: FloatArray
    torque: FloatArray
    speed: FloatArray
    temperature: float
    preload: float
    held: tuple[str, ...]
    speed_edges: tuple[float, float] = (0.0, 0.0)
    edge_curvature: tuple[float, float] = (0.0, 0.0)

    @property
    def span(self) -> float:
        """Time the block's samples stand for [s]: n torque intervals."""
        n = len(self.stamps)
        if n < 2:
            return 0.0
        return float(self.stamps[-1] - self.stamps[0]) * n / (n - 1)

    @property
    def mean_acceleration(self) -> float:
        """Block mean of dw/dt [rad/s^2]: (w at the end edge - w at the start edge) / span."""
        span = self.span
        return (self.speed_edges[1] - self.speed_edges[0]) / span if span > 0.0 else 0.0

    @property
    def time(self) -> float:
        """Mid time of the block's samples [s]."""
        return 0.5 * float(self.stamps[0] + self.stamps[-1])

    def part(self, start: int, stop: int) -> Block:
        """The block's samples ``start:stop`` as a block of their own (same index, slow
        signals and held names). An edge inside the block takes the speed half a torque
        interval out from the part's end sample (the mean of the two samples there, the
        speed being linear between its own samples) and |second difference| of the speed
        over +-PART_CURVATURE_SPAN about it (the bend a straight line between speed samples
        misses, as :meth:`SlowSignal.curvature_near` takes it at the block's own edges)."""
        n = len(self.stamps)
        if not 0 <= start < stop <= n:
            raise ConfigError(f"block part {start}:{stop} of {n} samples")
        if start == 0 and stop == n:
            return self
        w, t = self.speed, self.stamps
        first = self.speed_edges[0] if start == 0 else 0.5 * float(w[start - 1] + w[start])
        last = self.speed_edges[1] if stop == n else 0.5 * float(w[stop - 1] + w[stop])

        def bend(at: float) -> float:
            around = np.interp([at - PART_CURVATURE_SPAN, at, at + PART_CURVATURE_SPAN], t, w)
            return abs(float(around[0] - 2.0 * around[1] + around[2]))

        return replace(
            self,
            stamps=t[start:stop],
            torque=self.torque[start:stop],
            speed=w[start:stop],
            speed_edges=(first, last),
            edge_curvature=(
                self.edge_curvature[0]
                if start == 0
                else bend(0.5 * float(t[start - 1] + t[start])),
                self.edge_curvature[1] if stop == n else bend(0.5 * float(t[stop - 1] + t[stop])),
            ),
        )


class BlockAligner:
    """Groups torque samples into blocks and aligns the slow signals at their stamps.

    ``add_*`` methods take one sample each (stamp [s], value in SI units) and return the blocks
    that became complete; :meth:`flush` returns the rest at the end of a recording.
    """

    def __init__(self, settings: ResidualSettings) -> None:
        self.settings = settings
        self.speed = SlowSignal("speed", "rad/s")
        self.temperature = SlowSignal("temperature", "K", settings.slow_smoothing)
        self.preload = SlowSignal("preload", "N", settings.slow_smoothing)
        self._pending: dict[int, tuple[list[float], list[float]]] = {}
        self._last_torque_stamp = -math.inf

    def _index(self, stamp: float) -> int:
        return math.floor(stamp / self.settings.block_duration)

    def add_torque(self, stamp: float, value: float) -> list[Block]:
        """Add a torque sample [s, N m]."""
        if not (math.isfinite(stamp) and math.isfinite(value)):
            raise SampleError(f"torque: sample ({stamp!r} s, {value!r} N m) not finite")
        if stamp < self._last_torque_stamp:
            raise StampOrderError(
                f"torque: stamp {stamp:.6f} s is earlier than the last one "
                f"{self._last_torque_stamp:.6f} s (clock jump?)"
            )
        index = self._index(stamp)
        # Nothing can close while the newest block stays open and is the only one pending.
        quiet = len(self._pending) == 1 and index in self._pending
        self._last_torque_stamp = stamp
        stamps, values = self._pending.setdefault(index, ([], []))
        stamps.append(stamp)
        values.append(value)
        return [] if quiet else self._ready(flush=False)

    def add_speed(self, stamp: float, value: float) -> list[Block]:
        """Add a speed sample [s, rad/s]."""
        self.speed.add(stamp, value)
        return self._ready(flush=False)

    def add_temperature(self, stamp: float, value: float) -> list[Block]:
        """Add a temperature sample [s, K]."""
        self.temperature.add(stamp, value)
        return self._ready(flush=False)

    def add_preload(self, stamp: float, value: float) -> list[Block]:
        """Add a preload sample [s, N]."""
        self.preload.add(stamp, value)
        return self._ready(flush=False)

    def flush(self) -> list[Block]:
        """Every pending block (end of a recording), slow signals held where missing."""
        return self._ready(flush=True)

    def _signals(self) -> tuple[SlowSignal, SlowSignal, SlowSignal]:
        return self.speed, self.temperature, self.preload

    def _ready(self, *, flush: bool) -> list[Block]:
        out: list[Block] = []
        current = self._index(self._last_torque_stamp) if self._pending else 0
        if not flush and self._pending:
            # Quick answer for the common case: the oldest block still waits (open, or for a
            # slow signal that has not timed out).
            first = min(self._pending)
            end = (first + 1) * self.settings.block_duration
            waiting = min(s.latest for s in self._signals()) < end
            if first >= current or (
                waiting and self._last_torque_stamp < end + self.settings.max_wait
            ):
                return out
        for index in sorted(self._pending):
            end = (index + 1) * self.settings.block_duration
            closed = index < current or flush
            if not closed:
                break
            if any(not s.stamps for s in self._signals()):
                if flush or self._last_torque_stamp >= end + self.settings.max_wait:
                    del self._pending[index]  # no operating point yet: cannot be compared
                    continue
                break
            late = tuple(s.name for s in self._signals() if s.latest < end)
            timed_out = self._last_torque_stamp >= end + self.settings.max_wait
            if late and not (timed_out or flush):
                break
            stamps, values = self._pending.pop(index)
            t = np.asarray(stamps)
            mid = np.array([0.5 * (t[0] + t[-1])])
            half = 0.5 * float(np.median(np.diff(t))) if len(t) > 1 else 0.0
            edges = np.array([t[0] - half, t[-1] + half])
            at_edges = self.speed.at(edges)
            bends = self.speed.curvature_near(edges)
            out.append(
                Block(
                    index=index,
                    stamps=t,
                    torque=np.asarray(values),
                    speed=self.speed.at(t),
                    temperature=float(self.temperature.at(mid)[0]),
                    preload=float(self.preload.at(mid)[0]),
                    held=late,
                    speed_edges=(float(at_edges[0]), float(at_edges[1])),
                    edge_curvature=(float(bends[0]), float(bends[1])),
                )
            )
        return out


#: Half-span of the speed's second difference at an edge inside a block (:meth:`Block.part`)
#: [s]: the interval of a 100 Hz speed signal, whose samples the speed is linear between.
PART_CURVATURE_SPAN = 0.01


class ReversalGate:
    """Which blocks the quasi-static twin may be compared on (see ``gate_speed`` and
    ``gate_angle`` of :class:`ResidualSettings`): it follows the screw rotation since the last
    reversal or stop over the blocks it is shown, in order."""

    def __init__(self, settings: ResidualSettings) -> None:
        self.settings = settings
        self._sign = 0.0
        self._travel = math.inf
        self._last_stamp = -math.inf
        #: Least screw rotation since the last reversal or stop over the last block checked
        #: [rad] (inf before any).
        self.block_travel = math.inf
        #: Screw rotation since the last reversal or stop at each sample of the last block
        #: checked [rad], and whether each sample passed the gate [-].
        self.travel = np.zeros(0)
        self.passed = np.zeros(0, dtype=bool)

    def check(self, block: Block) -> str:
        """Why ``block`` is not compared ("" when it is: every sample passed); updates the
        rotation count, :attr:`travel` and :attr:`passed`."""
        r = self.settings
        reason = ""
        travel = np.empty(len(block.stamps))
        passed = np.zeros(len(block.stamps), dtype=bool)
        for i, (stamp, w) in enumerate(
            zip(block.stamps.tolist(), block.speed.tolist(), strict=True)
        ):
            dt = stamp - self._last_stamp if math.isfinite(self._last_stamp) else 0.0
            self._last_stamp = stamp
            sign = math.copysign(1.0, w) if abs(w) >= r.min_speed else 0.0
            if sign != self._sign:
                self._sign, self._travel = sign, 0.0
            else:
                self._travel += abs(w) * max(dt, 0.0)
            travel[i] = self._travel
            if abs(w) < r.gate_speed:
                reason = reason or f"gated: |speed| {abs(w):.3g} rad/s below {r.gate_speed:g} rad/s"
            elif self._travel < r.gate_angle:
                reason = reason or (
                    f"gated: {self._travel:.3g} rad since the last reversal or stop "
                    f"(< {r.gate_angle:g} rad)"
                )
            else:
                passed[i] = True
        self.travel, self.passed = travel, passed
        self.block_travel = float(np.min(travel)) if len(travel) else math.inf
        return reason

    def compared_part(self, block: Block) -> tuple[int, int] | None:
        """After :meth:`check` gated ``block``: the longest run of samples that passed as
        (start, stop), when it holds at least ``partial_share`` of the block's samples (and
        4, enough for a scatter); None otherwise. Sets :attr:`block_travel` to the run's."""
        passed = self.passed
        if len(passed) != len(block.stamps) or not np.any(passed):
            return None
        edges = np.flatnonzero(np.diff(np.concatenate([[0], passed.astype(np.int8), [0]])))
        starts, stops = edges[0::2], edges[1::2]
        k = int(np.argmax(stops - starts))
        start, stop = int(starts[k]), int(stops[k])
        if stop - start < max(self.settings.partial_share * len(passed), 4.0):
            return None
        self.block_travel = float(np.min(self.travel[start:stop]))
        return start, stop


def within_block_variance(block: Block) -> float | None:
    """Scatter of a block's torque about a straight line in time [N m^2], None if < 4 samples.

    An estimate of the sensor noise variance of one sample when the torque is steady within
    the block (the line removes a slow trend).
    """
    n = len(block.torque)
    if n < 4:
        return None
    t = block.stamps - block.stamps.mean()
    if np.ptp(t) > 0.0:
        slope, offset = np.polyfit(t, block.torque, 1)
        scatter = block.torque - (slope * t + offset)
    else:
        scatter = block.torque - block.torque.mean()
    return float(np.sum(scatter**2) / (n - 2))
