"""Channels of a synthetic bench recording for the monitor tests: what the bench bags carry."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

#: The synthetic recordings' constant temperature [K] and preload [N].
TEMPERATURE = 293.15
PRELOAD = 1500.0


def bench_channels(
    t: NDArray[np.float64],
    torque: NDArray[np.float64],
    speed: NDArray[np.float64],
    temperature: float = TEMPERATURE,
) -> dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """Torque at the instants ``t`` [s] (1 kHz in the tests) [N m]; speed [rad/s] at every 10th
    instant, preload at every 50th and ``temperature`` [K] at every 100th, constant."""
    ts = t[::10]
    return {
        "torque": (t, torque),
        "speed": (ts, speed[::10]),
        "temperature": (ts[::10], np.full(len(ts[::10]), temperature)),
        "preload": (ts[::5], np.full(len(ts[::5]), PRELOAD)),
    }
