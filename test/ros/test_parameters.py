"""Parameter specs: types, bounds, choices, and how a node declares them (descriptors)."""

from __future__ import annotations

import math

import pytest
from rcl_interfaces.msg import ParameterType
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter

from ballscrew_twin.errors import ConfigError
from ballscrew_twin.ros.node_parameters import ParameterRefusedError, TableNode, descriptor
from ballscrew_twin.ros.parameters import ParameterSpec, first_refusal, table_by_name
from ballscrew_twin.ros.twin_node import TwinNode
from ballscrew_twin.ros.twin_parameters import TWIN_PARAMETERS, rates_refused

RATE = ParameterSpec("rate", 10.0, "Hz", "A rate", 1.0, 100.0, run_time=True)
COUNT = ParameterSpec("count", 3, "-", "A count", 1, 5)
MODE = ParameterSpec("mode", "a", "", "A mode", choices=("a", "b"))
NAMES = ParameterSpec("names", ("a",), "", "Names", choices=("a", "b"))
FLAG = ParameterSpec("flag", False, "", "A flag")


def test_a_value_is_checked_for_type_bounds_and_choices() -> None:
    assert RATE.check(50.0) is None and RATE.check(50) is None  # an integer is a double
    # numbers through the package's one check: the name, the unit and the range
    assert RATE.check(100.5) == "rate = 100.5 is outside the allowed range [1, 100] Hz"
    assert RATE.check(0.5) == "rate = 0.5 is outside the allowed range [1, 100] Hz"
    assert RATE.check(1e4) == "rate = 10000.0 is outside the allowed range [1, 100] Hz"  # no hint
    assert RATE.check(math.nan) == "rate: nan is not a finite number (allowed range [1, 100] Hz)"
    assert RATE.check(1.0) is None and RATE.check(100.0) is None  # the closed ends
    assert RATE.check("fast") == "rate = 'fast' is a str, expected a double"
    assert COUNT.check(2.0) == "count = 2.0 is a float, expected a integer"
    assert COUNT.check(6) is not None and COUNT.check(5) is None
    assert MODE.check("c") == "mode = 'c' is not one of a, b"
    assert NAMES.check(["b", "a"]) is None  # rclpy gives string arrays as lists
    assert NAMES.check(["a", "z"]) == "names = 'z' is not one of a, b"
    assert FLAG.check(True) is None and FLAG.check(1) is not None


def test_a_spec_refuses_its_own_bad_default() -> None:
    with pytest.raises(ConfigError, match=r"x = 0.0 is outside the allowed range \[1, 2\] s"):
        ParameterSpec("x", 0.0, "s", "X", 1.0, 2.0)


def test_types_units_and_text() -> None:
    assert [s.type_name for s in (RATE, COUNT, MODE, NAMES, FLAG)] == [
        "double",
        "integer",
        "string",
        "string array",
        "bool",
    ]
    assert RATE.text == "A rate [Hz]" and MODE.text == "A mode"


def test_first_refusal_and_names() -> None:
    table = (RATE, COUNT, MODE)
    assert first_refusal(table, {"rate": 5.0, "mode": "b", "other": object()}) is None
    assert first_refusal(table, {"mode": "z", "count": 9}) == ("mode", MODE.check("z"))
    assert first_refusal(table, {"count": 9, "mode": "z"}) == ("count", COUNT.check(9))
    assert set(table_by_name(table)) == {"rate", "count", "mode"}
    with pytest.raises(ConfigError, match="rate given twice"):
        table_by_name((RATE, RATE))


def test_rates_refused() -> None:
    assert rates_refused(1000.0, 1000.0) is None
    reason = rates_refused(100.0, 500.0)
    assert reason is not None and reason.startswith("contact_rate_hz = 500 Hz exceeds")


def test_descriptors_carry_type_unit_range_choices_and_read_only() -> None:
    d = descriptor(RATE)
    assert d.type == ParameterType.PARAMETER_DOUBLE and d.description == "A rate [Hz]"
    assert not d.read_only
    assert (d.floating_point_range[0].from_value, d.floating_point_range[0].to_value) == (
        1.0,
        100.0,
    )
    c = descriptor(COUNT)
    assert c.read_only and (c.integer_range[0].from_value, c.integer_range[0].to_value) == (1, 5)
    assert descriptor(MODE).additional_constraints == "one of: a, b"
    assert descriptor(NAMES).type == ParameterType.PARAMETER_STRING_ARRAY
    assert descriptor(FLAG).type == ParameterType.PARAMETER_BOOL


def test_the_twin_node_declares_its_table(executor: SingleThreadedExecutor) -> None:
    node = TwinNode(
        context=executor.context, parameter_overrides=[Parameter("fidelity", value="catalog")]
    )
    executor.add_node(node)
    for spec in TWIN_PARAMETERS:
        expected = descriptor(spec)
        expected.name = spec.name  # rclpy names the descriptor it keeps
        assert node.describe_parameter(spec.name) == expected, spec.name
        value = node.get_parameter(spec.name).value
        if spec.name != "fidelity":
            assert value == spec.default, spec.name
    assert node.get_parameter("executor").value == "events"  # as in config/twin_node.yaml


def test_a_table_node_refuses_a_start_up_value_and_a_change(
    executor: SingleThreadedExecutor,
) -> None:
    node = TableNode("table", context=executor.context)
    node.declare_specs((RATE, MODE), {"mode": "b"})
    assert node.get_parameter("mode").value == "b"  # the default given wins over the table's
    assert node._float("rate") == 10.0 and node._str("mode") == "b"
    assert node._value("rate", {"rate": 20.0}) == 20.0
    refused = node.refuse_changes((RATE, MODE), [Parameter("mode", value="c")])
    assert refused is not None and not refused.successful and "not one of" in refused.reason
    assert node.refuse_changes((RATE, MODE), [Parameter("rate", value=20.0)]) is None
    other = TableNode(
        "other", context=executor.context, parameter_overrides=[Parameter("mode", value="c")]
    )
    with pytest.raises(ParameterRefusedError, match="mode = 'c' is not one of a, b"):
        other.declare_specs((MODE,))
    node.destroy_node()
    other.destroy_node()
