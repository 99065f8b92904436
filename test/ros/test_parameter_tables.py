"""The parameter tables of the nodes and the files in ``config/`` cannot disagree: every key of
a YAML file is a parameter of its node's table with the same default (and type), every
parameter of the table is in the file (or shown there as a comment), and the ``(rt)`` marks
of the file are the parameters that may change at run time."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest
import yaml

from ballscrew_twin.ros.health_parameters import HEALTH_PARAMETERS
from ballscrew_twin.ros.parameters import ParameterSpec, table_by_name
from ballscrew_twin.ros.twin_parameters import INPUT_PRESETS, TWIN_PARAMETERS

CONFIG = Path(__file__).resolve().parents[2] / "config"
#: Parameters whose YAML value differs from the table's default on purpose, and why
#: (none today: add an entry here, with its reason, rather than change the test).
DELIBERATE: dict[tuple[str, str], str] = {}
#: A parameter shown as a comment: ``# name: value  # ...``.
COMMENTED = re.compile(r"^\s*#\s+(\w+):\s+(\S+)\s+#")
#: A parameter line marked as changeable at run time: ``name: value  # ... (rt) ...``.
RUN_TIME_MARK = re.compile(r"^\s*(\w+):[^#]*#.*\(rt\)")

FILES = [("twin_node.yaml", TWIN_PARAMETERS), ("health_node.yaml", HEALTH_PARAMETERS)]


def _flatten(mapping: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"limits": {"max_preload": 1.0}}`` as ``{"limits.max_preload": 1.0}``."""
    flat: dict[str, Any] = {}
    for key, value in mapping.items():
        if isinstance(value, dict):
            flat.update(_flatten(value, f"{prefix}{key}."))
        else:
            flat[f"{prefix}{key}"] = value
    return flat


def _parameters(name: str) -> dict[str, Any]:
    """The parameters of the file ``config/name``, nested names joined with dots."""
    data = yaml.safe_load((CONFIG / name).read_text(encoding="utf-8"))
    (params,) = (v["ros__parameters"] for v in data.values())
    return _flatten(params)


def _commented(name: str, table: dict[str, ParameterSpec]) -> dict[str, Any]:
    """Parameters of the table shown as comments in ``config/name``, with their values."""
    found: dict[str, Any] = {}
    for line in (CONFIG / name).read_text(encoding="utf-8").splitlines():
        match = COMMENTED.match(line)
        if match and match[1] in table:
            found[match[1]] = yaml.safe_load(match[2])
    return found


def _same(value: Any, default: Any) -> bool:
    """Whether a YAML value is the default, of the same ROS type."""
    if isinstance(default, tuple):
        return isinstance(value, list) and tuple(value) == default
    return type(value) is type(default) and value == default


@pytest.mark.parametrize(("file", "table"), FILES)
def test_every_yaml_value_is_the_table_default(file: str, table: tuple[ParameterSpec]) -> None:
    specs = table_by_name(table)
    values = _parameters(file)
    assert set(values) <= set(specs), f"{file}: not in the node's table"
    for name, value in values.items():
        spec = specs[name]
        assert spec.check(value) is None, f"{file}: {spec.check(value)}"
        if (file, name) in DELIBERATE:
            assert not _same(value, spec.default), f"{file}: {name} no longer differs"
            continue
        assert _same(value, spec.default), (
            f"{file}: {name} = {value!r}, the node's default is {spec.default!r}"
        )


@pytest.mark.parametrize(("file", "table"), FILES)
def test_every_table_parameter_is_in_the_yaml(file: str, table: tuple[ParameterSpec]) -> None:
    specs = table_by_name(table)
    shown = set(_parameters(file)) | set(_commented(file, specs))
    assert shown == set(specs), f"{file}: missing {sorted(set(specs) - shown)}"


def test_commented_inputs_of_the_twin_are_the_commands_preset() -> None:
    commented = _commented("twin_node.yaml", table_by_name(TWIN_PARAMETERS))
    assert commented == INPUT_PRESETS["commands"]
    assert set(INPUT_PRESETS["bench"]) == set(commented)


def test_run_time_marks_of_the_twin_yaml_are_the_run_time_parameters() -> None:
    lines = (CONFIG / "twin_node.yaml").read_text(encoding="utf-8").splitlines()
    marked = {m[1] for line in lines if (m := RUN_TIME_MARK.match(line))}
    assert marked == {spec.name for spec in TWIN_PARAMETERS if spec.run_time}


@pytest.mark.parametrize("table", [TWIN_PARAMETERS, HEALTH_PARAMETERS])
def test_tables_are_well_formed(table: tuple[ParameterSpec]) -> None:
    table_by_name(table)  # no name twice
    for spec in table:
        assert spec.description and not spec.description.endswith(".")
        if spec.kind in (int, float):
            assert spec.unit, f"{spec.name}: a number needs a unit ('-' for a ratio)"
        if spec.low is not None and spec.high is not None:
            assert spec.low < spec.high


def _cell(value: Any) -> str:
    """A default or bound as written in docs/nodes.md."""
    if isinstance(value, bool):
        return f"`{str(value).lower()}`"
    if isinstance(value, float):
        return f"`{value:g}`"
    if isinstance(value, tuple):
        return "`[" + ", ".join(value) + "]`"
    return f'`"{value}"`' if value == "" else f"`{value}`"


def markdown_table(table: tuple[ParameterSpec, ...]) -> str:
    """The parameter table of a node as docs/nodes.md shows it."""
    rows = [
        "| parameter | type | default | unit | accepted | rt | description |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    for spec in table:
        if spec.choices:
            accepted = ", ".join(f"`{c}`" for c in spec.choices)
        elif spec.low is not None and spec.high is not None:
            accepted = f"{spec.low:g} .. {spec.high:g}"
        else:
            accepted = ""
        rows.append(
            f"| `{spec.name}` | {spec.type_name} | {_cell(spec.default)} | {spec.unit} "
            f"| {accepted} | {'rt' if spec.run_time else ''} "
            f"| {spec.description.replace('|', '&#124;')} |"
        )
    return "\n".join(rows) + "\n"


def presets_table() -> str:
    """The input defaults of each ``input_preset`` as docs/nodes.md shows them."""
    rows = ["| parameter | `commands` | `bench` |", "| --- | --- | --- |"]
    commands, bench = INPUT_PRESETS["commands"], INPUT_PRESETS["bench"]
    rows += [f"| `{k}` | {_cell(v)} | {_cell(bench[k])} |" for k, v in commands.items()]
    return "\n".join(rows) + "\n"


def test_docs_show_the_tables() -> None:
    doc = (CONFIG.parent / "docs" / "nodes.md").read_text(encoding="utf-8")
    for name, text in (
        ("TWIN_PARAMETERS", markdown_table(TWIN_PARAMETERS)),
        ("INPUT_PRESETS", presets_table()),
        ("HEALTH_PARAMETERS", markdown_table(HEALTH_PARAMETERS)),
    ):
        assert text in doc, f"docs/nodes.md: the table of {name} is not the code's:\n{text}"
