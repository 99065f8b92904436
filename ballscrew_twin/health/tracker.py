"""Kalman filter of slowly drifting quantities between the twin and the bench.

State x = (b, s, dF, dTh):
    b   torque-sensor bias [N m],
    s   friction scale factor minus one [-] (all friction mechanisms scaled by 1 + s),
    dF  change of the effective preload from the measured one [N],
    dTh offset of the unit's effective temperature from the thermometer's reading [K] (a
        thermometer that drifts, or a nut whose lubricant runs warmer or colder than the point
        measured; tracked only with ``temperature_prior`` or ``temperature_drift`` > 0).
Measurement (one torque block mean z [N m] at a predicted torque T and the twin's preload and
temperature sensitivities dT/dF and dT/dTh at the measured operating point):

    z = b + (1 + s) T + (dT/dF) dF + (dT/dTh) dTh + v,   so   z - T = H x + v,
    H = [1, T, dT/dF, dT/dTh],

v of variance R = sigma_s^2 / n + sigma_m^2 (sensor noise of the block mean plus the twin's
error there). The twin's error is not white: it is a function of the operating point and stays
the same block after block while the operating point does. So the state is updated as if the
twin's error were shared by N blocks (``update_variance`` of :meth:`DriftTracker.step`, R_update
= sigma_s^2 / n + N sigma_m^2; the monitor's ``drift_error_time`` sets N): a run of blocks where
the twin is off by its own error teaches the state what one block would, and the state does not
carry that error to other operating points (training unit 9: 36 s at 3 rad/s, -5 C, where the
twin is 2.9 mN m (17 %) below the unit, made s = +0.04, which at 128 rad/s predicted 1.8 mN m
that were not there, 3.5 innovation sigmas, a false alarm). The innovation's variance S uses R
itself.

Each state is a random walk whose spectral density is set from the drift rate it must follow
(``*_drift`` [unit / sqrt(s)]): drift that slow is absorbed into the state and leaves white
innovations; a sudden fault is much faster than the walk and shows in the innovations ``nu = z -
T - H x-`` with variance ``S = H P- H' + R`` until the filter catches up (time constant of hours
with the defaults). The filter can be frozen (after an alarm) so that it does not learn a fault
as normal. The states are told apart only when the operating point moves (T, dT/dF and dT/dTh
change in different proportions: the temperature's share of the drag is the lubricant's, large
at speed and nil near standstill, where the scale still acts); at one constant operating point
only their sum is observed. A temperature offset and a loss of viscosity change the drag alike;
the offset's walk is slow (0.05 K in 5 s with the default 0.02 K/sqrt(s), where a 20 % loss
moves the drag as 4-5 K do), so a sudden loss still shows in the innovations.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from filterpy.kalman import KalmanFilter

from ..errors import ConfigError
from ..params import not_negative, positive, validate_fields
from .residuals import FloatArray

STATE_NAMES: tuple[str, ...] = ("bias", "friction_scale", "preload_change", "temperature_offset")
STATE_UNITS: tuple[str, ...] = ("N m", "-", "N", "K")


@dataclass(frozen=True, kw_only=True)
class TrackerSettings:
    """Prior uncertainty and drift rates of the tracked quantities (1 sigma).

    Attributes:
        bias_prior: initial uncertainty of the sensor bias [N m].
        scale_prior: initial uncertainty of the friction scale factor [-] (the model error).
        preload_prior: initial uncertainty of the effective preload change [N].
        bias_drift: random-walk density of the bias [N m / sqrt(s)].
        scale_drift: random-walk density of the scale factor [1 / sqrt(s)].
        preload_drift: random-walk density of the preload change [N / sqrt(s)].
        temperature_prior: initial uncertainty of the temperature offset [K] (0, the
            default: the commissioning has fitted the unit's temperature shift; a prior adds
            to the innovations' variance at the start of every run, docs/model.md section 15).
        temperature_drift: random-walk density of the temperature offset [K / sqrt(s)] (0
            with ``temperature_prior`` 0: not tracked).
    """

    bias_prior: float = field(default=2.0e-3, metadata=positive("N m"))
    scale_prior: float = field(default=0.05, metadata=positive("-"))
    preload_prior: float = field(default=20.0, metadata=positive("N"))
    bias_drift: float = field(default=2.0e-6, metadata=positive("N m/sqrt(s)"))
    scale_drift: float = field(default=2.0e-4, metadata=positive("1/sqrt(s)"))
    preload_drift: float = field(default=0.05, metadata=positive("N/sqrt(s)"))
    temperature_prior: float = field(default=0.0, metadata=not_negative("K"))
    temperature_drift: float = field(default=0.02, metadata=not_negative("K/sqrt(s)"))

    @property
    def priors(self) -> tuple[float, ...]:
        """Initial 1-sigma of each state of STATE_NAMES, in its unit (STATE_UNITS)."""
        return (self.bias_prior, self.scale_prior, self.preload_prior, self.temperature_prior)

    @property
    def drifts(self) -> tuple[float, ...]:
        """Random-walk density of each state of STATE_NAMES [its unit / sqrt(s)]."""
        return (self.bias_drift, self.scale_drift, self.preload_drift, self.temperature_drift)

    @property
    def tracked(self) -> tuple[bool, ...]:
        """Whether each state of STATE_NAMES is tracked (a prior or a walk > 0)."""
        return tuple(p > 0.0 or d > 0.0 for p, d in zip(self.priors, self.drifts, strict=True))

    @property
    def tracks_temperature(self) -> bool:
        """Whether the temperature offset is a tracked state."""
        return self.tracked[STATE_NAMES.index("temperature_offset")]

    def __post_init__(self) -> None:
        """All values finite and > 0 (the temperature offset's >= 0), through the package's
        one number check (:func:`~ballscrew_twin.params.validate_fields`)."""
        validate_fields(self, "tracker settings", ": ")


@dataclass(frozen=True)
class Innovation:
    """One filter step.

    Attributes:
        innovation: nu, measured minus predicted by the twin and the tracked state [N m].
        variance: S, its predicted variance [N m^2].
        state: posterior state (b [N m], s [-], dF [N], dTh [K]) after the step (prior when
            frozen).
    """

    innovation: float
    variance: float
    state: FloatArray

    @property
    def normalized(self) -> float:
        """nu / sqrt(S) [-], standard normal while the model holds."""
        return self.innovation / math.sqrt(self.variance)


class DriftTracker:
    """Linear Kalman filter (filterpy) of bias, friction scale, effective preload change and
    temperature offset."""

    def __init__(self, settings: TrackerSettings) -> None:
        self.settings = settings
        self.kf = KalmanFilter(dim_x=len(STATE_NAMES), dim_z=1)
        self.kf.x = np.zeros((len(STATE_NAMES), 1))
        self.kf.P = np.diag(settings.priors) ** 2
        self.kf.F = np.eye(len(STATE_NAMES))
        self._density = np.array(settings.drifts) ** 2
        #: While True the state is not updated (predictions and innovations still computed).
        self.frozen = False

    @property
    def state(self) -> FloatArray:
        """Current state (b [N m], s [-], dF [N], dTh [K])."""
        return np.asarray(self.kf.x[:, 0], dtype=float).copy()

    @property
    def std(self) -> FloatArray:
        """Current 1-sigma uncertainty of each state, same units as :attr:`state`."""
        return np.sqrt(np.diag(self.kf.P))

    def step(
        self,
        measured: float,
        predicted: float,
        preload_sensitivity: float,
        noise_variance: float,
        dt: float,
        update_variance: float | None = None,
        temperature_sensitivity: float = 0.0,
    ) -> Innovation:
        """Advance by ``dt`` [s] and take one measurement.

        Args:
            measured: block mean torque z [N m].
            predicted: twin torque T at the measured operating point [N m].
            preload_sensitivity: dT/dF there [N m / N].
            noise_variance: R [N m^2], of the innovation.
            dt: time since the previous step [s] (> 0).
            update_variance: R of the state update [N m^2] (>= ``noise_variance``; default
                ``noise_variance``): larger where the block's error is shared with its
                neighbours (see the module docstring).
            temperature_sensitivity: dT/dTh there [N m / K].
        """
        if not (math.isfinite(dt) and dt > 0.0):
            raise ConfigError(f"tracker step: dt = {dt!r} s must be finite and > 0")
        if not (math.isfinite(noise_variance) and noise_variance > 0.0):
            raise ConfigError(f"tracker step: R = {noise_variance!r} N m^2 must be > 0")
        if update_variance is None:
            update_variance = noise_variance
        if not (math.isfinite(update_variance) and update_variance >= noise_variance):
            raise ConfigError(
                f"tracker step: update R = {update_variance!r} N m^2 must be >= R = "
                f"{noise_variance!r} N m^2"
            )
        self.kf.Q = np.diag(self._density * dt)
        self.kf.predict()
        h = self.observation(predicted, preload_sensitivity, temperature_sensitivity)[None, :]
        self.kf.H = h
        self.kf.R = np.array([[update_variance]])
        innovation = float(measured - predicted - (h @ self.kf.x)[0, 0])
        variance = float((h @ self.kf.P @ h.T)[0, 0] + noise_variance)
        if not self.frozen:
            self.kf.update(np.array([[measured - predicted]]))
        return Innovation(innovation, variance, self.state)

    @staticmethod
    def observation(
        predicted: float, preload_sensitivity: float, temperature_sensitivity: float = 0.0
    ) -> FloatArray:
        """H, the torque [N m] per unit of each state at a predicted torque T [N m] and the
        sensitivities dT/dF [N m / N] and dT/dTh [N m / K]."""
        return np.array([1.0, predicted, preload_sensitivity, temperature_sensitivity])

    def expected(
        self,
        predicted: float,
        preload_sensitivity: float,
        state: FloatArray,
        temperature_sensitivity: float = 0.0,
    ) -> float:
        """Torque the twin plus a tracked ``state`` expect [N m]."""
        h = self.observation(predicted, preload_sensitivity, temperature_sensitivity)
        return float(predicted + h @ state)
