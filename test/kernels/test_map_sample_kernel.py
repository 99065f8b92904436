"""The compiled map interpolation (kernels/map_sample.py) against the numpy reference
(``SteadyMap._interpolate_reference``) on the committed map, and the filled-node window against
slicing the ``filled`` table directly."""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np
import pytest

from ballscrew_twin.models import map_grid
from ballscrew_twin.models import steady_map as sm
from ballscrew_twin.models.map_interpolation import axis_cell, preload_node

RNG_SEED = 20261121


@pytest.fixture(scope="module")
def table() -> sm.SteadyMap:
    return sm.load_map()


def _queries(grid: map_grid.MapGrid, count: int) -> list[tuple[float, float, tuple[float, float]]]:
    """Random queries over and beyond the map: both speed signs, the standstill blend below
    speed_min, exact zero, clamping on every axis, equal and unequal nut preloads, and nodes."""
    rng = np.random.default_rng(RNG_SEED)
    queries = []
    for _ in range(count):
        log_speed = rng.uniform(np.log(grid.speed_min) - 2.0, np.log(grid.speed_max) + 0.5)
        speed = float(rng.choice([-1.0, 1.0]) * np.exp(log_speed))
        temperature = float(rng.uniform(grid.temperature_min - 20.0, grid.temperature_max + 20.0))
        master = float(rng.uniform(-100.0, 1.1 * grid.preload_max))
        slave = master if rng.random() < 0.3 else float(rng.uniform(0.0, grid.preload_max))
        queries.append((speed, temperature, (master, slave)))
    # Nodes and edges exactly: cell boundaries (fraction 0) and the last node (fraction 1).
    queries += [
        (0.0, grid.temperature_min, (0.0, 0.0)),
        (grid.speed_min, grid.temperature_max, (grid.preload_max, grid.preload_max)),
        (-grid.speed_max, float(grid.temperatures[1]), (float(grid.preloads[2]), 0.0)),
        (float(grid.speeds[3]), float(grid.temperatures[-2]), (1500.0, 1500.0)),
    ]
    return queries


@pytest.mark.parametrize("contacts", [False, True])
def test_compiled_equals_reference(table: sm.SteadyMap, contacts: bool) -> None:
    """Torques and contact states agree to rounding, and the notes are the same, over 400
    random queries and the grid's edges."""
    worst_torque = worst_states = 0.0
    for speed, temperature, preloads in _queries(table.grid, 400):
        fast = table.sample(speed, temperature, preloads, contacts=contacts, compiled=True)
        ref = table.sample(speed, temperature, preloads, contacts=contacts, compiled=False)
        assert fast.notes == ref.notes
        assert fast.torque.shape == ref.torque.shape == (map_grid.NUTS, 6)
        scale = np.abs(ref.torque).max() + 1e-12
        worst_torque = max(worst_torque, float(np.abs(fast.torque - ref.torque).max() / scale))
        if not contacts:
            assert fast.contacts is None and ref.contacts is None
            continue
        assert fast.contacts is not None and ref.contacts is not None
        assert fast.contacts.shape == ref.contacts.shape
        # Per field: relative to the field's largest magnitude at this query.
        field_scale = np.abs(ref.contacts).max(axis=(0, 1)) + 1e-30
        error = np.abs(fast.contacts - ref.contacts).max(axis=(0, 1)) / field_scale
        worst_states = max(worst_states, float(error.max()))
    assert worst_torque < 1e-12
    assert worst_states < 1e-12


def test_compiled_equals_reference_where_the_preload_limit_binds(table: sm.SteadyMap) -> None:
    """The packaged torques with a steep step, a flat (filled) node and a sign change along
    every preload line: the limited cubic binds, and kernel and reference still agree."""
    factors = np.ones(table.grid.preload_nodes)
    factors[3], factors[4], factors[6] = 4.0, 4.0, -0.5
    stepped = replace(table, torque=table.torque * factors[None, None, None, :, None, None])
    worst = 0.0
    for speed, temperature, preloads in _queries(stepped.grid, 200):
        fast = stepped.sample(speed, temperature, preloads, contacts=False, compiled=True)
        ref = stepped.sample(speed, temperature, preloads, contacts=False, compiled=False)
        scale = np.abs(ref.torque).max() + 1e-12
        worst = max(worst, float(np.abs(fast.torque - ref.torque).max() / scale))
    assert worst < 1e-12


def test_filled_window_matches_slicing(table: sm.SteadyMap) -> None:
    """The precomputed window equals slicing ``filled`` around every cell the sampler uses."""
    g = table.grid
    assert table.filled.any()  # the committed map has filled nodes: the check means something
    counts = (2, g.speed_nodes - 1, g.temperature_nodes - 1, g.preload_nodes - 1)
    cells = itertools.product(*(range(n) for n in counts))
    for sign, s, t, p in cells:
        a, b, c = max(s - 1, 0), max(t - 1, 0), max(p - 1, 0)
        expected = bool(table.filled[sign, a : a + 4, b : b + 4, c : c + 4].any())
        assert table._filled_near(sign, (s, t, p)) == expected, (sign, s, t, p)


def test_a_note_names_the_nut_near_a_filled_node(table: sm.SteadyMap) -> None:
    """A query inside the stencil of a filled node says so for that nut only."""
    g = table.grid
    sign, s, t, p = (int(i) for i in np.argwhere(table.filled)[0])
    speed = float(g.speeds[s]) * (1.0 if sign == 0 else -1.0)
    cell_s, cell_t = min(s, g.speed_nodes - 2), min(t, g.temperature_nodes - 2)
    # The slave nut's preload: a node whose cell (as the query finds it: the node's preload in
    # node units may round to just below the node) uses no filled node.
    clear = next(
        float(preload)
        for preload in g.preloads
        if not table._filled_near(
            sign, (cell_s, cell_t, axis_cell(preload_node(g, preload), g.preload_nodes)[0])
        )
    )
    notes = table.sample(speed, float(g.temperatures[t]), (float(g.preloads[p]), clear)).notes
    assert any(n.startswith("master nut: interpolated near map nodes") for n in notes)
    assert not any(n.startswith("slave nut") for n in notes)
