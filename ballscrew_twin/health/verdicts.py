"""What the health monitor says of each block (:class:`HealthSample`, with its verdict) and
of a run's first alarm (:class:`Alarm`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..models.base import OperatingPoint
from .classify import Classification

OK, WARN, FAULT, UNKNOWN = 0, 1, 2, 3
VERDICT_NAMES = {OK: "OK", WARN: "WARN", FAULT: "FAULT", UNKNOWN: "UNKNOWN"}


@dataclass(frozen=True)
class HealthSample:
    """Result of one block (what the node publishes as a HealthResidual).

    Attributes:
        time: block mid time [s] (the stamps' clock).
        measured: block mean torque [N m].
        predicted: twin torque at the block's operating point [N m] (nan if none).
        residual: measured - predicted [N m].
        normalized_residual: residual / sqrt(sigma_s^2 / n + sigma_m^2) [-].
        innovation: normalised Kalman innovation [-] (nan before the filter runs).
        statistics: detector -> (statistic, threshold) [-].
        test_statistic: statistic of the detector closest to its threshold [-].
        threshold: that detector's threshold [-].
        verdict: OK, WARN, FAULT or UNKNOWN.
        fault_class: likely class (FAULT only), else "".
        confidence: 0..1, see :meth:`HealthMonitor._verdict`.
        operating_point: measured operating point of the block, None if none.
        state: tracked (bias [N m], friction scale [-], preload change [N], temperature
            offset [K]).
        note: why the verdict is UNKNOWN, or which detector alarmed.
        span: time the block's compared samples stand for [s] (less than the block duration
            for a block compared on its stroke past the gate; nan when not given).
    """

    time: float
    measured: float
    predicted: float
    residual: float
    normalized_residual: float
    innovation: float
    statistics: dict[str, tuple[float, float]]
    test_statistic: float
    threshold: float
    verdict: int
    fault_class: str
    confidence: float
    operating_point: OperatingPoint | None
    state: tuple[float, float, float, float]
    note: str = ""
    span: float = math.nan


@dataclass
class Alarm:
    """The first alarm of a run.

    Attributes:
        time: time of the alarm: stamp of the last sample of the block that raised it [s].
        detector: which detector fired.
        onset: estimated change time [s].
        classification: the class and its confidence (refined until ``final``).
        final: whether the classification window has passed.
    """

    time: float
    detector: str
    onset: float
    classification: Classification
    final: bool = False
