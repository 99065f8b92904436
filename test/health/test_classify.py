"""Fault classification: sphere-pass orders (bearing identities) and signature fits."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from ballscrew_twin.health.classify import (
    MAX_REDUCED_CHI_SQUARE,
    Response,
    classify_mean_shift,
    classify_ripple,
    defect_orders,
)
from ballscrew_twin.health.fault_profiles import defect_frequencies
from ballscrew_twin.params import load_config


def test_raceway_pass_orders_add_up_to_spheres_per_turn() -> None:
    # Classical rolling-bearing identity: BPFO + BPFI = Z x shaft frequency (here per turn).
    config = load_config(None)
    orders = defect_orders(config)
    per_turn = config.screw.balls_per_nut / config.screw.loaded_turns
    assert orders["nut_raceway"] + orders["screw_raceway"] == pytest.approx(per_turn)
    assert orders["nut_raceway"] < orders["screw_raceway"]


def test_orders_in_the_limit_of_a_point_sphere_contact_at_ninety_degrees() -> None:
    # cos(alpha) = 0: cage at half the shaft speed, sphere spin order r_m / r_b.
    config = load_config(None)
    flat = replace(config, screw=replace(config.screw, nominal_contact_angle=math.pi / 2))
    orders = defect_orders(flat)
    per_turn = config.screw.balls_per_nut / config.screw.loaded_turns
    assert orders["nut_raceway"] == pytest.approx(per_turn / 2)
    assert orders["screw_raceway"] == pytest.approx(per_turn / 2)
    assert orders["sphere_spin"] == pytest.approx(
        config.screw.pitch_radius / config.screw.ball_radius
    )


def test_orders_are_the_frequencies_per_rotation_at_any_speed() -> None:
    config = load_config(None)
    for speed in (10.0, -20.0):
        freqs = defect_frequencies(config, speed)
        for name, order in defect_orders(config).items():
            assert freqs[name] == pytest.approx(order * abs(speed) / (2 * math.pi))


def _signatures() -> dict[str, np.ndarray]:
    """Per-block signatures over an operating profile with a low and a high speed."""
    low = np.arange(60) < 30
    return {
        "preload_loss": np.where(low, -0.015, -0.020),  # falls everywhere
        "lubricant_degradation": np.where(low, 0.003, -0.006),  # rises slow, falls fast
        "jam_onset": np.where(low, 0.004, 0.001),
    }


@pytest.mark.parametrize("true_class", ["preload_loss", "lubricant_degradation", "jam_onset"])
def test_mean_shift_classes_are_recovered_when_the_speed_moves(true_class: str) -> None:
    signatures = _signatures()
    rng = np.random.default_rng(11)
    sigma = np.full(60, 1e-4)
    severity = 0.2
    residuals = severity * signatures[true_class] + rng.normal(0, 1e-4, 60)
    result = classify_mean_shift(residuals, sigma, signatures)
    assert result.fault_class == true_class
    assert result.confidence > 0.99
    assert result.severities[true_class] == pytest.approx(severity, rel=0.1)


def test_two_classes_with_the_same_signature_shape_are_not_separable() -> None:
    constant = np.full(40, 1.0)
    signatures = {"preload_loss": -0.01 * constant, "lubricant_degradation": -0.004 * constant}
    residuals = np.full(40, -2e-3)
    result = classify_mean_shift(residuals, np.full(40, 1e-4), signatures)
    assert result.confidence == pytest.approx(0.5, abs=1e-6)


def test_a_change_no_class_can_make_is_left_unclassified() -> None:
    signatures = {"preload_loss": np.full(10, -0.01)}  # can only lower the torque
    result = classify_mean_shift(np.full(10, 1e-3), np.full(10, 1e-4), signatures)
    assert result.fault_class == ""
    assert result.confidence == 0.0


def test_ripple_class_follows_the_order_that_fired() -> None:
    result = classify_ripple({"nut_raceway": 3.0, "screw_raceway": 40.0, "sphere_spin": 1.0}, 20.0)
    assert result.fault_class == "raceway_defect" and result.confidence == 1.0
    result = classify_ripple({"nut_raceway": 30.0, "sphere_spin": 50.0}, 20.0)
    assert result.fault_class == "sphere_defect"
    assert result.confidence == pytest.approx(30.0 / 40.0)
    assert classify_ripple({"sphere_spin": 5.0}, 20.0).fault_class == ""


def test_a_fraction_lost_beyond_one_is_not_a_valid_explanation() -> None:
    # The lubricant signature would need a 150 % viscosity loss; the jam fits within range.
    n = 20
    signatures = {"lubricant_degradation": np.full(n, 0.002), "jam_onset": np.full(n, 0.0008)}
    residuals = np.full(n, 0.003)
    result = classify_mean_shift(residuals, np.full(n, 1e-4), signatures)
    assert result.severities["lubricant_degradation"] == pytest.approx(1.5)
    assert result.fault_class == "jam_onset"


def _two_close_shapes(n: int) -> dict[str, np.ndarray]:
    low = np.arange(n) < n // 2
    return {
        "preload_loss": np.where(low, -0.010, -0.020),
        "lubricant_degradation": np.where(low, -0.0103, -0.020),
    }


def test_a_misfit_beyond_the_noise_tempers_the_confidence() -> None:
    # Two shapes that differ by 3 % on half the blocks; the residual has the first shape plus
    # an unexplained pattern about 1.6 sigma large (reduced chi-square ~1.3): the best fit's
    # reduced chi-square scales the comparison, so the choice is no longer near-certain.
    n = 40
    signatures = _two_close_shapes(n)
    unexplained = 2.2e-4 * np.sin(np.arange(n))
    residuals = 0.2 * signatures["preload_loss"] + unexplained
    clean = classify_mean_shift(0.2 * signatures["preload_loss"], np.full(n, 1e-4), signatures)
    muddy = classify_mean_shift(residuals, np.full(n, 1e-4), signatures)
    assert clean.fault_class == "preload_loss" and clean.confidence > 0.9
    assert 1.0 < muddy.reduced_chi_square < MAX_REDUCED_CHI_SQUARE
    assert muddy.fault_class == "preload_loss"
    assert 0.5 <= muddy.confidence < clean.confidence


def test_a_residual_no_class_explains_is_unclassified_with_the_reason() -> None:
    # The same shapes, the unexplained pattern 20 sigma large: no class is named.
    n = 40
    signatures = _two_close_shapes(n)
    residuals = 0.2 * signatures["preload_loss"] + 2e-3 * np.sin(np.arange(n))
    result = classify_mean_shift(residuals, np.full(n, 1e-4), signatures)
    assert result.fault_class == "" and result.confidence == 0.0
    assert result.reduced_chi_square > MAX_REDUCED_CHI_SQUARE
    assert "reduced chi-square" in result.reason


def test_a_severity_outside_the_class_range_is_unclassified() -> None:
    # A torque rise that only a viscosity *increase* (negative loss) or a preload gain would
    # explain: no class in its range, so no class is named.
    n = 30
    signatures = {"preload_loss": np.full(n, -0.01), "lubricant_degradation": np.full(n, -0.004)}
    result = classify_mean_shift(np.full(n, 0.002), np.full(n, 1e-4), signatures)
    assert result.fault_class == ""
    assert result.reason


def test_correlated_blocks_count_as_fewer_pieces_of_evidence() -> None:
    n = 40
    signatures = _two_close_shapes(n)
    residuals = 0.2 * signatures["preload_loss"]
    alone = classify_mean_shift(residuals, np.full(n, 1e-4), signatures)
    grouped = classify_mean_shift(residuals, np.full(n, 1e-4), signatures, correlation=10.0)
    assert grouped.fault_class == alone.fault_class == "preload_loss"
    assert 0.5 < grouped.confidence < alone.confidence


def test_a_growing_fault_at_one_operating_point_stays_unseparable() -> None:
    # A fault ramping up at one constant operating point, with a slow 2 % drift of one
    # signature (temperature): the fit of a growing severity must not turn the drift and the
    # ramp into a confident choice between two classes that move the torque the same way.
    n = 60
    elapsed = np.arange(n) * 0.1
    drift = 1.0 + 0.02 * elapsed / elapsed[-1]
    signatures = {"lubricant_degradation": 0.004 * drift, "jam_onset": np.full(n, 0.008)}
    residuals = 0.3 * (elapsed / elapsed[-1]) * signatures["lubricant_degradation"]
    result = classify_mean_shift(residuals, np.full(n, 1e-5), signatures, elapsed)
    assert result.confidence < 0.9  # torque alone at one operating point: not separable


def test_a_response_is_linear_in_the_severity_between_its_points_and_through_zero() -> None:
    rng = np.random.default_rng(3)
    points = np.array([0.1, 0.3, 0.6])
    changes = rng.normal(0.0, 1e-3, (3, 5))
    response = Response(points, changes)
    severity = np.array([0.0, 0.05, 0.3, 0.45, 0.8])
    change, slope = response.at(severity)
    for j, a in enumerate(severity):
        xs, ys = np.concatenate(([0.0], points)), np.concatenate(([0.0], changes[:, j]))
        if a <= points[-1]:
            assert change[j] == pytest.approx(np.interp(a, xs, ys), abs=1e-15)
        else:  # beyond the last point: along the last segment
            last = (ys[-1] - ys[-2]) / (xs[-1] - xs[-2])
            assert change[j] == pytest.approx(ys[-1] + last * (a - xs[-1]), abs=1e-15)
            assert slope[j] == pytest.approx(last)
    assert slope[1] == pytest.approx(changes[0, 1] / 0.1)


def test_a_linear_class_gets_the_closed_form_weighted_least_squares_severity() -> None:
    signature = np.where(np.arange(30) < 15, -0.01, -0.02)
    sigma = np.where(np.arange(30) % 2 == 0, 1e-4, 2e-4)
    residuals = 0.17 * signature + np.random.default_rng(5).normal(0.0, 1e-4, 30)
    result = classify_mean_shift(residuals, sigma, {"preload_loss": signature})
    w = 1.0 / sigma**2
    exact = float(np.sum(w * signature * residuals) / np.sum(w * signature**2))
    assert result.severities["preload_loss"] == pytest.approx(exact, rel=1e-9)
    # and its score is the drop of the weighted sum of squares over two
    rss = float(np.sum(w * (residuals - exact * signature) ** 2))
    assert result.scores["preload_loss"] == pytest.approx(
        0.5 * (float(np.sum(w * residuals**2)) - rss), rel=1e-9
    )


def test_a_bending_response_is_fitted_at_the_severity_the_data_call_for() -> None:
    # A class whose change is quadratic in its severity (rises at low speed, crosses zero
    # near mid speed as the severity grows, falls at high speed: a viscosity loss), known at
    # four severities; the truth at 0.4 lies between two of them. The other class is linear
    # with the first class's secant at 0.3, the shape a one-secant fit would have used.
    group = np.repeat([0, 1, 2], 20)
    linear = np.array([1.5e-3, -0.5e-3, -3.0e-3])[group]
    quadratic = np.array([0.5e-3, 2.0e-3, -1.0e-3])[group]

    def change(a: float) -> np.ndarray:
        return linear * a + quadratic * a**2

    points = np.array([0.1, 0.3, 0.6, 0.9])
    responses = {
        "lubricant_degradation": Response(points, np.array([change(a) for a in points])),
        "jam_onset": change(0.3) / 0.3,
    }
    sigma = np.full(60, 3e-5)
    residuals = change(0.4) + np.random.default_rng(7).normal(0.0, 3e-5, 60)
    result = classify_mean_shift(residuals, sigma, responses)
    assert result.fault_class == "lubricant_degradation"
    assert result.confidence > 0.99
    assert result.severities["lubricant_degradation"] == pytest.approx(0.4, rel=0.05)
    assert result.reduced_chi_square < 2.0
