"""``ballscrew-twin commission BAG [BAG ...] --out baseline.yaml``: learn the healthy unit from
one healthy recording, or several of the same unit fitted together (:func:`one_timeline`).

The monitor's faults are deviations from *this* unit, not from the nominal screw. On a healthy
recording (a bag, or the first minutes of a live run) the blocks the monitor would compare
(:class:`.residuals.ReversalGate`) are fitted with the unit model of :mod:`.baseline`:

    z_j = g (mean_i S(w_ij) T_unit(w_ij, T_j + dT, k_F F_j; k_mu, k_tau) + J a_j) + b,

over theta = (g, b, ln k_F, dT, J, beta_1, beta_2, ln k_mu, ln k_tau) (the last two, the
unit's mu_dry and tau_0 scales, only where the screw has a friction response table:
:mod:`~ballscrew_twin.models.friction_response`), by scipy's trust-region least squares (the
calibration's method) with the relative block residuals r_j / (|T_j| + e_abs) / 1 % as the
cost under a soft-L1 loss (a block across a preload step or a hard acceleration does not pull
the whole fit), plus Gaussian priors from the production spreads (one sigma: preload 15 %,
gain 2 %, temperature shift 5 K, each shape coefficient 0.1, ln k_mu and ln k_tau 0.3:
:data:`PRIOR_SIGMA`). The priors
matter: at one set preload a preload scale and a gain change the torque nearly alike, and the
priors split that change the way the spreads of a production lot make likeliest (a maximum a
posteriori fit). The uncertainty of each fitted value
comes from the Jacobian at the optimum, (J' J)^-1 times the reduced residual variance (it does
not include the pull of the priors where the data hardly tell two unknowns apart).

The twin's error after the fit sets the baseline's error model: e_rel is ``error_scale`` times
the 95th percentile of |r_j| / |T_j| over 1.96 (a 1-sigma equivalent that a few outliers do not
inflate), e_abs the block-mean sensor noise floor, the sensor noise sigma_s the median scatter
within the blocks at low acceleration. ``--plot`` draws measured against predicted (nominal and
fitted), the relative residual, and the fitted values with their uncertainties.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, TypedDict

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from ..errors import ConfigError
from ..params import TwinConfig, check_number, config_fingerprint, limits, not_negative, positive
from .baseline import (
    BAND_REACH,
    ERROR_BAND_EDGES,
    SHIFT_EXTRAPOLATION,
    SPEED_BIN_COUNT,
    Baseline,
    speed_bin,
)
from .correction import (
    LOG_SPEED_NODES,
    MIN_SUPPORT,
    TEMPERATURE_NODES,
    ResidualSurface,
    basis,
    nearest_nodes,
    robust_fit,
)
from .residuals import (
    Block,
    BlockAligner,
    FloatArray,
    ResidualSettings,
    ReversalGate,
    UnitTwin,
    within_block_variance,
)

#: One-sigma priors of the fitted values (the production spreads of issue 13) [-].
PRIOR_SIGMA = {
    "torque_gain": 0.02,
    "preload_scale": 0.15,
    "temperature_shift": 5.0,
    "shape": 0.1,
    "friction_scale": 0.3,
}
#: Relative block misfit taken as one sigma by the fit's weights [-], and the misfit (in
#: those sigmas) beyond which a block counts linearly, not squared (soft-L1 loss: a block
#: across a preload step or a hard acceleration does not pull the whole fit).
FIT_SIGMA = 0.01
ROBUST_SCALE = 3.0
#: Weight of the priors as a share of the fitted blocks [-].
PRIOR_SHARE = 0.1
#: Most blocks the fit uses (evenly picked) and speeds per block for its drag mean [-].
FIT_BLOCKS = 600
FIT_SPEEDS = 8
#: Default ``error_scale``: e_rel = scale x the fit's 95th-percentile relative error / 1.96.
ERROR_SCALE = 1.5
#: Floor of e_rel [-]: the real-time map's own interpolation error (bench accuracy: 0.7 %).
ERROR_FLOOR = 0.007
#: Fewest blocks in a speed band for its own error; below, the band's error is at least
#: ``unseen_error``, by default UNSEEN_ERROR [-]: 1.5 % since round 28 of issue 13 (3 % before;
#: with the thermometer's drift tracked, the innovations where the commissioning had not taught
#: the twin stayed within 2.05 % (p99) on the training units, docs/benchmarks.md).
BAND_BLOCKS = 20
UNSEEN_ERROR = 0.015
#: Quantile of the parametric fit's |relative residual| taken as the error where the residual
#: surface has no support [-].
UNSEEN_QUANTILE = 0.99
#: The numeric keywords of :func:`commission` and the limits each is checked against
#: (:func:`~ballscrew_twin.params.check_number`; ``bench detection --compare-setting`` too).
KEYWORD_LIMITS: dict[str, dict[str, Any]] = {
    "error_scale": positive("-"),
    "unseen_error": positive("-"),
    "unseen_quantile": limits("-", 0.0, 1.0, lo_open=True),
    "temperature_error": not_negative("1/K"),
    "shift_extrapolation": positive("K"),
    "band_reach": limits("-", 0.0, 3.0),
}


class CommissionKeywords(TypedDict, total=False):
    """The keywords of :data:`KEYWORD_LIMITS`, each optional, to pass to :func:`commission`
    as ``**keywords`` (units there)."""

    error_scale: float
    unseen_error: float
    unseen_quantile: float
    temperature_error: float
    shift_extrapolation: float
    band_reach: float


#: Blocks whose inertia torque exceeds this share of their drag do not teach the residual
#: surface (the inertia's own error would) [-].
SURFACE_INERTIA = 0.3
#: Huber scale of the surface's robust fit [-] and length of the alternating stretches of its
#: two cross-validation folds [s].
SURFACE_SCALE = 0.01
FOLD_CHUNK = 30.0
#: e_J, the inertia torque's relative error: INERTIA_SIGMAS times the fit's relative
#: uncertainty of J, at least INERTIA_ERROR_FLOOR (training units: the fitted J was off by
#: up to 3.5 % where the fit claimed 0.45 %, the twin's systematic error leaking into it) [-].
INERTIA_SIGMAS = 3.0
INERTIA_ERROR_FLOOR = 0.05
#: The settling angle after reversals (:func:`_settling_angle`): bin width [rad], fewest
#: blocks in all [-], quantile [-] and ratio to the band error [-] a bin's blocks must meet,
#: and the largest ratio one of them may reach [-].
SETTLING_STEP = 0.1
SETTLING_BLOCKS = 10
SETTLING_QUANTILE = 0.9
SETTLED_RATIO = 2.0
SETTLED_MAX = 4.0
#: e_T, growth of the relative error per kelvin outside the temperatures commissioned at a
#: speed [1/K]. 0.5 %/K until round 34 of issue 13; `bench extrapolation` on training units
#: 0-12 (steady blocks up to 40 K outside, under baselines of a whole cold start, of its first
#: 200 s and of its last 600 s): at 0.2 %/K no block 2 K or more outside reached a ratio of
#: error to sigma above 1.24, against 5.2 inside the commissioned range (the fitted shift's
#: term E_dT already covers most of it); held out on units 31000-31014 it changed one alarm,
#: 0.1 s earlier, and raised no false alarm.
TEMPERATURE_ERROR = 0.002
#: Time between two recordings fitted together, on the one time line of :func:`one_timeline`
#: [s] (longer than a block, so that no block spans the seam).
RECORDING_GAP = 10.0

#: One recording: channel name -> (absolute stamps [s], values [SI]).
Channels = Mapping[str, tuple[FloatArray, FloatArray]]


@dataclass(frozen=True)
class FitBlock:
    """A block the fit uses (SI units).

    Attributes:
        time: mid time [s]; measured: block mean torque [N m]; speeds: picked speeds [rad/s];
        temperature [K]; preload [N]; acceleration: block mean dw/dt [rad/s^2]; samples: n.
    """

    time: float
    measured: float
    speeds: FloatArray
    temperature: float
    preload: float
    acceleration: float
    samples: int


@dataclass(frozen=True)
class CommissioningResult:
    """A fitted baseline and what the plot shows.

    Attributes:
        baseline: the fitted unit.
        uncertainty: 1-sigma uncertainty of each fitted value (baseline's units).
        blocks: the blocks fitted.
        nominal: predicted block means of the nominal twin [N m].
        fitted: predicted block means of the fitted baseline [N m].
        gated_share: share of the recording's blocks gated [-].
        at_bounds: the fitted values that ended on a bound of the fit (names as in
            ``uncertainty``): the recording did not pin the unit down there, and the residual
            surface and the unseen error took up the rest (held-out unit 22023 of ``bench
            detection``: gain 0.50 and preload scale 1.74 against a true 1.02 and 0.90).
    """

    baseline: Baseline
    uncertainty: dict[str, float]
    blocks: list[FitBlock]
    nominal: FloatArray
    fitted: FloatArray
    gated_share: float
    at_bounds: tuple[str, ...] = ()


def aligned_blocks(channels: Channels, settings: ResidualSettings) -> list[Block]:
    """Every block of a recording's channels (absolute stamps [s], SI values), merged in
    stamp order as the monitor sees them (:func:`.monitor.feed`)."""
    aligner = BlockAligner(settings)
    adders = {
        "speed": aligner.add_speed,
        "temperature": aligner.add_temperature,
        "preload": aligner.add_preload,
        "torque": aligner.add_torque,
    }
    names = list(adders)
    for name in names:
        if name not in channels:
            raise ConfigError(f"commission: channel {name!r} is missing")
    stamps = np.concatenate([np.asarray(channels[c][0], float) for c in names])
    which = np.concatenate([np.full(len(channels[c][0]), k) for k, c in enumerate(names)])
    values = np.concatenate([np.asarray(channels[c][1], float) for c in names])
    blocks: list[Block] = []
    calls = [adders[c] for c in names]
    for i in np.lexsort((which, stamps)):
        blocks.extend(calls[which[i]](float(stamps[i]), float(values[i])))
    blocks.extend(aligner.flush())
    return blocks


def _pick(values: FloatArray, count: int) -> FloatArray:
    step = max(len(values) // count, 1)
    return np.asarray(values[::step], dtype=float)


class _AdjustedUnit:
    """The twin adjusted to theta = (g, b, ln k_F, dT, J, beta_1, beta_2, ln k_mu, ln k_tau):
    preload scale, temperature shift and friction scales, the shape correction, and the
    residual surface when given."""

    def __init__(
        self, twin: UnitTwin, theta: FloatArray, surface: ResidualSurface | None = None
    ) -> None:
        self.unit = twin.adjusted(
            math.exp(theta[2]), theta[3], (math.exp(theta[7]), math.exp(theta[8]))
        )
        self.shaped = Baseline(
            config="",
            fingerprint="",
            inertia=1.0,
            shape_slope=theta[5],
            shape_curvature=theta[6],
            surface=surface,
        )

    def drag(self, speeds: FloatArray, temperature: float, preload: float) -> FloatArray:
        """Drag torque [N m] at each of ``speeds`` [rad/s], ``temperature`` [K], ``preload``
        [N]."""
        values = self.unit.drag(speeds, temperature, preload) * self.shaped.shape(speeds)
        return np.asarray(values * self.shaped.surface_factor(speeds, temperature))


def _drags(
    twin: UnitTwin,
    theta: FloatArray,
    blocks: list[FitBlock],
    surface: ResidualSurface | None = None,
) -> FloatArray:
    """Block means of the drag with the shape correction (and the surface) [N m]."""
    adjusted = _AdjustedUnit(twin, theta, surface)
    return np.array(
        [float(np.mean(adjusted.drag(b.speeds, b.temperature, b.preload))) for b in blocks]
    )


def _predict(
    twin: UnitTwin,
    theta: FloatArray,
    blocks: list[FitBlock],
    surface: ResidualSurface | None = None,
) -> FloatArray:
    """Block means of the unit model with parameters theta (:class:`_AdjustedUnit`; and the
    residual surface)."""
    drag = _drags(twin, theta, blocks, surface)
    accel = np.array([b.acceleration for b in blocks])
    return np.asarray(theta[0] * (drag + theta[4] * accel) + theta[1])


@dataclass(frozen=True)
class SurfaceStudy:
    """The blocks the residual surface is learnt from (those whose inertia torque is below
    SURFACE_INERTIA of their drag).

    Attributes:
        times: block mid times [s]; speeds: block mean |speed| [rad/s];
        residual: relative residual of the parametric fit, (z - z_fit) / (g D) [-];
        design: each block's drag-weighted mean basis of the surface's nodes [-];
        nearness: each block's drag-weighted share of samples nearest to each node [-]
            (:func:`~ballscrew_twin.health.correction.nearest_nodes`).
    """

    times: FloatArray
    speeds: FloatArray
    residual: FloatArray
    design: FloatArray
    nearness: FloatArray


def out_of_fold_residuals(study: SurfaceStudy) -> FloatArray:
    """Relative residual [-] of each block after the residual surface learnt without it: two
    folds of alternating FOLD_CHUNK-long stretches, each predicted by the surface of the other.
    NaN where the other fold's surface has an interpolated support below MIN_SUPPORT blocks.

    Not the monitor's unlearnt share (:meth:`ResidualSurface.unlearnt_share`): judging only
    blocks where at most 10 % of the fold's surface came from untaught nodes shrank the bands
    of the dev units' extrapolated regimes (unit 5022: 2.9 % -> 0.9 % at 3-10 rad/s) but left
    others with too few judged blocks, raised to the 3 % of a band hardly seen (unit 5021,
    below 3 rad/s), and detected no better (units 5019-5024 side by side: the same alarms but
    one jam missed; round 8 of issue 13, not kept)."""
    folds = _folds(study.times)
    out_of_fold = np.full(len(study.residual), np.nan)
    for k in (0, 1):
        train, held = folds != k, folds == k
        if np.count_nonzero(train) >= BAND_BLOCKS and np.any(held):
            fold_surface = robust_fit(
                study.design[train], study.residual[train], study.nearness[train], SURFACE_SCALE
            )
            learnt = held & (study.design @ np.ravel(fold_surface.support) >= MIN_SUPPORT)
            predicted = study.design[learnt] @ np.ravel(fold_surface.values)
            out_of_fold[learnt] = study.residual[learnt] - predicted
    return out_of_fold


def _folds(times: FloatArray) -> NDArray[np.int64]:
    """Fold (0 or 1) of each block at ``times`` [s]: alternating FOLD_CHUNK-long stretches."""
    return np.asarray(np.floor((times - times[0]) / FOLD_CHUNK).astype(np.int64) % 2)


def validated_support(study: SurfaceStudy) -> FloatArray:
    """Each node's support as far as both folds of :func:`out_of_fold_residuals` taught it
    [blocks]: twice the smaller of the two folds' supports (the plain support when the
    recording is too short for two folds).

    A node that one stretch of the recording alone taught is learnt by the surface but never
    judged out of fold (the other fold's surface has no support there), so the band errors do
    not know how wrong it is. Held-out unit 13001 (round 14 of issue 13): its commissioning
    saw 100-300 rad/s below -4 C only in its first 30 s; the surface, smoothed and robust to
    1 % misfits, left 2-4 % there in sample while the band's error was 0.7 %, and a later run
    at -9.6 C and 170 rad/s, 4.3 % above the twin, raised the CUSUM 8 s before its fault.
    With this support those nodes are thin, and the unseen error covers them.
    """
    folds = _folds(study.times)
    shape = (len(LOG_SPEED_NODES), len(TEMPERATURE_NODES))
    if np.all(folds == 0):
        return np.sum(study.nearness, axis=0).reshape(shape)
    per_fold = [np.sum(study.nearness[folds == k], axis=0) for k in (0, 1)]
    return (2.0 * np.minimum(per_fold[0], per_fold[1])).reshape(shape)


def _surface_study(twin: UnitTwin, theta: FloatArray, usable: list[Block]) -> SurfaceStudy:
    """Relative residuals and design rows of every usable block at the fitted ``theta``."""
    adjusted = _AdjustedUnit(twin, theta)
    times, speeds, residual, rows, near = [], [], [], [], []
    for b in usable:
        picked = _pick(b.speed, FIT_SPEEDS)
        drags = adjusted.drag(picked, b.temperature, b.preload)
        drag = float(np.mean(drags))
        inertia = theta[4] * b.mean_acceleration
        if abs(drag) < 1e-9 or abs(inertia) > SURFACE_INERTIA * abs(drag):
            continue
        predicted = theta[0] * (drag + inertia) + theta[1]
        times.append(b.time)
        speeds.append(float(np.mean(np.abs(b.speed))))
        residual.append((float(np.mean(b.torque)) - predicted) / (theta[0] * drag))
        weights = drags / np.sum(drags)
        temperatures = np.full(len(picked), b.temperature)
        rows.append(weights @ basis(picked, temperatures))
        near.append(weights @ nearest_nodes(picked, temperatures))
    if len(rows) < BAND_BLOCKS:
        raise ConfigError(
            f"commission: {len(rows)} blocks at low acceleration; at least {BAND_BLOCKS} are "
            "needed to learn the unit's residual surface"
        )
    return SurfaceStudy(
        np.array(times), np.array(speeds), np.array(residual), np.array(rows), np.array(near)
    )


def _settling_angle(
    twin: UnitTwin,
    theta: FloatArray,
    surface: ResidualSurface,
    blocks: list[tuple[Block, float]],
    bands: tuple[float, ...],
    gate_angle: float,
) -> float:
    """Screw rotation after a reversal or stop [rad] beyond which this unit's torque is as
    well predicted as anywhere: the least angle a (on a SETTLING_STEP grid) from which the
    SETTLING_QUANTILE of |relative residual| / band error over the blocks gated by angle alone
    (at least SETTLING_BLOCKS of them at >= a) stays within SETTLED_RATIO; ``gate_angle`` when
    the recording has too few such blocks. Measured on the data: it makes no assumption about
    the unit's presliding law. Per bin of SETTLING_STEP from the gate down: a bin is settled
    when its SETTLING_QUANTILE ratio is within SETTLED_RATIO and its largest within SETTLED_MAX;
    the angle is the lower edge of the lowest bin of the settled run that reaches the gate
    (bins without data are passed over, but the angle does not go below the lowest data)."""
    if not blocks:
        return gate_angle
    adjusted = _AdjustedUnit(twin, theta, surface)
    errors = Baseline(
        config="", fingerprint="", inertia=theta[4], error_bands=bands, surface=surface
    )
    travels, ratios = [], []
    for b, travel in blocks:
        picked = _pick(b.speed, FIT_SPEEDS)
        drag = float(np.mean(adjusted.drag(picked, b.temperature, b.preload)))
        inertia = theta[4] * b.mean_acceleration
        if abs(drag) < 1e-9 or abs(inertia) > SURFACE_INERTIA * abs(drag):
            continue
        relative = (float(np.mean(b.torque)) - theta[0] * (drag + inertia) - theta[1]) / (
            theta[0] * drag
        )
        error = errors.error_at(float(np.mean(b.speed)), b.temperature)
        travels.append(travel)
        ratios.append(abs(relative) / error)
    travel_arr, ratio_arr = np.array(travels), np.array(ratios)
    if len(ratio_arr) < SETTLING_BLOCKS:
        return gate_angle
    # From the top down: the angle is the upper edge of the highest bin that is not settled
    # (everything beyond it is), and never below the lowest bin the data reach.
    edges = np.arange(0.0, gate_angle + 0.5 * SETTLING_STEP, SETTLING_STEP)
    settled_from = float(edges[-1])
    lowest = float(edges[-1])
    for low, high in reversed(list(itertools.pairwise(edges))):
        inside = ratio_arr[(travel_arr >= low) & (travel_arr < high)]
        if len(inside) == 0:
            continue
        lowest = float(low)
        if (
            float(np.quantile(inside, SETTLING_QUANTILE)) > SETTLED_RATIO
            or float(np.max(inside)) > SETTLED_MAX
        ):
            break
        settled_from = float(low)
    return min(max(settled_from, lowest, SETTLING_STEP), gate_angle)


def one_timeline(recordings: Sequence[Channels]) -> list[Channels]:
    """The channels of several recordings of one unit [s, SI] on one time line: each recording
    after the first is moved to start RECORDING_GAP after the one before it ended (the
    recordings' own clocks may overlap; the folds of :func:`out_of_fold_residuals` alternate
    along this line). Raises ConfigError for no recording or one without samples."""
    if not recordings:
        raise ConfigError("commission: no recording given")
    placed: list[Channels] = []
    end = -math.inf
    for k, channels in enumerate(recordings):
        stamps = [np.asarray(series[0], float) for series in channels.values()]
        if not stamps or any(len(t) == 0 for t in stamps):
            raise ConfigError(
                f"commission: recording {k + 1} has no channels, or a channel without samples"
            )
        first = min(float(t[0]) for t in stamps)
        offset = 0.0 if k == 0 else end + RECORDING_GAP - first
        placed.append(
            {name: (np.asarray(t, float) + offset, v) for name, (t, v) in channels.items()}
        )
        end = max(float(t[-1]) for t in stamps) + offset
    return placed


def commission(
    channels: Channels | Sequence[Channels],
    config: TwinConfig,
    settings: ResidualSettings | None = None,
    *,
    source: str = "",
    error_scale: float = ERROR_SCALE,
    unseen_error: float = UNSEEN_ERROR,
    unseen_quantile: float = UNSEEN_QUANTILE,
    temperature_error: float = TEMPERATURE_ERROR,
    shift_extrapolation: float = SHIFT_EXTRAPOLATION,
    band_reach: float = BAND_REACH,
    twin: UnitTwin | None = None,
) -> CommissioningResult:
    """Fit the baseline of the unit that made ``channels`` (see the module docstring): one
    recording's channels, or a sequence of several healthy recordings of the same unit (say a
    cold start and a warm run at the speeds it serves at), fitted together. Each recording is
    cut into blocks and gated on its own, so that nothing is compared across the seam.
    ``unseen_error`` [-] is the least 1-sigma relative error taken where the recording did not
    teach the twin (a speed band with too few blocks, the residual surface's thin nodes);
    there the unit's own ``unseen_quantile`` [-] of the parametric fit's |relative residual|
    is taken where it is larger. ``temperature_error`` [1/K] is the baseline's e_T, the
    relative error's growth per kelvin outside the temperatures commissioned at a speed, and
    ``shift_extrapolation`` [K] the scale of the fitted shift's term there
    (:meth:`.Baseline.extrapolation_error`), ``band_reach`` [decades] how far along the speed
    the temperatures commissioned at other speeds count (:meth:`.Baseline.reached_range`).

    Raises:
        ConfigError: too few comparable blocks (the recording stands still or reverses all
            the time), or no real-time map for ``config``.
    """
    settings = settings or ResidualSettings()
    given = {
        "error_scale": error_scale,
        "unseen_error": unseen_error,
        "unseen_quantile": unseen_quantile,
        "temperature_error": temperature_error,
        "shift_extrapolation": shift_extrapolation,
        "band_reach": band_reach,
    }
    for name, value in given.items():
        check_number(value, KEYWORD_LIMITS[name], f"commission: {name}", text=False)
    twin = twin or UnitTwin(config)
    every: list[Block] = []
    usable: list[Block] = []
    settling: list[tuple[Block, float]] = []  # gated only by the rotation since a reversal
    for recording in one_timeline([channels] if isinstance(channels, Mapping) else channels):
        gate = ReversalGate(settings)
        blocks = aligned_blocks(recording, settings)
        every.extend(blocks)
        for b in blocks:
            reason = gate.check(b)
            if len(b.torque) < 4 or "speed" in b.held:
                continue
            if not reason:
                usable.append(b)
            elif float(np.min(np.abs(b.speed))) >= settings.gate_speed:
                settling.append((b, gate.block_travel))
    if len(usable) < 20:
        raise ConfigError(
            f"commission{(' ' + source) if source else ''}: {len(usable)} of {len(every)} blocks "
            "are comparable (moving, past a reversal); at least 20 are needed: record a healthy "
            "run with motion at steady or slowly changing speed"
        )
    stride = max(len(usable) // FIT_BLOCKS, 1)
    fit_blocks = [
        FitBlock(
            b.time,
            float(np.mean(b.torque)),
            _pick(b.speed, FIT_SPEEDS),
            b.temperature,
            b.preload,
            b.mean_acceleration,
            len(b.torque),
        )
        for b in usable[::stride]
    ]
    measured = np.array([b.measured for b in fit_blocks])
    scale = np.abs(measured) + 1e-3 * float(np.max(np.abs(measured)))
    nominal_theta = np.array([1.0, 0.0, 0.0, 0.0, config.screw.screw_inertia, 0.0, 0.0, 0.0, 0.0])
    # theta's entries with a prior, and its one-sigma width
    prior_index = np.array([0, 2, 3, 5, 6, 7, 8])
    priors = np.array(
        [
            PRIOR_SIGMA["torque_gain"],
            PRIOR_SIGMA["preload_scale"],
            PRIOR_SIGMA["temperature_shift"],
            PRIOR_SIGMA["shape"],
            PRIOR_SIGMA["shape"],
            PRIOR_SIGMA["friction_scale"],
            PRIOR_SIGMA["friction_scale"],
        ]
    )
    # the friction scales are fitted only where the screw has a response table
    free = np.ones(len(nominal_theta), dtype=bool)
    free[7:] = twin.response is not None

    # The twin's misfit is systematic over a regime, not independent from block to block: the
    # priors weigh as PRIOR_SHARE of the blocks (a data set cannot argue a unit far outside its
    # production spread by repeating one regime's error).
    prior_weight = math.sqrt(PRIOR_SHARE * len(fit_blocks))
    # The fit runs on u, theta = nominal + step * u, so every unknown is of order one (the
    # finite-difference steps and the trust region are then alike for all of them).
    j0 = config.screw.screw_inertia
    step = np.array([0.02, 1e-3, 0.1, 2.0, 0.1 * j0, 0.02, 0.02, 0.1, 0.1])
    lower = np.array(
        [0.5, -0.05, math.log(0.3), -30.0, 0.2 * j0, -0.5, -0.5, math.log(0.4), math.log(0.4)]
    )
    upper = np.array(
        [1.5, 0.05, math.log(2.0), 30.0, 5.0 * j0, 0.5, 0.5, math.log(2.5), math.log(2.5)]
    )

    def full(u: FloatArray) -> FloatArray:
        theta = nominal_theta.copy()
        theta[free] += step[free] * u
        return theta

    def cost(u: FloatArray) -> FloatArray:
        theta = full(u)
        misfit = (measured - _predict(twin, theta, fit_blocks)) / scale / FIT_SIGMA
        deviation = (theta - nominal_theta)[prior_index]
        keep = free[prior_index]
        return np.concatenate([misfit, (deviation / priors * prior_weight)[keep]])

    fit = least_squares(
        cost,
        np.zeros(np.count_nonzero(free)),
        bounds=(
            ((lower - nominal_theta) / step)[free],
            ((upper - nominal_theta) / step)[free],
        ),
        diff_step=1e-4,
        loss="soft_l1",
        f_scale=ROBUST_SCALE,
        max_nfev=200,
    )
    theta = full(fit.x)
    jacobian = np.asarray(fit.jac) / step[free]  # of the fitted values
    dof = max(len(fit.fun) - len(fit.x), 1)
    residual_var = float(np.sum(fit.fun**2)) / dof
    sigma = np.zeros(len(theta))  # 0 for a value not fitted
    try:
        covariance = np.linalg.inv(jacobian.T @ jacobian) * residual_var
        sigma[free] = np.sqrt(np.clip(np.diag(covariance), 0.0, None))
    except np.linalg.LinAlgError:
        sigma[free] = math.nan

    # What the adjusted twin still misses, learnt as a surface over speed and temperature
    # (:mod:`.correction`); its error per speed band is measured out of fold (two folds of
    # alternating FOLD_CHUNK-long stretches), so that it is not the in-sample scatter.
    study = _surface_study(twin, theta, usable)
    out_of_fold = out_of_fold_residuals(study)
    surface = replace(
        robust_fit(study.design, study.residual, study.nearness, SURFACE_SCALE),
        support=validated_support(study),
    )
    # Where the surface was not learnt, the twin is as wrong as the parametric fit alone was
    # at its worst on this unit (training unit 9: 23 % at -10 C and 3 rad/s, a corner the
    # warm-up passed in seconds), at least unseen_error.
    unseen = max(float(np.quantile(np.abs(study.residual), unseen_quantile)), unseen_error)
    judged = np.isfinite(out_of_fold)
    if np.count_nonzero(judged) < BAND_BLOCKS:  # too short to cross-validate: in sample
        out_of_fold = study.residual - study.design @ np.ravel(surface.values)
        judged = np.ones(len(out_of_fold), dtype=bool)
    relative = np.abs(out_of_fold[judged])

    def band_error(inside: NDArray[np.bool_]) -> float:
        if np.count_nonzero(inside) < BAND_BLOCKS:  # a regime the recording hardly saw
            return max(error_scale * float(np.percentile(relative, 95)) / 1.96, unseen_error)
        return max(error_scale * float(np.percentile(relative[inside], 95)) / 1.96, ERROR_FLOOR)

    band = np.searchsorted(ERROR_BAND_EDGES, study.speeds[judged])
    bands = tuple(band_error(band == k) for k in range(len(ERROR_BAND_EDGES) + 1))
    error_relative = band_error(np.ones(len(relative), dtype=bool))
    predicted = _predict(twin, theta, fit_blocks, surface)
    angle = _settling_angle(twin, theta, surface, settling, bands, settings.gate_angle)
    quiet = [
        b for b in usable if abs(b.mean_acceleration) * theta[4] < 0.05 * np.mean(np.abs(b.torque))
    ]
    variances = [v for b in (quiet or usable) if (v := within_block_variance(b)) is not None]
    noise = math.sqrt(float(np.median(variances))) if variances else None
    mean_n = float(np.mean([b.samples for b in fit_blocks]))
    temperatures = [b.temperature for b in usable]
    # the temperatures seen in each speed band (a band never seen: the whole recording's)
    seen = np.array(temperatures)
    in_band = np.searchsorted(ERROR_BAND_EDGES, [abs(float(np.mean(b.speed))) for b in usable])
    band_ranges = [
        (float(np.min(seen[in_band == k])), float(np.max(seen[in_band == k])))
        if np.any(in_band == k)
        else (float(np.min(seen)), float(np.max(seen)))
        for k in range(len(ERROR_BAND_EDGES) + 1)
    ]
    # and in each fine speed bin, for the reach of the temperatures along the speed
    in_bin = np.array([speed_bin(float(np.mean(b.speed))) for b in usable])
    bin_ranges = [
        (float(np.min(seen[in_bin == k])), float(np.max(seen[in_bin == k])))
        if np.any(in_bin == k)
        else (math.inf, -math.inf)  # not seen: an empty range
        for k in range(SPEED_BIN_COUNT)
    ]
    baseline = Baseline(
        config=config.name,
        fingerprint=config_fingerprint(config),
        source=source,
        torque_gain=float(theta[0]),
        torque_bias=float(theta[1]),
        preload_scale=float(math.exp(theta[2])),
        temperature_shift=float(theta[3]),
        inertia=float(theta[4]),
        shape_slope=float(theta[5]),
        shape_curvature=float(theta[6]),
        dry_friction_scale=float(math.exp(theta[7])),
        eyring_scale=float(math.exp(theta[8])),
        sensor_noise=noise,
        error_relative=error_relative,
        error_bands=bands,
        error_absolute=(noise or 1e-4) / math.sqrt(mean_n),
        inertia_error=max(INERTIA_SIGMAS * float(sigma[4] / theta[4]), INERTIA_ERROR_FLOOR)
        if math.isfinite(sigma[4])
        else Baseline.inertia_error,
        temperature_error=temperature_error,
        shift_extrapolation=shift_extrapolation,
        band_reach=band_reach,
        temperature_min=float(min(temperatures)),
        temperature_max=float(max(temperatures)),
        band_temperature_min=tuple(low for low, _ in band_ranges),
        band_temperature_max=tuple(high for _, high in band_ranges),
        bin_temperature_min=tuple(low for low, _ in bin_ranges),
        bin_temperature_max=tuple(high for _, high in bin_ranges),
        fit_rms=float(np.sqrt(np.mean(((measured - predicted) / scale) ** 2))),
        blocks=len(fit_blocks),
        surface=surface,
        settling_angle=angle,
        unseen_error=unseen,
    )
    on_bound = free & ((theta - lower <= 1e-6 * step) | (upper - theta <= 1e-6 * step))
    uncertainty = {
        "torque_gain": float(sigma[0]),
        "torque_bias": float(sigma[1]),
        "preload_scale": float(sigma[2] * math.exp(theta[2])),
        "temperature_shift": float(sigma[3]),
        "inertia": float(sigma[4]),
        "shape_slope": float(sigma[5]),
        "shape_curvature": float(sigma[6]),
        "dry_friction_scale": float(sigma[7] * math.exp(theta[7])),
        "eyring_scale": float(sigma[8] * math.exp(theta[8])),
    }
    return CommissioningResult(
        baseline=baseline,
        uncertainty=uncertainty,
        blocks=fit_blocks,
        nominal=_predict(twin, nominal_theta, fit_blocks),
        fitted=predicted,
        gated_share=1.0 - len(usable) / max(len(every), 1),
        # the names of uncertainty, in the order of theta
        at_bounds=tuple(name for name, hit in zip(uncertainty, on_bound, strict=True) if hit),
    )
