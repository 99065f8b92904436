"""A node's parameter table (``ros/parameters.py``) declared on rclpy, and read back.

:class:`TableNode` is the base of the twin node and the health node: it declares the specs
with descriptors (type, description with unit, range, read-only), refuses a start-up value the
table refuses (a string outside its choices: rclpy checks ranges, not choices), checks
run-time changes against the same table, and reads values back by type.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

from rcl_interfaces.msg import (
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    ParameterType,
    SetParametersResult,
)
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.parameter import Parameter

from .parameters import ParameterSpec, ParameterValue, first_refusal

#: ROS parameter type of each Python type of default.
ROS_TYPES: dict[type, int] = {
    bool: ParameterType.PARAMETER_BOOL,
    int: ParameterType.PARAMETER_INTEGER,
    float: ParameterType.PARAMETER_DOUBLE,
    str: ParameterType.PARAMETER_STRING,
    tuple: ParameterType.PARAMETER_STRING_ARRAY,
}


class ParameterRefusedError(ParameterException, ValueError):
    """A parameter value the node's table refuses (rclpy's ParameterException; a ValueError
    like the other bad start-up values)."""

    def __init__(self, name: str, reason: str) -> None:
        super().__init__(reason, [name])


def descriptor(spec: ParameterSpec) -> ParameterDescriptor:
    """The rclpy descriptor of ``spec``: type, description with unit, range, choices,
    read-only unless changeable at run time."""
    d = ParameterDescriptor(
        type=ROS_TYPES[spec.kind],
        description=spec.text,
        read_only=not spec.run_time,
        additional_constraints=f"one of: {', '.join(spec.choices)}" if spec.choices else "",
    )
    if spec.kind is float and spec.low is not None and spec.high is not None:
        d.floating_point_range = [
            FloatingPointRange(from_value=spec.low, to_value=spec.high, step=0.0)
        ]
    if spec.kind is int and spec.low is not None and spec.high is not None:
        d.integer_range = [IntegerRange(from_value=int(spec.low), to_value=int(spec.high), step=1)]
    return d


class TableNode(Node):
    """An rclpy node whose parameters come from tables of :class:`ParameterSpec`."""

    def declare_specs(
        self,
        specs: Iterable[ParameterSpec],
        defaults: Mapping[str, ParameterValue] | None = None,
    ) -> None:
        """Declare ``specs`` (``defaults`` overrides the table's default by name), then check
        the values they took (from overrides or a params file) against the specs.

        Raises:
            ParameterRefusedError: a value the table refuses.
        """
        specs = tuple(specs)
        defaults = defaults or {}
        for spec in specs:
            default = defaults.get(spec.name, spec.default)
            value = list(default) if isinstance(default, tuple) else default
            self.declare_parameter(spec.name, value, descriptor(spec))
        values = {spec.name: self.get_parameter(spec.name).value for spec in specs}
        if (refusal := first_refusal(specs, values)) is not None:
            raise ParameterRefusedError(*refusal)

    @staticmethod
    def refuse_changes(
        specs: tuple[ParameterSpec, ...], params: list[Parameter]
    ) -> SetParametersResult | None:
        """A refusal of the run-time changes ``params`` the table refuses, or None."""
        refusal = first_refusal(specs, {p.name: p.value for p in params})
        if refusal is None:
            return None
        return SetParametersResult(successful=False, reason=refusal[1])

    def _float(self, name: str) -> float:
        """Value of a double parameter."""
        return float(self.get_parameter(name).value)

    def _int(self, name: str) -> int:
        """Value of an integer parameter."""
        return int(self.get_parameter(name).value)

    def _str(self, name: str) -> str:
        """Value of a string parameter."""
        return str(self.get_parameter(name).value)

    def _value(self, name: str, changes: Mapping[str, Any]) -> Any:
        """Value of a parameter after a batch of ``changes`` (name -> new value)."""
        return changes[name] if name in changes else self.get_parameter(name).value
