"""The health-monitor pipeline shared by the live node and the offline ``detect`` command.

Samples in (stamp [s], SI value) -> blocks aligned with the slow signals (:mod:`.residuals`) ->
twin prediction and residual -> Kalman tracking of slow drift (:mod:`.tracker`) -> detectors
on the innovations, on the residual against this run's memory of the same operating point
(:mod:`.memory`) and on the raw torque (:mod:`.detectors`) -> verdict and fault class
(:mod:`.classify`). The node calls the ``add_*`` methods as messages arrive; ``detect`` calls
them for the bag's messages merged in stamp order (:func:`feed`), so both see the same blocks
in the same order and reach the same verdict.

The prediction follows the measured trajectory: the twin (the real-time map adjusted to the
commissioned unit, :class:`.residuals.UnitTwin` and :class:`.baseline.Baseline`) is evaluated
at every torque sample's speed and averaged over the block, never at the block's mean speed;
the inertia torque is the block mean of J dw/dt, (w_end - w_start) / span, from the speed at
the block's edges; every block carries its own uncertainty (:mod:`.baseline`). Blocks that
reach below ``gate_speed`` or lie within ``gate_angle`` of screw rotation after a reversal are
gated (UNKNOWN, counted in :attr:`HealthMonitor.gated_time`): there the unit's breakaway and
presliding friction, which the quasi-static twin does not have, dominate. With
``partial_share`` < 1 a block whose longest run of samples that pass the gate holds at least
that share of it is compared on that run alone (the stroke of a fast sine between its
reversals; the rest counts as gated).

Verdicts: UNKNOWN during the warm-up (the sensor noise is learnt then; the data must be healthy)
and at standstill, gated blocks or an invalid operating point; OK; WARN when a detector's
statistic passes ``warn_fraction`` of its threshold; FAULT from the first alarm on (latched,
the Kalman filter is frozen so that it does not learn the fault). The class is refined for
``classification_window`` [s] after the alarm, and on while its confidence is below
``confident_class`` for up to ``classification_patience`` [s], then kept.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np

from ..errors import BallscrewTwinError, ConfigError, MapError
from ..models.base import OperatingPoint
from ..models.friction_response import scaled_config
from ..params import TwinConfig
from .baseline import Baseline
from .classify import (
    Classification,
    Response,
    classify_mean_shift,
    classify_ripple,
    defect_orders,
)
from .detectors import (
    Cusum,
    WindowChiSquare,
)
from .memory import (
    LOUD_SIGMA,
    REPEAT_SHARE,
    UPDATE_GATE,
    ResidualMemory,
    bin_key,
)
from .monitor_settings import MonitorSettings
from .order_stage import OrderStage
from .residuals import (
    FAULT_CHANGES,
    Block,
    BlockAligner,
    FloatArray,
    ReversalGate,
    TwinPredictor,
    UnitTwin,
    make_twin_model,
    within_block_variance,
)
from .tracker import DriftTracker, TrackerSettings
from .transient_terms import PredictedLag, following_error, presliding_remainder
from .verdicts import FAULT, OK, UNKNOWN, WARN, Alarm, HealthSample

#: Blocks of history kept for classification after an alarm.
HISTORY_BLOCKS = 1200
#: Samples of a block at which the twin is evaluated (evenly spread) [-].
EVALUATED_SAMPLES = 20
#: Samples of a block at which the preload sensitivity dT/dF is taken (evenly picked) [-].
SIGNATURE_SPEEDS = 5
#: Tracker priors of a commissioned unit relative to the nominal ones [-].
COMMISSIONED_PRIOR = 0.05
#: Relative preload step of the preload sensitivity [-].
PRELOAD_STEP = 0.05
#: Temperature step of the temperature sensitivity dT/dTh of the tracker [K].
TEMPERATURE_STEP = 1.0


@dataclass(frozen=True)
class _Record:
    """What a block leaves behind for a later classification."""

    time: float
    measured: float
    predicted: float
    preload_sensitivity: float
    temperature_sensitivity: float
    operating_point: OperatingPoint
    noise_variance: float
    state: FloatArray
    covariance: FloatArray
    #: The block against this run's memory of its bin (:meth:`HealthMonitor._local`): its
    #: residual less the bin's healthy residual [N m] and that difference's variance
    #: [N^2 m^2]; None where the bin was no reference.
    local: tuple[float, float] | None = None
    #: The block's mean commissioned correction of the twin's drag, shape x surface [-]: a
    #: fault's change of the twin's drag is this unit's change times it.
    correction: float = 1.0


class _SteadyTwin:
    """The steady model through the cached :class:`.residuals.TwinPredictor`, for a screw with
    no real-time map (slower: a steady solve per new grid cell)."""

    def __init__(self, predictor: TwinPredictor, baseline: Baseline) -> None:
        self.predictor = predictor
        self.baseline = baseline

    def drag(
        self,
        speed: FloatArray,
        temperature: float,
        preload: float,
        *,
        preload_factor: float = 1.0,
    ) -> FloatArray:
        """Drag torque [N m] at each speed [rad/s], at the unit's own operating point
        (:meth:`.Baseline.unit_point`)."""
        out = []
        for w in speed:
            measured = OperatingPoint(
                screw_speed=float(w), temperature=temperature, preload=preload_factor * preload
            )
            op = self.baseline.unit_point(measured)
            out.append(self.predictor.predict(op).at(op))
        return np.array(out)


class HealthMonitor:
    """Live/offline fault detector of one ball screw (see the module docstring).

    Args:
        config: the screw's parameter set.
        settings: detection settings.
        model_factory: builds the twin (default :func:`.residuals.make_twin_model`).
        predictor: a predictor to share (its cache) between monitors of the same screw and
            residual settings, e.g. over many recordings; default: a new one.
    """

    def __init__(
        self,
        config: TwinConfig,
        settings: MonitorSettings | None = None,
        model_factory: object = make_twin_model,
        predictor: TwinPredictor | None = None,
        baseline: Baseline | None = None,
        twin: UnitTwin | None = None,
    ) -> None:
        self.config = config
        self.settings = settings or MonitorSettings()
        s = self.settings
        if predictor is not None and (
            predictor.config != config or predictor.settings != s.residual
        ):
            raise ConfigError("health monitor: the shared predictor has another config/settings")
        self.predictor = predictor or TwinPredictor(config, s.residual, model_factory)
        if baseline is None:
            baseline = replace(
                Baseline.nominal(config),
                error_relative=s.residual.model_error_relative,
                error_absolute=s.residual.model_error_absolute,
                sensor_noise=s.residual.sensor_noise,
            )
        else:
            baseline.check_config(config)
        self.baseline = baseline
        self.twin: UnitTwin | _SteadyTwin
        #: Why the twin is what it is (e.g. no real-time map for this screw).
        self.twin_note = ""
        scales = (baseline.dry_friction_scale, baseline.eyring_scale)
        #: Per class, the twin its response is read from (:meth:`_classify`): the nominal
        #: screw, or the one with the unit's commissioned friction (settings'
        #: ``unit_friction_responses`` for every class, ``unit_friction_jam`` for the jam's).
        self.fault_predictors = dict.fromkeys(FAULT_CHANGES, self.predictor)
        on_the_unit = [
            name
            for name in FAULT_CHANGES
            if s.unit_friction_responses or (s.unit_friction_jam and name == "jam_onset")
        ]
        if on_the_unit and scales != (1.0, 1.0):
            scaled = TwinPredictor(scaled_config(config, scales), s.residual, model_factory)
            self.fault_predictors.update(dict.fromkeys(on_the_unit, scaled))
        try:
            if twin is not None:
                self.twin = twin.adjusted(
                    baseline.preload_scale, baseline.temperature_shift, scales
                )
            else:
                self.twin = UnitTwin(
                    config, baseline.preload_scale, baseline.temperature_shift, scales
                )
            self.twin_name = "realtime_map"
        except MapError as err:
            self.twin = _SteadyTwin(self.predictor, baseline)
            self.twin_name = self.predictor.model.name
            self.twin_note = f"real-time map not used ({err}); the steady model predicts"
        #: Time of the blocks gated near standstill / reversals, and of those compared [s].
        self.gated_time = 0.0
        self.compared_time = 0.0
        gate_settings = s.residual
        if baseline.settling_angle is not None:  # the unit settles sooner than the default
            gate_settings = replace(
                s.residual, gate_angle=min(s.residual.gate_angle, baseline.settling_angle)
            )
        self.gate = ReversalGate(gate_settings)
        self.aligner = BlockAligner(s.residual)
        self.tracker = DriftTracker(self._tracker_settings())
        #: Blocks that share one error of the twin in the tracker's update [-].
        self._shared_blocks = max(s.drift_error_time / s.residual.block_duration, 1.0)
        block_rate = 1.0 / s.residual.block_duration
        share = s.false_alarm_rate / len(s.detectors)
        self.cusum = Cusum(s.cusum_shift, share, block_rate)
        #: The run's own residual per operating point and the CUSUM on its innovations
        #: (:mod:`.memory`), with the block times of those innovations.
        self.memory = ResidualMemory(agreement=s.bin_agreement, trend=s.bin_trend)
        self.local_cusum = Cusum(s.cusum_shift, share, block_rate)
        self._local_times: deque[float] = deque(maxlen=HISTORY_BLOCKS)
        self._local_stat = 0.0
        self.chi_square = WindowChiSquare(s.chi_square_window, share, block_rate)
        self.orders = defect_orders(config)
        #: The order test on the per-sample residual (:mod:`.order_stage`).
        self.order = OrderStage(s, self.orders, baseline, share)
        self.alarm: Alarm | None = None
        #: Following error of the friction over the last compared block [N m].
        self._last_lag = 0.0
        #: The friction's lag behind the twin, predicted with settings.lag_prediction.
        self._trailing = PredictedLag()
        #: (block mid time [s], classification) at each refinement of the alarm's class.
        self.classifications: list[tuple[float, Classification]] = []
        self.samples: list[HealthSample] = []
        self._start: float | None = None
        self._last_index: int | None = None
        self._noise_sum = 0.0
        self._noise_count = 0
        self._history: deque[_Record] = deque(maxlen=HISTORY_BLOCKS)
        #: (class, block time) -> the twin's torque change at each evaluated severity [N m]
        #: (a block's is asked again at every refinement of the class; one alarm per monitor,
        #: which re-arming replaces, so it holds at most the blocks of one classification)
        self._fault_changes: dict[tuple[str, float], FloatArray] = {}
        #: Largest power ratio of each order in the tests since the alarm's onset [-]: the
        #: ripple evidence the class is judged on (a defect's ripple also shifts the mean).
        self._order_peaks: dict[str, float] = {}

    @property
    def thresholds(self) -> dict[str, float]:
        """Alarm threshold of each detector that may alarm, in ``settings.detectors`` order
        [-]."""
        every = {
            "cusum": self.cusum.threshold,
            "local": self.local_cusum.threshold,
            "chi_square": self.chi_square.threshold,
            "spectral": self.order.test.threshold,
        }
        return {name: every[name] for name in self.settings.detectors}

    def _tracker_settings(self) -> TrackerSettings:
        """The tracker's priors: as set for the nominal twin (it learns the unit in the
        warm-up); for a commissioned unit the fit has already placed bias, friction level and
        preload, so the filter starts near certain and only follows slow drift (a fault is a
        departure from the baseline, not something to learn). There the bias is known to the
        block-mean noise (both directions of rotation pin it down), while what is left of the
        friction level is the twin's own error: an offset seen at one operating point is taken
        as a friction scale (it flips with the direction of rotation), not as a sensor bias
        (which does not, and would then alarm at the first reversal)."""
        t = self.settings.tracker
        b = self.baseline
        if b.source == "nominal":
            return t
        return replace(
            t,
            bias_prior=max(b.error_absolute, 1e-9),
            scale_prior=COMMISSIONED_PRIOR * t.scale_prior,
            preload_prior=COMMISSIONED_PRIOR * t.preload_prior,
        )

    # ------------------------------------------------------------------ inputs
    def add_torque(self, stamp: float, value: float) -> list[HealthSample]:
        """A measured torque sample (stamp [s], torque [N m]); returns new block results."""
        return self._run(self.aligner.add_torque(stamp, value))

    def add_speed(self, stamp: float, value: float) -> list[HealthSample]:
        """A screw-speed sample [s, rad/s]."""
        return self._run(self.aligner.add_speed(stamp, value))

    def add_temperature(self, stamp: float, value: float) -> list[HealthSample]:
        """A temperature sample [s, K]."""
        return self._run(self.aligner.add_temperature(stamp, value))

    def add_preload(self, stamp: float, value: float) -> list[HealthSample]:
        """A load-cell preload sample [s, N]."""
        return self._run(self.aligner.add_preload(stamp, value))

    def flush(self) -> list[HealthSample]:
        """Process what is still pending (end of a recording)."""
        return self._run(self.aligner.flush())

    def _run(self, blocks: list[Block]) -> list[HealthSample]:
        out = [self._process(b) for b in blocks]
        self.samples.extend(out)
        return out

    # ------------------------------------------------------------------ noise
    @property
    def sensor_variance(self) -> float | None:
        """Variance of one torque sample [N m^2]: given, or learnt in the warm-up (None yet)."""
        given = self.baseline.sensor_noise
        if given is not None:
            return given * given
        if self._noise_count == 0:
            return None
        return self._noise_sum / self._noise_count

    # ------------------------------------------------------------------ one block
    def _unknown(self, block: Block, note: str, op: OperatingPoint | None) -> HealthSample:
        return HealthSample(
            time=block.time,
            measured=float(np.mean(block.torque)),
            predicted=math.nan,
            residual=math.nan,
            normalized_residual=math.nan,
            innovation=math.nan,
            statistics={},
            test_statistic=0.0,
            threshold=0.0,
            verdict=FAULT if self.alarm else UNKNOWN,
            fault_class=self.alarm.classification.fault_class if self.alarm else "",
            confidence=self.alarm.classification.confidence if self.alarm else 0.0,
            operating_point=op,
            state=tuple(self.tracker.state.tolist()),
            note=note,
            span=block.span,
        )

    @property
    def lag_angle(self) -> float:
        """phi_l, the angle over which the unit's friction follows the drag [rad]: the gate
        angle (or the commissioned settling angle) over the settings' ``settling_lag_angles``
        (:mod:`.transient_terms`)."""
        return self.gate.settings.gate_angle / self.settings.settling_lag_angles

    def transient_variance(
        self, block: Block, inertia: float, lag: float, standstill: float
    ) -> float:
        """Variance of the twin's block mean from the block's motion [N^2 m^2], before the
        torque gain: the inertia torque's error, the edge curvature of the speed, ``lag``
        [N m], the friction's following error and presliding remainder
        (:mod:`.transient_terms`), and ``standstill``
        [N m], the error near standstill (the drag curve shifted ``standstill_shift`` of the
        settings)."""
        b = self.baseline
        span = block.span
        edge = (
            b.inertia * (block.edge_curvature[0] + block.edge_curvature[1]) / (4.0 * span)
            if span > 0.0
            else 0.0
        )
        return (b.inertia_error * inertia) ** 2 + edge**2 + lag**2 + standstill**2

    def block_sigma(self, block: Block, drag: float, transient: float, edge_change: float) -> float:
        """1-sigma error of the twin's block mean [N m] without the sensor noise (see
        :mod:`.baseline`): its steady error (band, absolute, outside the commissioned
        temperatures: growing with the distance, and from the shift with ``edge_change``
        [N m], the drag's change from the nearest commissioned temperature) and the
        ``transient`` variance of :meth:`transient_variance`."""
        b = self.baseline
        speed = float(np.mean(block.speed))
        outside = b.temperature_error * b.temperature_distance(block.temperature, speed)
        shift = b.extrapolation_error(edge_change)
        error = b.error_at(speed, block.temperature)
        return b.torque_gain * math.sqrt(
            (error * drag) ** 2 + b.error_absolute**2 + (outside * drag) ** 2 + shift**2 + transient
        )

    def _process(self, block: Block) -> HealthSample:
        s = self.settings
        b = self.baseline
        if self._start is None:
            self._start = block.time
        in_warmup = block.time - self._start < s.warmup
        angle = self.order.angle(block)
        gate = self.gate.check(block)
        travel = self.gate.travel
        if "speed" in block.held:
            gate = gate or "gated: the speed was held past its last sample (late or ended)"
        elif gate and (part := self.gate.compared_part(block)) is not None:
            # compared on its stroke between the gated samples (settings.partial_share)
            whole = block.span
            block, angle = block.part(*part), angle[part[0] : part[1]]
            travel = travel[part[0] : part[1]]
            self.gated_time += whole - block.span
            gate = ""
        speed = float(np.mean(block.speed))
        op = OperatingPoint(screw_speed=speed, temperature=block.temperature, preload=block.preload)
        if gate:
            self.gated_time += block.span
            return self._unknown(block, gate, op)
        try:
            op.validate()
            # The twin at up to EVALUATED_SAMPLES evenly spread samples, linear in time in
            # between (the drag is smooth over a block; a 1 kHz meter need not cost 100 maps).
            stride = max(math.ceil(len(block.speed) / EVALUATED_SAMPLES), 1)
            at = np.unique(np.append(np.arange(0, len(block.speed), stride), len(block.speed) - 1))
            evaluated = self.twin.drag(block.speed[at], block.temperature, block.preload)
            factor = b.shape(block.speed[at]) * b.surface_factor(block.speed[at], block.temperature)
            drags = np.interp(block.stamps, block.stamps[at], evaluated * factor)
            picked = np.arange(0, len(at), max(len(at) // SIGNATURE_SPEEDS, 1))
            few = at[picked]
            lighter = (
                self.twin.drag(
                    block.speed[few],
                    block.temperature,
                    block.preload,
                    preload_factor=1.0 - PRELOAD_STEP,
                )
                * factor[picked]
            )
            # the drag curve shifted standstill_shift towards standstill, at the same samples
            toward = block.speed[few] - np.sign(block.speed[few]) * s.standstill_shift
            shifted = self.twin.drag(toward, block.temperature, block.preload) * factor[picked]
            # the tracker's temperature sensitivity, at the same samples
            warm = block.temperature + TEMPERATURE_STEP
            warmer = (
                self.twin.drag(block.speed[few], warm, block.preload) * factor[picked]
                if self.tracker.settings.tracks_temperature
                else None
            )
            # outside the temperatures commissioned at this speed: the drag at the nearest one
            edge = b.nearest_commissioned(block.temperature, speed)
            at_edge = (
                self.twin.drag(block.speed[few], edge, block.preload) * factor[picked]
                if edge != block.temperature
                else drags[few]
            )
        except BallscrewTwinError as err:  # invalid operating point, solver failure
            return self._unknown(block, f"no prediction: {err}", None)
        drag = float(np.mean(drags))
        heavy = float(np.mean(drags[few]))
        edge_change = heavy - float(np.mean(at_edge))
        load = max(block.preload, 1e-9)
        preload_sensitivity = (
            b.torque_gain * (heavy - float(np.mean(lighter))) / (PRELOAD_STEP * load)
        )
        temperature_sensitivity = (
            b.torque_gain * (float(np.mean(warmer)) - heavy) / TEMPERATURE_STEP
            if warmer is not None
            else 0.0
        )
        self.compared_time += block.span

        n = len(block.torque)
        measured = float(np.mean(block.torque))
        if in_warmup and b.sensor_noise is None:
            variance = within_block_variance(block)
            if variance is not None:
                self._noise_sum += variance
                self._noise_count += 1
        sensor_var = self.sensor_variance
        if sensor_var is None:
            return self._unknown(block, "warm-up: sensor noise not known yet", op)

        inertia = b.inertia * block.mean_acceleration
        if abs(inertia) > s.inertia_gate * abs(drag):
            self.compared_time -= block.span
            self.gated_time += block.span
            return self._unknown(
                block,
                f"gated: inertia torque {inertia:.3g} N m exceeds {s.inertia_gate:g} x the "
                f"drag {drag:.3g} N m",
                op,
            )
        trailing = self._trailing.block(
            block.stamps, at, angle[at], evaluated * factor, s.lag_prediction * self.lag_angle
        )
        predicted = b.torque_gain * (drag + float(np.mean(trailing)) + inertia) + b.torque_bias
        residual = measured - predicted
        # the lag outlasts the sweep by a block: this block's following error or the last
        # one's, of which a lag_prediction share k of the angle is predicted, leaving
        # max(k, 1 - k) of it unknown
        following = following_error(angle[at], evaluated * factor, block.stamps[at], self.lag_angle)
        unknown_share = max(s.lag_prediction, 1.0 - s.lag_prediction)
        # and what is left of a reversal's presliding jump, times the settings' share of it
        remainder = s.presliding_remainder * presliding_remainder(travel, drags, self.lag_angle)
        lag = math.hypot(unknown_share * max(following, self._last_lag), remainder)
        standstill = float(np.mean(np.abs(drags[few] - shifted)))
        transient = self.transient_variance(block, inertia, lag, standstill)
        model_sigma = self.block_sigma(block, drag, transient, edge_change)
        self._last_lag = following
        noise_var = sensor_var / n + model_sigma**2
        normalized = residual / math.sqrt(noise_var)
        gap = 1 if self._last_index is None else max(block.index - self._last_index, 1)
        self._last_index = block.index
        prior_state = self.tracker.state
        prior_cov = np.array(self.tracker.kf.P, dtype=float)
        step = self.tracker.step(
            measured,
            predicted,
            preload_sensitivity,
            noise_var,
            gap * s.residual.block_duration,
            update_variance=sensor_var / n + self._shared_blocks * model_sigma**2,
            temperature_sensitivity=temperature_sensitivity,
        )
        own = b.torque_gain * math.sqrt(transient)
        local, local_change = self._local(block, speed, residual, drag, own, sensor_var / n)
        self._history.append(
            _Record(
                block.time,
                measured,
                predicted,
                preload_sensitivity,
                temperature_sensitivity,
                op,
                noise_var,
                prior_state,
                prior_cov,
                local_change,
                float(np.mean(factor)),
            )
        )
        # per sample (with the predicted lag) for the order test, which takes the inertia
        # torque off when the next block's speed is known
        expected = b.torque_gain * (drags + trailing) + b.torque_bias
        self.order.hold(block.stamps, block.torque - expected, angle, drags)
        e = step.normalized
        if in_warmup:
            return self._sample(block, measured, predicted, residual, normalized, e, {}, op)

        local_step = None
        if local is not None:
            local_step = self.local_cusum.update(local)
            self._local_times.append(block.time)
            self._local_stat = local_step.statistic
        # oriented by the direction of the friction: a fault that changes the friction moves
        # the residual with the drag's sign, and reversals must not undo what it accumulated
        # the block's information on a change of the drag: its variance without the
        # transient terms (which a fault does not change) over its whole variance
        steady_share = max(noise_var - (b.torque_gain**2) * transient, 0.0) / noise_var
        weight = max(math.sqrt(steady_share), s.cusum_min_weight)
        cusum = self.cusum.update(e if drag >= 0.0 else -e, weight)
        chi_stat, chi_alarm = self.chi_square.update(e)
        if self.order.run(block.time) and self.alarm is not None and not self.alarm.final:
            for name, ratio in self.order.ratios.items():
                self._order_peaks[name] = max(ratio, self._order_peaks.get(name, 0.0))
        statistics = {
            "cusum": cusum.statistic,
            "local": self._local_stat,
            "chi_square": chi_stat,
            "spectral": self.order.statistic,
        }
        stats = {name: (statistics[name], limit) for name, limit in self.thresholds.items()}
        if self.alarm is None:
            fired = [
                name
                for name, hit in (
                    ("spectral", self.order.ripple_alarm),
                    ("cusum", cusum.alarm),
                    ("local", local_step is not None and local_step.alarm),
                    ("chi_square", chi_alarm),
                )
                if hit and name in s.detectors
            ]
            if fired:
                detector = fired[0]
                blocks_back = self.cusum.count - cusum.change_index - 1
                if detector == "cusum":
                    onset = block.time - blocks_back * s.residual.block_duration
                elif detector == "local" and local_step is not None:
                    back = self.local_cusum.count - local_step.change_index - 1
                    onset = self._local_times[max(len(self._local_times) - 1 - back, 0)]
                elif detector == "chi_square":
                    onset = block.time - s.chi_square_window * s.residual.block_duration
                else:
                    onset = block.time - s.spectral_window
                self.alarm = Alarm(
                    float(block.stamps[-1]), detector, onset, Classification("", 0.0, {}, {})
                )
                self._order_peaks = dict(self.order.ratios)
                self.tracker.frozen = True
        if self.alarm is not None and not self.alarm.final:
            self.alarm.classification = self._classify()
            self.classifications.append((block.time, self.alarm.classification))
            elapsed = block.stamps[-1] - self.alarm.time
            if elapsed >= s.classification_window and (
                self.alarm.classification.confidence >= s.confident_class
                or elapsed >= s.classification_patience
            ):
                self.alarm.final = True
        return self._sample(block, measured, predicted, residual, normalized, e, stats, op)

    def _local(
        self,
        block: Block,
        speed: float,
        residual: float,
        drag: float,
        own: float,
        sensor_variance: float,
    ) -> tuple[float | None, tuple[float, float] | None]:
        """Innovation of the block against this run's memory of its operating point and
        motion (:mod:`.memory`), and the block's residual less its bin's healthy residual
        [N m] with that difference's variance [N^2 m^2]; (None, None) when the block is mostly
        inertia or lag (``own``, the transient sigma [N m], beyond LOUD_SIGMA of the drag), is
        within the settings' ``local_settling`` gate angles of a reversal or stop, or its bin is
        new. A healthy block updates its bin."""
        scale = self.baseline.torque_gain * abs(drag)
        change = block.mean_acceleration * block.span
        key = bin_key(speed, block.temperature, block.preload, change)
        if key is None or scale <= 0.0:
            return None, None
        if self.gate.block_travel < self.settings.local_settling * self.gate.settings.gate_angle:
            return None, None
        if own > LOUD_SIGMA * scale:
            return None, None
        variance = (sensor_variance + (REPEAT_SHARE * own) ** 2) / scale**2
        relative = residual / (self.baseline.torque_gain * drag)
        where = (block.time, block.temperature, speed)
        z = self.memory.innovation(key, relative, variance, *where)
        found = self.memory.reference(key, *where)
        if self.alarm is None and (z is None or abs(z) < UPDATE_GATE):
            self.memory.update(key, relative, variance, *where)
        if found is None:
            return z, None
        mean, spread = found
        torque = self.baseline.torque_gain * drag
        return z, ((relative - mean) * torque, (variance + spread) * torque**2)

    def _sample(
        self,
        block: Block,
        measured: float,
        predicted: float,
        residual: float,
        normalized: float,
        innovation: float,
        stats: dict[str, tuple[float, float]],
        op: OperatingPoint,
    ) -> HealthSample:
        """Assemble a result and its verdict."""
        s = self.settings
        if stats:
            name = max(stats, key=lambda k: stats[k][0] / stats[k][1])
            stat, threshold = stats[name]
        else:
            name, stat, threshold = "", 0.0, 0.0
        ratio = stat / threshold if threshold > 0.0 else 0.0
        note = f"held: {', '.join(block.held)}" if block.held else ""
        if self.alarm is not None:
            verdict = FAULT
            fault_class = self.alarm.classification.fault_class
            confidence = self.alarm.classification.confidence
            note = f"alarm by {self.alarm.detector} at {self.alarm.time:.3f} s"
        elif not stats:
            verdict, fault_class, confidence = UNKNOWN, "", 0.0
            note = "warm-up"
        elif ratio >= s.warn_fraction:
            verdict, fault_class, confidence = WARN, "", min(ratio, 1.0)
            note = f"{name} at {ratio:.0%} of its threshold"
        else:
            verdict, fault_class, confidence = OK, "", 1.0 - ratio
        return HealthSample(
            time=block.time,
            measured=measured,
            predicted=predicted,
            residual=residual,
            normalized_residual=normalized,
            innovation=innovation,
            statistics=stats,
            test_statistic=stat,
            threshold=threshold,
            verdict=verdict,
            fault_class=fault_class,
            confidence=confidence,
            operating_point=op,
            state=tuple(self.tracker.state.tolist()),
            note=note,
            span=block.span,
        )

    # ------------------------------------------------------------------ classification
    def _classify(self) -> Classification:
        """Class of the current alarm from the evidence since its onset."""
        assert self.alarm is not None
        threshold = self.order.test.threshold
        if any(r > threshold for r in self._order_peaks.values()):
            # an order line since the alarm names a defect whichever detector alarmed first
            # (its ripple shifts the mean drag by half its peak, which the mean-shift tests see;
            # a spectral alarm seeded these peaks with the ratios that raised it)
            return classify_ripple(self._order_peaks, threshold)
        records = [r for r in self._history if r.time >= self.alarm.onset]
        if not records:
            return Classification("", 0.0, {}, {}, reason="no compared block since the onset")
        base = records[0]
        residuals, sigmas, preload = [], [], []
        for r in records:
            if r.local is not None:
                # the change since this run's healthy past at the same operating point: free
                # of the twin's own error there, which would bend the classes' fits
                residuals.append(r.local[0])
                sigmas.append(math.sqrt(r.local[1]))
            else:
                expected = self.tracker.expected(
                    r.predicted, r.preload_sensitivity, base.state, r.temperature_sensitivity
                )
                h = self.tracker.observation(
                    r.predicted, r.preload_sensitivity, r.temperature_sensitivity
                )
                residuals.append(r.measured - expected)
                sigmas.append(math.sqrt(r.noise_variance + float(h @ base.covariance @ h)))
            preload.append(-r.operating_point.preload * r.preload_sensitivity)
        gain = self.baseline.torque_gain

        def response(name: str) -> Response:
            # the changed twin at every evaluated severity (the response bends between them),
            # at the unit's own operating point, scaled as the unit's drag is (its commissioned
            # shape and surface correct the twin's drag; a change of it in the same measure)
            _, severities = FAULT_CHANGES[name]
            predictor = self.fault_predictors[name]
            for r in records:
                if (name, r.time) not in self._fault_changes:
                    op = self.baseline.unit_point(r.operating_point)
                    self._fault_changes[(name, r.time)] = np.array(
                        [
                            gain * r.correction * predictor.fault_change(name, op, a)
                            for a in severities
                        ]
                    )
            changes = [self._fault_changes[(name, r.time)] for r in records]
            return Response(np.array(severities), np.array(changes).T)

        responses: dict[str, FloatArray | Response] = {
            "preload_loss": np.array(preload),
            **{name: response(name) for name in FAULT_CHANGES},
        }
        elapsed = np.array([r.time - self.alarm.onset for r in records])
        correlation = self.settings.error_correlation_time / self.settings.residual.block_duration
        return classify_mean_shift(
            np.array(residuals), np.array(sigmas), responses, elapsed, correlation
        )


def feed(
    monitor: HealthMonitor, channels: Mapping[str, tuple[FloatArray, FloatArray]]
) -> list[HealthSample]:
    """Feed recorded channels to ``monitor`` merged in stamp order, then flush.

    Args:
        channels: "torque" [N m], "speed" [rad/s], "temperature" [K], "preload" [N] ->
            (stamps [s], values); torque and speed are required.

    Returns:
        Every block result, in time order (also in ``monitor.samples``).
    """
    adders = {
        "torque": monitor.add_torque,
        "speed": monitor.add_speed,
        "temperature": monitor.add_temperature,
        "preload": monitor.add_preload,
    }
    for required in ("torque", "speed", "temperature", "preload"):
        if required not in channels:
            raise ConfigError(f"health monitor: channel {required!r} is missing")
    # Slow channels before torque at equal stamps: the order a live node most likely sees.
    priority = {"speed": 0, "temperature": 1, "preload": 2, "torque": 3}
    stamps = np.concatenate([np.asarray(channels[c][0], float) for c in adders])
    which = np.concatenate([np.full(len(channels[c][0]), priority[c]) for c in adders])
    values = np.concatenate([np.asarray(channels[c][1], float) for c in adders])
    order = np.lexsort((which, stamps))
    by_priority = [adders[c] for c in sorted(adders, key=priority.__getitem__)]
    start = len(monitor.samples)
    for i in order:
        by_priority[which[i]](float(stamps[i]), float(values[i]))
    monitor.flush()
    return monitor.samples[start:]
