"""The folded stencils of the unpadded torque table against Catmull-Rom on an explicitly padded
axis (a linearly extrapolated ghost node at each end)."""

from __future__ import annotations

import numpy as np

from ballscrew_twin.models.map_interpolation import (
    catmull_rom_weights,
    folded_position,
    folded_rows,
    pad_axis,
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
