"""Declarative ROS parameter tables of the project's nodes, and their checks (no rclpy here).

A node's parameters are one tuple of :class:`ParameterSpec`: name, default (whose Python type
is the parameter's ROS type), unit, description, bounds or choices, and whether it may change
at run time. The node layer (``ros/node_parameters.py``) turns the table into rclpy
declarations with descriptors; ``config/*.yaml`` is tested against the same table
(``test/ros/test_parameter_tables.py``), and ``docs/nodes.md`` lists it.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from ..errors import ConfigError
from ..params import check_number, limits

#: Python types of parameter values, by the name used in descriptions and docs.
ParameterValue = bool | int | float | str | tuple[str, ...]
TYPE_NAMES: dict[type, str] = {
    bool: "bool",
    int: "integer",
    float: "double",
    str: "string",
    tuple: "string array",
}


@dataclass(frozen=True)
class ParameterSpec:
    """One ROS parameter of a node.

    Attributes:
        name: parameter name (``limits.max_preload``: nested in the YAML file).
        default: default value; its Python type is the parameter's type (``float``: double,
            ``int``: integer, ``str``, ``bool``, ``tuple`` of str: string array).
        unit: unit of the value (``Hz``, ``s``, ``N``, ``-`` for a ratio, ``""`` for none).
        description: what the parameter does, one sentence (without the unit).
        low: smallest accepted value (numbers only), or None for no bound.
        high: largest accepted value (numbers only), or None for no bound.
        choices: the accepted values of a string (or of each item of a string array);
            empty: any.
        run_time: whether it may be changed while the node runs (else read at start-up only).
    """

    name: str
    default: ParameterValue
    unit: str
    description: str
    low: float | None = None
    high: float | None = None
    choices: tuple[str, ...] = ()
    run_time: bool = False

    def __post_init__(self) -> None:
        """Reject a spec whose own default it would refuse."""
        if (reason := self.check(self.default)) is not None:
            raise ConfigError(f"parameter table: {reason}")

    @property
    def kind(self) -> type:
        """Python type of the value: bool, int, float, str or tuple."""
        return type(self.default)

    @property
    def type_name(self) -> str:
        """ROS type of the value as a word: double, integer, string, bool, string array."""
        return TYPE_NAMES[self.kind]

    @property
    def text(self) -> str:
        """Description with the unit and the bounds or choices, as on the node's descriptor."""
        text = self.description
        if self.unit:
            text += f" [{self.unit}]"
        return text

    @property
    def number_limits(self) -> dict[str, Any]:
        """What a number of this parameter is checked against by the package's one number
        check (:func:`~ballscrew_twin.params.check_number`): its unit (``-`` when it has
        none), its bounds (infinite when None), whole numbers for an integer."""
        return limits(
            self.unit or "-",
            -math.inf if self.low is None else self.low,
            math.inf if self.high is None else self.high,
            integer=self.kind is int,
        )

    def check(self, value: object) -> str | None:
        """Why ``value`` is not accepted for this parameter, or None when it is: its type,
        a number by the package's one number check (finite, within :attr:`number_limits`; the
        refusal names the parameter, its unit and range), a string by its choices."""
        if self.kind is float and type(value) is int:
            value = float(value)
        if isinstance(self.default, tuple) and isinstance(value, list):
            value = tuple(value)
        if type(value) is not self.kind:
            return (
                f"{self.name} = {value!r} is a {type(value).__name__}, expected a {self.type_name}"
            )
        if isinstance(value, int | float) and not isinstance(value, bool):
            try:
                check_number(value, self.number_limits, self.name, text=False)
            except ConfigError as err:
                return str(err)
        if self.choices:
            items = value if isinstance(value, tuple) else (value,)
            for item in items:
                if item not in self.choices:
                    return f"{self.name} = {item!r} is not one of {', '.join(self.choices)}"
        return None


def table_by_name(table: Iterable[ParameterSpec]) -> dict[str, ParameterSpec]:
    """The specs of ``table`` by name; a name given twice is an error."""
    specs: dict[str, ParameterSpec] = {}
    for spec in table:
        if spec.name in specs:
            raise ConfigError(f"parameter table: {spec.name} given twice")
        specs[spec.name] = spec
    return specs


def first_refusal(
    table: Sequence[ParameterSpec], values: Mapping[str, object]
) -> tuple[str, str] | None:
    """The first of ``values`` (name -> value) that ``table`` refuses, as (name, reason), or
    None when every one is accepted; names not in the table are not looked at."""
    specs = table_by_name(table)
    for name, value in values.items():
        if name in specs and (reason := specs[name].check(value)) is not None:
            return name, reason
    return None
