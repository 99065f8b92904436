"""The output types of models/base.py: the cheap constructors a 1 kHz model uses."""

from __future__ import annotations

import copy
import dataclasses
import pickle

import numpy as np
import pytest

from ballscrew_twin.models.base import (
    ContactStates,
    OperatingPoint,
    TorqueBreakdown,
    TwinOutput,
    contact_states_from_rows,
    filled,
)

FLOAT_FIELDS = tuple(
    f.name
    for f in dataclasses.fields(ContactStates)
    if f.name not in ("sphere", "nut", "half_groove", "in_contact")
)


def _row_states() -> tuple[ContactStates, np.ndarray]:
    rows = np.arange(len(FLOAT_FIELDS) * 8, dtype=np.float64).reshape(len(FLOAT_FIELDS), 8)
    sphere = np.repeat(np.arange(2), 4)
    nut = np.repeat(np.arange(2), 4)
    half_groove = np.tile(np.arange(4), 2)
    in_contact = np.array([True, False] * 4)
    return contact_states_from_rows(sphere, nut, half_groove, in_contact, rows, FLOAT_FIELDS), rows


def test_filled_equals_the_constructor() -> None:
    parts = {
        name: float(k + 1)
        for k, name in enumerate(f.name for f in dataclasses.fields(TorqueBreakdown))
    }
    breakdown = filled(TorqueBreakdown, **parts)
    assert breakdown == TorqueBreakdown(**parts)
    assert vars(breakdown) == vars(TorqueBreakdown(**parts))
    assert breakdown.total == 21.0
    point = OperatingPoint(screw_speed=10.0, temperature=300.0, preload=100.0)
    values = {
        "drag_torque": 1.5,
        "nut_torque": (0.5, 1.0),
        "breakdown": breakdown,
        "fidelity": "steady-symmetric",
        "operating_point": point,
        "contacts": None,
        "notes": ("a note",),
    }
    output = filled(TwinOutput, **values)
    assert output == TwinOutput(**values)  # type: ignore[arg-type]
    assert list(vars(output)) == [f.name for f in dataclasses.fields(TwinOutput)]
    with pytest.raises(dataclasses.FrozenInstanceError):
        output.drag_torque = 2.0  # type: ignore[misc]
    assert dataclasses.replace(output, notes=()).notes == ()


def test_row_contact_states_read_as_the_rows() -> None:
    states, rows = _row_states()
    assert isinstance(states, ContactStates)
    assert "normal_force" not in vars(states)  # no view made before a field is read
    for k, name in enumerate(FLOAT_FIELDS):
        np.testing.assert_array_equal(getattr(states, name), rows[k])
        assert np.shares_memory(getattr(states, name), rows)
    np.testing.assert_array_equal(states.in_contact, [True, False] * 4)
    assert not hasattr(states, "no_such_field")
    with pytest.raises(dataclasses.FrozenInstanceError):
        states.normal_force = rows[0]  # type: ignore[misc]


def test_row_contact_states_behave_as_the_dataclass() -> None:
    states, _ = _row_states()
    copied = pickle.loads(pickle.dumps(states))  # before any field was read
    duplicate = copy.deepcopy(states)
    changed = dataclasses.replace(states, slip_speed=np.zeros(8))
    plain = ContactStates(**{f.name: getattr(states, f.name) for f in dataclasses.fields(states)})
    for name in FLOAT_FIELDS:
        np.testing.assert_array_equal(getattr(copied, name), getattr(plain, name))
        np.testing.assert_array_equal(getattr(duplicate, name), getattr(plain, name))
        if name != "slip_speed":
            np.testing.assert_array_equal(getattr(changed, name), getattr(plain, name))
    np.testing.assert_array_equal(changed.slip_speed, np.zeros(8))
    assert dataclasses.asdict(states).keys() == dataclasses.asdict(plain).keys()
    assert repr(states).startswith("_RowContactStates(sphere=array(")
