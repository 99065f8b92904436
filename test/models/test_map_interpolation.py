"""The folded stencils of the unpadded torque table against Catmull-Rom on an explicitly padded
axis (a linearly extrapolated ghost node at each end), and the limited cubic along the preload
against Catmull-Rom where no limit binds and against overshoot where one does."""

from __future__ import annotations

import numpy as np

from ballscrew_twin.models.map_interpolation import (
    catmull_rom_weights,
    folded_position,
    folded_rows,
    pad_axis,
    preload_line,
)


def test_folded_stencils_equal_the_padded_ghost_node_stencils() -> None:
    rng = np.random.default_rng(14)
    for count in (4, 5, 9):
        values = rng.normal(size=count)
        padded = pad_axis(values, 0)
        cells = np.array([0, 0, count - 2, count - 2, *rng.integers(0, count - 1, 20)])
        fractions = np.concatenate([[0.0, 0.7, 0.3, 1.0], rng.uniform(0.0, 1.0, 20)])
        starts, weights = folded_rows(cells, fractions, count)
        for cell, fraction, start, row in zip(cells, fractions, starts, weights, strict=True):
            expected = catmull_rom_weights(fraction) @ padded[cell : cell + 4]
            assert 0 <= start <= count - 4
            assert abs(row @ values[start : start + 4] - expected) < 1e-13
            single = folded_position((int(cell), float(fraction)), count)
            assert single.start == start
            np.testing.assert_array_equal(single.weights, row)


def _line(values: np.ndarray, cell: int, fraction: float) -> float:
    """``preload_line`` of a 1-D axis of ``values`` at ``fraction`` of ``cell``."""
    return float(preload_line(values, 0, (cell, fraction)))


def test_the_preload_line_is_catmull_rom_where_no_limit_binds() -> None:
    # Monotone and gently curved: every central slope lies within 3x the smaller secant.
    for values in (
        1.0 + 0.1 * np.arange(9.0) + 0.002 * np.arange(9.0) ** 2,
        np.exp(-0.2 * np.arange(6.0)),
    ):
        count = len(values)
        for cell in range(count - 1):
            for fraction in (0.0, 0.25, 0.6, 1.0):
                pos = folded_position((cell, fraction), count)
                plain = float(pos.weights @ values[pos.start : pos.start + 4])
                assert abs(_line(values, cell, fraction) - plain) < 1e-13


def test_the_preload_line_does_not_overshoot_a_step_or_a_filled_node() -> None:
    fractions = np.linspace(0.0, 1.0, 41)
    # A steep fall over one cell beside flat ones (the master nut of the 32 mm screw at
    # 15-23 N), and a node filled from its neighbour (a flat step), and a local maximum.
    for values in (
        np.array([70.0, 68.0, 67.5, 20.9, 19.3, 18.9, 19.8]),
        np.array([5.0, 3.0, 3.0, 1.0, 0.5, 0.4]),
        np.array([0.0, 1.0, 3.0, 2.0, 0.0, -1.0]),
    ):
        count = len(values)
        for cell in range(count - 1):
            line = np.array([_line(values, cell, f) for f in fractions])
            low, high = sorted((values[cell], values[cell + 1]))
            assert line.min() >= low - 1e-12 and line.max() <= high + 1e-12, (values, cell)
    # The plain cubic of the first case does overshoot (what the limit is for).
    values = np.array([70.0, 68.0, 67.5, 20.9, 19.3, 18.9, 19.8])
    pos = [folded_position((3, f), len(values)) for f in fractions]
    plain = np.array([p.weights @ values[p.start : p.start + 4] for p in pos])
    assert plain.min() < 19.3 - 0.5
