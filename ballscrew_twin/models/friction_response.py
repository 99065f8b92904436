"""How the drag torque answers a unit's own friction parameters: a table of the steady model.

Two parameters of the friction law spread from unit to unit and are not in the real-time map:
the dry friction coefficient mu_dry (Eq. 36; run-in of the grooves) and the Eyring stress
tau_0 (Eq. 35; the lubricant's additive package). Their effect is not a scale of one
mechanism: mu_dry also sets the hysteresis moment through mu_s / mu_dry (Eq. 43) and so
lowers the torque at speed where no dry contact is left, and tau_0 scales every lubricant
traction (shear, spin, curvature) and through mu_s the hysteresis. So the steady model itself
is solved with each parameter scaled by 1 / R and R (R = :data:`SCALE_STEP`) at every node,
and the logarithm of the torque is taken quadratic in x_p = ln k_p about the nominal set:

    ln T(w, T, F; k) = ln T(w, T, F; 1) + sum_p (a_p x_p + b_p x_p^2),
    a_p = (L_p+ - L_p-) / (2 h),  b_p = (L_p+ + L_p- - 2 L_0) / (2 h^2),  h = ln R,

L the logarithm of the solved torque. The two are taken to act independently: on the paper
screw, at 7 points over 0.5-300 rad/s, -10..40 C, 600-2500 N and 4 pairs of scales of +-20-30 %
both at once, ln T of the pair minus the sum of the two alone is within 0.018, and this table
is within 0.021 of ln T of solves of the scaled screw (docs/model.md section 16). Between
the nodes a_p and b_p are linear in ln |w|, T and ln F (:class:`FrictionResponse`), clamped at
the grid's edges; the torque is odd in the speed, so one sign is tabulated.

``ballscrew-twin map response`` builds it; the table of the shipped paper screw is package
data, any other screw's goes to the user cache under its fingerprint. All SI: rad/s, K, N.
"""

from __future__ import annotations

import itertools
import math
import multiprocessing
import signal
import time
from collections.abc import Iterable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..errors import MapError, SolverError
from ..params import TwinConfig, config_fingerprint
from .base import OperatingPoint
from .map_build import Progress, fill_failed
from .map_store import cache_dir, save_atomic
from .steady import SteadyStateModel

FloatArray = NDArray[np.float64]

#: The parameters, in the order of the table's axis 3 (names of :class:`TwinConfig` fields).
PARAMETERS = ("dry_friction_coefficient", "eyring_stress")
#: Ratio R of the scaled solves [-] (the production spread of both is +- 30 %).
SCALE_STEP = 1.3
#: Nodes: |speed| uniform in log [rad/s], temperature [K], preload uniform in log [N].
SPEED_RANGE = (0.01, 600.0)
SPEED_NODES = 12
TEMPERATURE_RANGE = (233.15, 373.15)
TEMPERATURE_NODES = 11
PRELOAD_RANGE = (150.0, 4050.0)
PRELOAD_NODES = 4
#: A node whose response is steeper than SLOPE_MAX (|a_p|) or bends more than CURVATURE_MAX
#: over one step (|b_p| h^2) is taken from its nearest regular speed node [-]: there the scaled
#: solves ended on other branches of the steady model (cold, fast and light: at -40 C, 600
#: rad/s and 150 N the paper screw gave a = 8.9, b = -22; docs/model.md section 16).
SLOPE_MAX = 2.0
CURVATURE_MAX = 0.05
#: Format version of the saved file.
FORMAT_VERSION = 1
#: The table of the shipped parameter set (package data).
DEFAULT_RESPONSE_PATH = Path(__file__).resolve().parent.parent / "data" / "friction_response.npz"

_WORKER: dict[str, TwinConfig] = {}


def scaled_config(config: TwinConfig, scales: tuple[float, float]) -> TwinConfig:
    """``config`` with mu_dry and tau_0 times ``scales`` [-] (:data:`PARAMETERS` order)."""
    return replace(
        config,
        contact=replace(
            config.contact,
            dry_friction_coefficient=config.contact.dry_friction_coefficient * scales[0],
        ),
        lubricant=replace(
            config.lubricant, eyring_stress=config.lubricant.eyring_stress * scales[1]
        ),
    )


def _variants() -> list[tuple[float, float]]:
    """The parameter scales solved at each node: nominal, then each parameter at 1/R and R."""
    out = [(1.0, 1.0)]
    for p in range(len(PARAMETERS)):
        for k in (1.0 / SCALE_STEP, SCALE_STEP):
            out.append((k, 1.0) if p == 0 else (1.0, k))
    return out


@dataclass(frozen=True)
class FrictionResponse:
    """The response table (see the module docstring).

    Attributes:
        speeds: |speed| nodes [rad/s]; temperatures: [K]; preloads: [N].
        coefficients: (S, T, P, 2 parameters, 2) a_p and b_p [-].
        filled: (S, T, P) nodes where a solve failed or the response was irregular (filled
            from the nearest regular speed node).
        fingerprint: :func:`config_fingerprint` of the parameter set it was built for.
    """

    speeds: FloatArray
    temperatures: FloatArray
    preloads: FloatArray
    coefficients: FloatArray
    filled: NDArray[np.bool_]
    fingerprint: str

    def __post_init__(self) -> None:
        shape = (len(self.speeds), len(self.temperatures), len(self.preloads), len(PARAMETERS), 2)
        if self.coefficients.shape != shape or not np.isfinite(self.coefficients).all():
            raise MapError(
                f"friction response: coefficients of shape {self.coefficients.shape} (need "
                f"{shape}) or not finite"
            )

    def log_factor(
        self, speeds: FloatArray, temperature: float, preload: float, log_scales: FloatArray
    ) -> FloatArray:
        """sum_p (a_p x_p + b_p x_p^2) [-] at each of ``speeds`` [rad/s], one ``temperature``
        [K] and contact ``preload`` [N], x = ``log_scales`` = ln k_p (:data:`PARAMETERS`)."""
        x = np.asarray(log_scales, dtype=np.float64)
        # Bilinear in temperature and ln preload first: one line of speed nodes.
        line = np.zeros(len(self.speeds))
        around_t = _linear(self.temperatures, temperature)
        around_f = _linear(np.log(self.preloads), math.log(max(preload, 1e-9)))
        for (t, wt), (p, wp) in itertools.product(around_t, around_f):
            c = self.coefficients[:, t, p]  # (S, 2, 2)
            line += wt * wp * (c[:, :, 0] @ x + c[:, :, 1] @ (x * x))
        query = np.log(np.maximum(np.abs(np.asarray(speeds, dtype=np.float64)), 1e-12))
        return np.asarray(np.interp(query, np.log(self.speeds), line))

    def save(self, path: str | Path) -> None:
        """Write the table as a compressed ``.npz`` file."""
        np.savez_compressed(
            Path(path),
            format_version=np.array(FORMAT_VERSION),
            speeds=self.speeds,
            temperatures=self.temperatures,
            preloads=self.preloads,
            coefficients=self.coefficients,
            filled=self.filled,
            fingerprint=np.array(self.fingerprint),
            parameters=np.array(PARAMETERS),
        )


def _linear(nodes: FloatArray, value: float) -> list[tuple[int, float]]:
    """The two nodes around ``value`` and their linear weights (clamped to the ends)."""
    v = min(max(value, float(nodes[0])), float(nodes[-1]))
    i = min(int(np.searchsorted(nodes, v, side="right")) - 1, len(nodes) - 2)
    frac = (v - float(nodes[i])) / float(nodes[i + 1] - nodes[i])
    return [(i, 1.0 - frac), (i + 1, frac)]


def load_response(path: str | Path) -> FrictionResponse:
    """Read a table written by :meth:`FrictionResponse.save`.

    Raises:
        MapError: missing, unreadable, of another format or for other parameters.
    """
    try:
        with np.load(Path(path), allow_pickle=False) as data:
            version = int(data["format_version"])
            if version != FORMAT_VERSION or tuple(data["parameters"]) != PARAMETERS:
                raise MapError(
                    f"friction response {path}: format {version} or parameters "
                    f"{tuple(data['parameters'])} (need {FORMAT_VERSION}, {PARAMETERS})"
                )
            return FrictionResponse(
                speeds=np.asarray(data["speeds"], dtype=np.float64),
                temperatures=np.asarray(data["temperatures"], dtype=np.float64),
                preloads=np.asarray(data["preloads"], dtype=np.float64),
                coefficients=np.asarray(data["coefficients"], dtype=np.float64),
                filled=np.asarray(data["filled"], dtype=bool),
                fingerprint=str(data["fingerprint"]),
            )
    except (OSError, KeyError, ValueError) as exc:
        raise MapError(f"friction response {path}: cannot be read ({exc})") from exc


def cached_response_path(config: TwinConfig) -> Path:
    """Where the user cache keeps the response table of ``config``."""
    return cache_dir() / f"friction_response_{config_fingerprint(config)[:16]}.npz"


def find_response(config: TwinConfig) -> FrictionResponse | None:
    """The response table built for ``config`` (package data, else the user cache), or None
    when there is none: a file built for other parameters or unreadable is passed over (an
    unreadable cached one is then built again by :func:`ensure_response`)."""
    fingerprint = config_fingerprint(config)
    for path in (DEFAULT_RESPONSE_PATH, cached_response_path(config)):
        if path.is_file():
            try:
                table = load_response(path)
            except MapError:
                continue
            if table.fingerprint == fingerprint:
                return table
    return None


def ensure_response(config: TwinConfig, workers: int = 2) -> tuple[FrictionResponse, Path | None]:
    """The response table of ``config``, built into the user cache when there is none (a few
    seconds: 2640 steady solves); the path it was written to, or None when it was found."""
    found = find_response(config)
    if found is not None:
        return found, None
    path = cached_response_path(config)
    table = build_response(config, workers=workers)
    save_atomic(table, path)
    return table, path


def _worker_init(config: TwinConfig) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _WORKER["config"] = config


def _solve_line(task: tuple[int, int, int]) -> tuple[tuple[int, int, int], FloatArray]:
    """|T| [N m] along the speed nodes of one (variant, temperature node, preload node),
    warm-started upwards; NaN where the solve fails."""
    variant, t, p = task
    speeds, temperatures, preloads = _nodes()
    config = _WORKER["config"]
    model = SteadyStateModel(scaled_config(config, _variants()[variant]), mode="symmetric")
    out = np.full(len(speeds), np.nan)
    for i, speed in enumerate(speeds):
        op = OperatingPoint(
            screw_speed=float(speed),
            temperature=float(temperatures[t]),
            preload=float(preloads[p]),
        )
        try:
            out[i] = abs(float(model.evaluate(op).drag_torque))
        except SolverError:
            model.forget_warm_start()
    return task, out


def _nodes() -> tuple[FloatArray, FloatArray, FloatArray]:
    """The nodes: |speed| [rad/s], temperature [K], preload [N] (module constants)."""
    low_w, high_w = (math.log(w) for w in SPEED_RANGE)
    low_f, high_f = (math.log(f) for f in PRELOAD_RANGE)
    return (
        np.exp(np.linspace(low_w, high_w, SPEED_NODES)),
        np.linspace(TEMPERATURE_RANGE[0], TEMPERATURE_RANGE[1], TEMPERATURE_NODES),
        np.exp(np.linspace(low_f, high_f, PRELOAD_NODES)),
    )


def build_response(
    config: TwinConfig, workers: int = 2, on_progress: Progress | None = None
) -> FrictionResponse:
    """Solve every node of every variant (:func:`_variants`) with the symmetric steady model
    (see the module docstring); ``on_progress`` (lines done, lines in all, seconds elapsed)
    after each line of speeds."""
    speeds, temperatures, preloads = _nodes()
    variants = _variants()
    tasks = list(
        itertools.product(range(len(variants)), range(len(temperatures)), range(len(preloads)))
    )
    logs = np.full((len(variants), len(speeds), len(temperatures), len(preloads)), np.nan)
    start = time.monotonic()

    def store(results: Iterable[tuple[tuple[int, int, int], FloatArray]]) -> None:
        for done, ((v, t, p), torques) in enumerate(results, start=1):
            with np.errstate(divide="ignore", invalid="ignore"):
                logs[v, :, t, p] = np.where(torques > 0.0, np.log(torques), np.nan)
            if on_progress is not None:
                on_progress(done, len(tasks), time.monotonic() - start)

    if workers <= 1:
        _WORKER["config"] = config
        store(_solve_line(task) for task in tasks)
    else:
        context = multiprocessing.get_context("spawn")
        with context.Pool(workers, initializer=_worker_init, initargs=(config,)) as pool:
            store(pool.imap_unordered(_solve_line, tasks))
    h = math.log(SCALE_STEP)
    coefficients = np.empty((*logs.shape[1:], len(PARAMETERS), 2))
    for p in range(len(PARAMETERS)):
        low, high = logs[1 + 2 * p], logs[2 + 2 * p]
        coefficients[..., p, 0] = (high - low) / (2.0 * h)
        coefficients[..., p, 1] = (high + low - 2.0 * logs[0]) / (2.0 * h * h)
    with np.errstate(invalid="ignore"):
        irregular = (np.abs(coefficients[..., 0]) > SLOPE_MAX) | (
            np.abs(coefficients[..., 1]) * h * h > CURVATURE_MAX
        )
    filled = np.any(~np.isfinite(coefficients), axis=(-2, -1)) | np.any(irregular, axis=-1)
    _fill_along_speed(coefficients, filled)
    return FrictionResponse(
        speeds, temperatures, preloads, coefficients, filled, config_fingerprint(config)
    )


def _fill_along_speed(table: FloatArray, failed: NDArray[np.bool_]) -> None:
    """Replace the ``failed`` (S, T, P) nodes of (S, T, P, ...) ``table`` by the nearest good
    speed node of their line (ties go down), in place: the steady map's
    :func:`~.map_build.fill_failed` on one sign.

    Raises:
        MapError: a whole line failed (the map would take a neighbouring preload's line; the
            response of a screw that fails so is not trusted)."""
    whole = np.argwhere(failed.all(axis=0))
    if len(whole):
        t, p = (int(k) for k in whole[0])
        raise MapError(f"friction response: every speed failed at node ({t}, {p})")
    fill_failed(table[None], failed[None])
