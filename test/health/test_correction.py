"""The residual surface: bilinear basis exact on bilinear functions, the penalised fit recovers a
smooth surface where it has data and relaxes to zero far from it, outliers do not bend it, and
a node's support counts only the samples nearest to it."""

from __future__ import annotations

import numpy as np
import pytest

from ballscrew_twin.errors import ConfigError
from ballscrew_twin.health.correction import (
    LOG_SPEED_NODES,
    MIN_SUPPORT,
    SPEED_REFERENCE,
    TEMPERATURE_NODES,
    ResidualSurface,
    basis,
    fit_surface,
    log_speed,
    nearest_nodes,
    robust_fit,
)

SHAPE = (len(LOG_SPEED_NODES), len(TEMPERATURE_NODES))


def _true_surface(speed: np.ndarray, temperature: np.ndarray) -> np.ndarray:
    """A smooth unit misfit: -3 % at 8 rad/s and 300 K, fading over speed and temperature."""
    x = np.log10(np.abs(speed) / 8.0)
    return -0.03 * np.exp(-(x**2) / 0.5) * (1.0 + 0.004 * (temperature - 300.0))


def test_basis_rows_sum_to_one_and_interpolate_bilinear_functions_exactly() -> None:
    rng = np.random.default_rng(3)
    speed = np.exp(rng.uniform(np.log(0.5), np.log(400.0), 200)) * rng.choice([-1, 1], 200)
    temperature = rng.uniform(240.0, 360.0, 200)
    rows = basis(speed, temperature)
    np.testing.assert_allclose(rows.sum(axis=1), 1.0, rtol=0, atol=1e-14)
    x_nodes, t_nodes = np.meshgrid(LOG_SPEED_NODES, TEMPERATURE_NODES, indexing="ij")
    nodes = 0.2 + 0.1 * x_nodes - 0.002 * (t_nodes - 300.0)  # linear: exact under bilinear
    expected = 0.2 + 0.1 * log_speed(speed) - 0.002 * (temperature - 300.0)
    np.testing.assert_allclose(rows @ nodes.ravel(), expected, rtol=0, atol=1e-12)
    assert log_speed(np.array([SPEED_REFERENCE, -SPEED_REFERENCE]))[1] == 0.0
    # the surface's own interpolation is the same bilinear form as the basis
    surface = ResidualSurface(0.01 * np.sin(nodes), np.abs(nodes))
    for t in (240.0, 301.7, 360.0):
        np.testing.assert_allclose(
            surface.at(speed, t),
            basis(speed, np.full(len(speed), t)) @ surface.values.ravel(),
            rtol=0,
            atol=1e-15,
        )
        assert surface.support_at(7.0, t) == pytest.approx(
            float(basis(np.array([7.0]), np.array([t]))[0] @ surface.support.ravel()), abs=1e-13
        )


def test_the_fit_recovers_a_smooth_surface_where_it_has_data_and_relaxes_far_from_it() -> None:
    rng = np.random.default_rng(5)
    n = 3000
    speed = np.exp(rng.uniform(np.log(2.0), np.log(300.0), n))
    temperature = rng.uniform(280.0, 310.0, n)
    truth = _true_surface(speed, temperature)
    surface = fit_surface(
        basis(speed, temperature),
        truth + rng.normal(0.0, 0.003, n),
        nearest_nodes(speed, temperature),
    )
    probe_w = np.array([3.0, 8.0, 30.0, 100.0])
    for t in (285.0, 300.0):
        # inside the data: the truth to 0.25 % of the drag (noise 0.3 % per block)
        np.testing.assert_allclose(
            surface.at(probe_w, t), _true_surface(probe_w, np.full(4, t)), rtol=0, atol=2.5e-3
        )
        assert surface.support_at(8.0, t) > MIN_SUPPORT
    # 60 K beyond the data there is no support, and the surface has relaxed towards zero
    assert surface.support_at(8.0, 370.0) == 0.0
    assert abs(surface.at(np.array([8.0]), 370.0)[0]) < 0.3 * abs(
        surface.at(np.array([8.0]), 305.0)[0]
    )


def test_outliers_do_not_bend_the_robust_fit() -> None:
    rng = np.random.default_rng(8)
    n = 2000
    speed = np.exp(rng.uniform(np.log(3.0), np.log(100.0), n))
    temperature = np.full(n, 295.0)
    residual = np.full(n, 0.01) + rng.normal(0.0, 0.002, n)
    residual[::20] = 0.5  # 5 % of the blocks across a preload step
    design, near = basis(speed, temperature), nearest_nodes(speed, temperature)
    plain = fit_surface(design, residual, near).at(np.array([10.0]), 295.0)[0]
    robust = robust_fit(design, residual, near, 0.01).at(np.array([10.0]), 295.0)[0]
    assert plain > 0.03  # least squares is pulled by the outliers
    assert robust == pytest.approx(0.01, abs=1.5e-3)


def test_a_surface_of_the_wrong_shape_or_size_is_refused() -> None:
    with pytest.raises(ConfigError, match="shape"):
        ResidualSurface(np.zeros((3, 3)), np.zeros((3, 3)))
    with pytest.raises(ConfigError, match="< 1"):
        ResidualSurface(np.full(SHAPE, 1.5), np.zeros(SHAPE))
    with pytest.raises(ConfigError, match="not finite"):
        ResidualSurface(np.full(SHAPE, np.nan), np.zeros(SHAPE))
    with pytest.raises(ConfigError, match="scale"):
        robust_fit(
            np.zeros((2, SHAPE[0] * SHAPE[1])), np.zeros(2), np.zeros((2, SHAPE[0] * SHAPE[1])), 0.0
        )
    with pytest.raises(ConfigError, match="nearness"):
        fit_surface(np.zeros((2, SHAPE[0] * SHAPE[1])), np.zeros(2), np.zeros((3, 4)))


def test_each_sample_counts_for_its_nearest_node() -> None:
    rng = np.random.default_rng(11)
    speed = np.exp(rng.uniform(np.log(0.05), np.log(900.0), 300)) * rng.choice([-1, 1], 300)
    temperature = rng.uniform(220.0, 390.0, 300)
    rows = nearest_nodes(speed, temperature)
    np.testing.assert_array_equal(rows.sum(axis=1), 1.0)
    # Oracle: the node at the least distance in node units on each axis, clamped to the grid.
    x = (
        np.clip(log_speed(speed), LOG_SPEED_NODES[0], LOG_SPEED_NODES[-1]) - LOG_SPEED_NODES[0]
    ) / 0.25
    t = (
        np.clip(temperature, TEMPERATURE_NODES[0], TEMPERATURE_NODES[-1]) - TEMPERATURE_NODES[0]
    ) / 5.0
    expected = np.floor(x + 0.5).astype(int) * len(TEMPERATURE_NODES) + np.floor(t + 0.5).astype(
        int
    )
    np.testing.assert_array_equal(np.argmax(rows, axis=1), expected)


def test_data_on_the_far_side_of_a_cell_does_not_teach_its_node() -> None:
    """Blocks at 18-21 C only (a service run, unit 22011 of round 23): the 15 C node is not
    learnt, though its bilinear weight over those blocks is several times MIN_SUPPORT at most
    speed nodes."""
    rng = np.random.default_rng(12)
    speed = np.exp(rng.uniform(np.log(5.0), np.log(200.0), 2000))
    temperature = 273.15 + rng.uniform(18.0, 21.0, 2000)
    design = basis(speed, temperature)
    surface = fit_surface(design, np.full(2000, 0.02), nearest_nodes(speed, temperature))
    node_15 = TEMPERATURE_NODES.index(288.15)
    node_20 = TEMPERATURE_NODES.index(293.15)
    weight_15 = design.reshape(len(design), len(LOG_SPEED_NODES), -1)[:, :, node_15].sum(axis=0)
    assert weight_15.max() > 3 * MIN_SUPPORT  # what the basis-weight support would count
    assert np.all(surface.support[:, node_15] == 0.0)
    assert surface.support[:, node_20].max() >= MIN_SUPPORT
    # so a query at 12.9 C takes its value from unlearnt nodes only
    assert surface.unlearnt_share(30.0, 286.05) == 1.0


def test_a_query_between_a_learnt_and_an_unlearnt_node_is_mostly_unlearnt() -> None:
    """Support at one speed node only (90 blocks at every temperature): a query 80 % of the
    way to the next, unsupported node interpolates 18 blocks of support (over MIN_SUPPORT)
    but takes 80 % of its value from a node nothing taught: its unlearnt share is 0.8."""
    shape = (len(LOG_SPEED_NODES), len(TEMPERATURE_NODES))
    learnt = LOG_SPEED_NODES.index(0.25)  # 53 rad/s
    support = np.zeros(shape)
    support[learnt, :] = 90.0
    surface = ResidualSurface(np.zeros(shape), support)
    between = SPEED_REFERENCE * 10 ** (0.25 + 0.8 * 0.25)  # 84.5 rad/s
    assert surface.support_at(between, 274.45) == pytest.approx(18.0)
    assert surface.support_at(between, 274.45) > MIN_SUPPORT
    assert surface.unlearnt_share(between, 274.45) == pytest.approx(0.8)
    assert surface.unlearnt_share(SPEED_REFERENCE * 10**0.25, 274.45) == pytest.approx(0.0)
    assert surface.unlearnt_share(300.0, 274.45) == 1.0
    # a node half-taught (5 of MIN_SUPPORT blocks) counts half
    support[learnt + 1, :] = 0.5 * MIN_SUPPORT
    half = ResidualSurface(np.zeros(shape), support)
    assert half.unlearnt_share(between, 274.45) == pytest.approx(0.8 * 0.5)
