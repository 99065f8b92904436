"""Commissioning recovers a unit's parameters from data made with known ones, and says when it
cannot fit."""

from __future__ import annotations

import contextlib
import inspect
import io
import math
from dataclasses import replace
from pathlib import Path
from typing import cast

import numpy as np
import pytest

from ballscrew_twin.cli import main
from ballscrew_twin.errors import ConfigError
from ballscrew_twin.health.baseline import (
    BAND_REACH,
    ERROR_BAND_EDGES,
    SHIFT_EXTRAPOLATION,
    Baseline,
    load_baseline,
    speed_bin,
)
from ballscrew_twin.health.bench_data import SAMPLE_DIR
from ballscrew_twin.health.commission import (
    FIT_BLOCKS,
    FOLD_CHUNK,
    KEYWORD_LIMITS,
    RECORDING_GAP,
    TEMPERATURE_ERROR,
    UNSEEN_ERROR,
    CommissioningResult,
    CommissionKeywords,
    SurfaceStudy,
    _settling_angle,
    commission,
    one_timeline,
    validated_support,
)
from ballscrew_twin.health.correction import (
    LOG_SPEED_NODES,
    MIN_SUPPORT,
    TEMPERATURE_NODES,
    ResidualSurface,
    basis,
    nearest_nodes,
)
from ballscrew_twin.health.residuals import Block, UnitTwin
from ballscrew_twin.params import load_config

# The gain is 1 here: at one temperature a gain trades against the preload scale, and the
# maximum a posteriori fit pulls that direction to its prior (gain 1 +- 2 %); what the data
# pin down (preload scale, temperature shift, bias, inertia, shape) is checked against truth.
TRUTH = {
    "torque_gain": 1.0,
    "torque_bias": 3e-4,
    "preload_scale": 0.9,
    "temperature_shift": 2.0,
    "inertia": 1.2e-5,
    "shape_slope": 0.04,
    "shape_curvature": -0.02,
}


def _recording(
    seed: int,
    truth_values: dict[str, float] | None = None,
    temperatures: tuple[float, float] = (15.0, 30.0),
    levels: tuple[float, ...] = (5.0, 20.0, 60.0, 150.0, 300.0, 40.0, 10.0),
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Holds and ramps at ``levels`` [rad/s] both ways, two set preloads, a ramp through
    ``temperatures`` [C], made with the map and ``truth_values`` (default TRUTH; torque at
    500 Hz, speed 100 Hz)."""
    values = {"dry_friction_scale": 1.0, "eyring_scale": 1.0, **(truth_values or TRUTH)}
    config = load_config(None)
    rng = np.random.default_rng(seed)
    fine = np.arange(0.0, 280.0, 1e-3)
    holds = np.array([v * s for s in (1.0, -1.0) for v in levels])
    speed = np.repeat(holds, math.ceil(len(fine) / len(holds)))[: len(fine)]
    kernel = np.full(300, 1.0 / 300)  # 0.3 s ramps between levels
    speed = np.convolve(np.pad(speed, (150, 149), "edge"), kernel, "valid")
    start, end = temperatures
    temperature = 273.15 + start + (end - start) * fine / fine[-1]
    preload = np.where(fine < 140.0, 1000.0, 2000.0)
    truth = Baseline(
        config="",
        fingerprint="",
        inertia=values["inertia"],
        shape_slope=values["shape_slope"],
        shape_curvature=values["shape_curvature"],
    )
    twin = UnitTwin(
        config,
        values["preload_scale"],
        values["temperature_shift"],
        (values["dry_friction_scale"], values["eyring_scale"]),
    )
    t_torque = fine[::2]
    w = np.interp(t_torque, fine, speed)
    drag = np.empty_like(t_torque)
    for k in range(0, len(t_torque), 500):  # one temperature and preload per second
        part = slice(k, k + 500)
        drag[part] = twin.drag(w[part], float(temperature[2 * k]), float(preload[2 * k]))
    accel = np.interp(t_torque, fine, np.gradient(speed, fine))
    torque = values["torque_gain"] * (drag * truth.shape(w) + values["inertia"] * accel)
    torque = torque + values["torque_bias"] + rng.normal(0.0, 1e-4, len(t_torque))
    t_speed = fine[::10]
    return {
        "torque": (t_torque, torque),
        "speed": (t_speed, np.interp(t_speed, fine, speed) + rng.normal(0.0, 0.005, len(t_speed))),
        "temperature": (fine[::100], temperature[::100]),
        "preload": (fine[::50], preload[::50]),
    }


@pytest.fixture(scope="module")
def fitted_result() -> CommissioningResult:
    return commission(_recording(1), load_config(None), source="synthetic")


@pytest.fixture(scope="module")
def fitted(fitted_result: CommissioningResult) -> Baseline:
    return fitted_result.baseline


def test_commissioning_recovers_the_unit(fitted: Baseline) -> None:
    assert fitted.torque_gain == pytest.approx(TRUTH["torque_gain"], abs=0.01)
    assert fitted.preload_scale == pytest.approx(TRUTH["preload_scale"], rel=0.03)
    assert fitted.temperature_shift == pytest.approx(TRUTH["temperature_shift"], abs=1.0)
    assert fitted.torque_bias == pytest.approx(TRUTH["torque_bias"], abs=1e-4)
    assert fitted.inertia == pytest.approx(TRUTH["inertia"], rel=0.1)
    assert fitted.shape_slope == pytest.approx(TRUTH["shape_slope"], abs=0.01)
    # the recording's own noise: 1e-4 N m per sample
    assert fitted.sensor_noise == pytest.approx(1e-4, rel=0.2)
    # a data set the model explains leaves an error at the floor of the map itself
    assert fitted.error_relative == pytest.approx(0.007, abs=1e-3)


def test_commissioning_fits_the_friction_scales() -> None:
    # a unit with its own mu_dry and tau_0 (the production spread is +- 30 %), no shape
    # correction, through -20..40 C and 0.5..300 rad/s
    truth = {**TRUTH, "shape_slope": 0.0, "shape_curvature": 0.0}
    truth.update(dry_friction_scale=0.8, eyring_scale=1.25)
    recording = _recording(2, truth, (-20.0, 40.0), (0.5, 2.0, 5.0, 20.0, 60.0, 150.0, 300.0))
    config = load_config(None)
    fitted = commission(recording, config, source="synthetic").baseline
    # Each goes the unit's way. Not to its value: a higher tau_0 and a lower preload scale
    # raise the torque nearly alike, and the priors (maximum a posteriori) take the nearer
    # pair, here 0.96 / 1.10 for 0.90 / 1.25, with mu_dry 0.70; what counts is the torque.
    assert fitted.dry_friction_scale < 0.9
    assert fitted.eyring_scale > 1.05
    # a twin without the response table fits the same recording several times worse
    blind = UnitTwin(config)
    blind.response = None
    without = commission(recording, config, source="synthetic", twin=blind).baseline
    assert (without.dry_friction_scale, without.eyring_scale) == (1.0, 1.0)
    assert without.fit_rms > 2.5 * fitted.fit_rms


def test_a_fit_that_ends_on_a_bound_says_which_value(fitted_result: CommissioningResult) -> None:
    # a torque sensor reading 20 % of the torque: the gain's bound is 0.5 (at 40 % the fit
    # stays inside its bounds since it has the friction scales: preload scale 0.39, +14 K)
    recording = _recording(1)
    stamps, torque = recording["torque"]
    recording["torque"] = (stamps, 0.2 * torque)
    result = commission(recording, load_config(None), source="synthetic")
    assert "torque_gain" in result.at_bounds
    assert result.baseline.torque_gain == pytest.approx(0.5)
    # the recording the fit explains ends inside every bound
    assert fitted_result.at_bounds == ()


def test_each_speed_band_keeps_the_temperatures_it_was_commissioned_at(
    fitted: Baseline,
) -> None:
    # The recording warms linearly from 15 to 30 C over 280 s and holds 60 and 40 rad/s
    # (band 30-100 rad/s) at 40-60, 100-120, 180-200 and 240-260 s, 150 and 300 rad/s (band
    # 100-300 rad/s) at 60-100 and 200-240 s: each band's range is that of its holds.
    def warmed(t: float) -> float:
        return 288.15 + 15.0 * t / 280.0

    band = ERROR_BAND_EDGES.index(30.0) + 1
    assert fitted.band_temperature_min[band] == pytest.approx(warmed(40.0), abs=0.3)
    assert fitted.band_temperature_max[band] == pytest.approx(warmed(260.0), abs=0.3)
    assert fitted.band_temperature_min[band + 1] == pytest.approx(warmed(60.0), abs=0.3)
    assert fitted.band_temperature_max[band + 1] == pytest.approx(warmed(240.0), abs=0.3)
    assert min(fitted.band_temperature_min) == fitted.temperature_min
    assert max(fitted.band_temperature_max) == fitted.temperature_max
    # and each fine speed bin its own: the bins inside a band (from 31.6 and 126 rad/s, where
    # the bins' edges fall, to 100 and 251 rad/s) within the band's range, all of them
    # together the recording's, the held speeds' bins seen; a reach of 0.1 decades about
    # 150 rad/s sees its first hold
    low, high = np.array(fitted.bin_temperature_min), np.array(fitted.bin_temperature_max)
    for k, (start, stop) in enumerate(((32.0, 99.0), (130.0, 250.0)), start=band):
        bins = slice(speed_bin(start), speed_bin(stop) + 1)
        assert np.min(low[bins]) >= fitted.band_temperature_min[k]
        assert np.max(high[bins]) <= fitted.band_temperature_max[k]
    assert (np.min(low), np.max(high)) == (fitted.temperature_min, fitted.temperature_max)
    for speed in (40.0, 60.0, 150.0, 300.0):
        assert math.isfinite(low[speed_bin(speed)])
    assert (low[speed_bin(1.0)], high[speed_bin(1.0)]) == (math.inf, -math.inf)
    reaching = replace(fitted, band_reach=0.1)
    assert replace(fitted, band_reach=0.0).reached_range(150.0) is None  # no reach
    coolest, warmest = reaching.reached_range(150.0)  # and the ramps through 119-189 rad/s
    assert coolest == pytest.approx(warmed(60.0), abs=0.3) and warmest <= fitted.temperature_max


def _halves() -> tuple[dict[str, tuple[np.ndarray, np.ndarray]], ...]:
    """_recording(1) cut at 140 s into a cooler and a warmer recording, the second on a clock
    of its own that starts at 0 s, as a second bag's would."""
    whole = _recording(1)
    first = {k: (t[t < 140.0], v[t < 140.0]) for k, (t, v) in whole.items()}
    second = {k: (t[t >= 140.0] - 140.0, v[t >= 140.0]) for k, (t, v) in whole.items()}
    return first, second


def test_two_recordings_on_one_clock_are_put_one_after_the_other() -> None:
    first, second = _halves()
    placed = one_timeline([first, second])
    end = max(float(t[-1]) for t, _ in first.values())
    start = min(float(t[0]) for t, _ in placed[1].values())
    assert start == pytest.approx(end + RECORDING_GAP)
    for name, (t, v) in second.items():
        assert np.array_equal(placed[1][name][1], v)  # values untouched
        assert np.allclose(np.diff(placed[1][name][0]), np.diff(t))  # spacing kept
    assert all(np.array_equal(placed[0][k][0], first[k][0]) for k in first)  # the first stays
    with pytest.raises(ConfigError, match="no recording"):
        one_timeline([])
    empty = {**second, "preload": (np.array([]), np.array([]))}
    with pytest.raises(
        ConfigError, match="recording 2 has no channels, or a channel without samples"
    ):
        one_timeline([first, empty])


def test_two_recordings_of_a_unit_commission_it_together(fitted: Baseline) -> None:
    # Each half of the recording saw half of its temperatures (15-22.5 C and 22.5-30 C), and
    # the warmer one comes first on a clock that overlaps the cooler one's; together they
    # recover the same unit as the whole recording and keep every band's temperatures from
    # both (the 30-100 rad/s holds run from 40 s to 260 s).
    first, second = _halves()
    both = commission([second, first], load_config(None), source="a + b").baseline
    assert both.source == "a + b"
    assert both.preload_scale == pytest.approx(TRUTH["preload_scale"], rel=0.03)
    assert both.temperature_shift == pytest.approx(TRUTH["temperature_shift"], abs=1.0)
    assert both.torque_bias == pytest.approx(TRUTH["torque_bias"], abs=1e-4)
    assert both.inertia == pytest.approx(TRUTH["inertia"], rel=0.1)
    band = ERROR_BAND_EDGES.index(30.0) + 1
    for edges in ("band_temperature_min", "band_temperature_max"):
        assert getattr(both, edges)[band] == pytest.approx(getattr(fitted, edges)[band], abs=0.3)


@pytest.mark.parametrize("name", ["error_scale", "unseen_error"])
@pytest.mark.parametrize("scale", [0.0, -1.5, math.inf, math.nan])
def test_an_error_scale_that_is_not_a_positive_number_is_refused(scale: float, name: str) -> None:
    with pytest.raises(ConfigError, match=rf"^commission: {name}"):
        commission({}, load_config(None), **{name: scale})


@pytest.mark.parametrize("quantile", [0.0, -0.5, 1.5, math.nan])
def test_an_unseen_quantile_outside_zero_to_one_is_refused(quantile: float) -> None:
    refused = r"^commission: unseen_quantile(:| = -?[\d.]+ is outside the).* range \(0, 1\] -"
    with pytest.raises(ConfigError, match=refused):
        commission({}, load_config(None), unseen_quantile=quantile)


def test_the_checked_keywords_are_the_typed_ones_and_commissions_own() -> None:
    """``bench detection`` passes a checked setting as ``**CommissionKeywords``: the three
    lists of names must agree, and each keyword of ``commission`` must have a default."""
    typed = CommissionKeywords.__optional_keys__
    assert set(KEYWORD_LIMITS) == typed and CommissionKeywords.__required_keys__ == set()
    parameters = inspect.signature(commission).parameters
    for name in typed:
        assert parameters[name].kind is inspect.Parameter.KEYWORD_ONLY
        assert parameters[name].default is not inspect.Parameter.empty


@pytest.mark.parametrize(
    ("keyword", "value"),
    [
        *(("temperature_error", growth) for growth in (-0.001, math.inf, math.nan)),
        *(("shift_extrapolation", scale) for scale in (0.0, -1.0, math.inf, math.nan)),
        *(("band_reach", reach) for reach in (-0.1, 3.5, math.nan)),
    ],
)
def test_a_growth_or_shift_scale_outside_its_range_is_refused(keyword: str, value: float) -> None:
    """e_T must be finite and >= 0, the shift's scale finite and > 0, the reach 0-3 decades;
    the message names it."""
    with pytest.raises(ConfigError, match=rf"^commission: {keyword}"):
        commission({}, load_config(None), **{keyword: value})


@pytest.mark.parametrize(
    ("keyword", "default", "value"),
    [
        ("temperature_error", TEMPERATURE_ERROR, 0.0005),
        ("shift_extrapolation", SHIFT_EXTRAPOLATION, 25.0),
        ("band_reach", BAND_REACH, 0.2),
    ],
)
def test_the_growth_and_shift_scale_keywords_set_their_field_and_nothing_else(
    fitted: Baseline, keyword: str, default: float, value: float
) -> None:
    """The keyword sets the baseline's e_T or the shift's scale and nothing else of the fit."""
    changed = commission(
        _recording(1), load_config(None), source="synthetic", **{keyword: value}
    ).baseline
    assert getattr(fitted, keyword) == default != value
    assert getattr(changed, keyword) == value
    assert replace(changed, **{keyword: default}) == fitted


def test_the_unseen_quantile_sets_the_untaught_error_above_its_floor(fitted: Baseline) -> None:
    """With a floor far below the fit's misfit the untaught error is the misfit's quantile:
    the median below the largest, both above the floor, and the median below the default
    floor that the default 99th percentile did not pass; where it taught, nothing changes."""
    recording = _recording(1)
    config = load_config(None)
    median = commission(recording, config, unseen_error=1e-6, unseen_quantile=0.5).baseline
    largest = commission(recording, config, unseen_error=1e-6, unseen_quantile=1.0).baseline
    assert 1e-6 < median.unseen_error < largest.unseen_error
    assert fitted.unseen_error == UNSEEN_ERROR and median.unseen_error < UNSEEN_ERROR
    assert median.error_bands[1:] == largest.error_bands[1:] == fitted.error_bands[1:]


def test_the_unseen_error_is_the_least_error_where_the_recording_did_not_teach(
    fitted: Baseline,
) -> None:
    """The same recording with another ``unseen_error``: the same fit and the same bands
    where it taught the twin, the new floor where it did not (the twin made the recording, so
    the fit's own 99th percentile lies far below either floor)."""
    wider = commission(_recording(1), load_config(None), source="synthetic", unseen_error=0.08)
    b = wider.baseline
    assert fitted.unseen_error == UNSEEN_ERROR and b.unseen_error == 0.08
    assert b.preload_scale == fitted.preload_scale and b.error_relative == fitted.error_relative
    # below 3 rad/s the recording (5-300 rad/s) has no blocks: that band takes the floor
    assert fitted.error_bands[0] == UNSEEN_ERROR and b.error_bands[0] == 0.08
    assert b.error_bands[1:] == fitted.error_bands[1:]
    # and so does the error where the surface has no support (-30 C, never seen)
    assert b.error_at(60.0, 243.15) == pytest.approx(math.hypot(b.error_bands[3], 0.08))


def test_commissioning_on_a_standstill_says_why_it_cannot(tmp_path: Path) -> None:
    channels = _recording(2)
    still = {k: (t, np.zeros_like(v) if k == "speed" else v) for k, (t, v) in channels.items()}
    with pytest.raises(ConfigError, match="comparable"):
        commission(still, load_config(None))


@pytest.fixture(scope="module")
def commissioned_bag(
    tmp_path_factory: pytest.TempPathFactory,
) -> tuple[Baseline, str, Path]:
    """The sample healthy bag commissioned by the command (with a growth e_T and a shift's
    scale of its own): its baseline, what it printed, and its plot."""
    folder = tmp_path_factory.mktemp("commissioned")
    out, png = folder / "unit.yaml", folder / "fit.png"
    capture = io.StringIO()
    with contextlib.redirect_stdout(capture):
        bag, growth = str(SAMPLE_DIR / "healthy"), "--temperature-error=0.003"
        scale, reach = "--shift-extrapolation=12.5", "--band-reach=0.3"
        code = main(
            ["commission", bag, "--out", str(out), "--plot", str(png), growth, scale, reach]
        )
    assert code == 0
    return load_baseline(out), capture.getvalue(), png


def test_commission_command_writes_baseline_and_plot(
    commissioned_bag: tuple[Baseline, str, Path],
) -> None:
    baseline, printed, png = commissioned_bag
    assert baseline.source == "healthy" and baseline.blocks > 100
    # it says where the residual surface was taught, and the error taken elsewhere
    assert baseline.surface is not None
    taught = int(np.sum(baseline.surface.support >= MIN_SUPPORT))
    nodes = baseline.surface.support.size
    assert 0 < taught < nodes
    assert f"taught at {taught} of {nodes} nodes" in printed
    assert f"taken as {baseline.unseen_error:.2%} (1 sigma)" in printed
    assert baseline.temperature_error == 0.003
    assert "grows by 0.30% per K (--temperature-error)" in printed
    assert baseline.shift_extrapolation == 12.5
    assert "|shift| / 12.5 K (--shift-extrapolation)" in printed
    assert baseline.band_reach == 0.3 and "within 0.3 decades of it (--band-reach)" in printed
    assert "caution" not in printed  # one recording: no word on several
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_commission_command_fits_several_bags_together(
    tmp_path: Path,
    commissioned_bag: tuple[Baseline, str, Path],
    capsys: pytest.CaptureFixture[str],
) -> None:
    once = commissioned_bag[0]
    healthy, out = SAMPLE_DIR / "healthy", tmp_path / "unit.yaml"
    assert main(["commission", str(healthy), str(healthy), "--out", str(out)]) == 0
    # the held-out finding of round 23 is said where a user fits several recordings
    assert "caution: fitted together, several recordings" in capsys.readouterr().out
    twice = load_baseline(out)
    assert twice.source == "healthy + healthy"
    # the same recording twice: the same unit from twice its blocks (all of them fitted below
    # 2 x FIT_BLOCKS)
    assert once.blocks < FIT_BLOCKS
    assert twice.blocks == 2 * once.blocks
    assert twice.preload_scale == pytest.approx(once.preload_scale, rel=0.01)
    assert twice.temperature_shift == pytest.approx(once.temperature_shift, abs=0.2)
    # a bag that is not there stops it before any fit, naming it
    assert main(["commission", str(healthy), str(tmp_path / "nowhere"), "--out", str(out)]) == 2


def test_a_twin_made_recording_leaves_a_flat_residual_surface(fitted: Baseline) -> None:
    # the recording is made by the map itself with the TRUTH parameters: nothing is left for
    # the surface to learn where the recording was (15-30 C, 5-300 rad/s)
    assert fitted.surface is not None
    speeds = np.array([6.0, 20.0, 60.0, 150.0])
    for temperature in (292.0, 300.0):
        assert fitted.surface_factor(speeds, temperature) == pytest.approx(1.0, abs=2e-3)
    # Learnt (by both folds) at the holds that span a fold boundary: 20 rad/s at 16.6 C
    # (20-40 s), 300 rad/s at 20 C (80-100 s), -5 rad/s at 23.0 C (140-160 s) and -150 rad/s
    # at 26.3 C (200-220 s); the other holds lie in one fold each.
    for speed, temperature in ((20.0, 289.75), (300.0, 293.15), (5.0, 296.2), (150.0, 299.4)):
        assert fitted.surface.support_at(speed, temperature) > MIN_SUPPORT
    assert fitted.surface.support_at(20.0, 350.0) == 0.0


class _FlatTwin:
    """A twin of constant drag 10 mN m (whatever the speed), for the settling study."""

    def adjusted(
        self,
        preload_scale: float,
        temperature_shift: float,
        friction_scales: tuple[float, float] = (1.0, 1.0),
    ) -> _FlatTwin:
        return self

    def drag(self, speed: np.ndarray, temperature: float, preload: float) -> np.ndarray:
        return np.full(len(speed), 0.01)


def _settling_blocks(phi_c: float) -> list[tuple[Block, float]]:
    """Blocks after reversals at 2 rad/s of a unit whose torque approaches the drag from the
    other direction's over a presliding angle phi_c: T = D (1 - 2 exp(-phi / phi_c))."""
    rng = np.random.default_rng(4)
    out = []
    for _ in range(12):  # twelve reversals, travel sampled every 0.05 rad up to 2 rad
        for travel in np.arange(0.0, 2.0, 0.05):
            phi = travel + np.linspace(0.0, 0.05, 20)
            torque = 0.01 * (1.0 - 2.0 * np.exp(-phi / phi_c)) + rng.normal(0.0, 2e-5, 20)
            stamps = np.linspace(0.0, 0.025, 20)
            block = Block(0, stamps, torque, np.full(20, 2.0), 293.0, 1000.0, ())
            out.append((block, float(travel)))
    return out


@pytest.mark.parametrize(("phi_c", "low", "high"), [(0.02, 0.05, 0.2), (0.1, 0.4, 0.8)])
def test_the_settling_angle_is_where_the_presliding_has_died_out(
    phi_c: float, low: float, high: float
) -> None:
    theta = np.array([1.0, 0.0, 0.0, 0.0, 1e-5, 0.0, 0.0, 0.0, 0.0])
    flat = ResidualSurface(
        np.zeros((len(LOG_SPEED_NODES), len(TEMPERATURE_NODES))),
        np.full((len(LOG_SPEED_NODES), len(TEMPERATURE_NODES)), 100.0),
    )
    bands = (0.007,) * 6
    twin = cast(UnitTwin, _FlatTwin())
    angle = _settling_angle(twin, theta, flat, _settling_blocks(phi_c), bands, 2.0)
    # 2 exp(-a / phi_c) <= 2 x 0.7 %: a >= phi_c ln(143) = 4.96 phi_c, on a 0.1 rad grid
    assert low <= angle <= high
    assert _settling_angle(twin, theta, flat, [], bands, 2.0) == 2.0


def test_a_corner_taught_in_one_stretch_alone_is_not_validated() -> None:
    # Blocks of 0.1 s: the first 20 s at 170 rad/s and -10 C (a cold start's corner), then
    # 100 s alternating between 170 rad/s at 25 C and 20 rad/s at 25 C. The cold node lies
    # in the first fold only, so both folds never taught it; the warm ones, in both.
    cold = np.arange(0.0, 20.0, 0.1)
    warm = np.arange(20.0, 120.0, 0.1)
    times = np.concatenate([cold, warm])
    speeds = np.concatenate([np.full(len(cold), 170.0), np.where(warm % 2.0 < 1.0, 170.0, 20.0)])
    temperatures = np.concatenate([np.full(len(cold), 263.15), np.full(len(warm), 298.15)])
    design, near = basis(speeds, temperatures), nearest_nodes(speeds, temperatures)
    study = SurfaceStudy(times, speeds, np.zeros(len(times)), design, near)
    validated = np.ravel(validated_support(study))
    plain = np.sum(near, axis=0)
    cold_node = int(np.argmax(nearest_nodes(np.array([170.0]), np.array([263.15]))[0]))
    assert plain[cold_node] >= MIN_SUPPORT  # the surface alone would call it learnt
    assert validated[cold_node] == 0.0
    # a warm node: twice the count of the fold that saw it less (an independent count)
    warm_node = int(np.argmax(nearest_nodes(np.array([170.0]), np.array([298.15]))[0]))
    folds = np.floor((times - times[0]) / FOLD_CHUNK).astype(int) % 2
    counts = [float(np.sum(near[folds == k, warm_node])) for k in (0, 1)]
    assert validated[warm_node] == pytest.approx(2.0 * min(counts))
    assert validated[warm_node] >= MIN_SUPPORT
