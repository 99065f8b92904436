"""Tests of :mod:`ballscrew_twin.params`: the paper YAML loads; bad files are rejected with a
:class:`ConfigError` naming the field and the file."""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
import yaml

from ballscrew_twin.errors import ConfigError, SolverError
from ballscrew_twin.models.base import OperatingPoint
from ballscrew_twin.models.steady import SteadyStateModel
from ballscrew_twin.params import config_fingerprint, default_config_path, load_config

PAPER = Path(__file__).resolve().parent.parent / "config" / "paper_screw.yaml"
RAW: dict[str, Any] = yaml.safe_load(PAPER.read_text(encoding="utf-8"))


def write(tmp_path: Path, edit: Callable[[dict[str, Any]], None]) -> Path:
    data = copy.deepcopy(RAW)
    edit(data)
    path = tmp_path / "bad_screw.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return path


def rejected(tmp_path: Path, edit: Callable[[dict[str, Any]], None]) -> str:
    """Message, with the file name cut out (tmp_path holds the test name, hence field names).

    Asserts the file is named; the field checks then run on the rest of the message.
    """
    path = write(tmp_path, edit)
    with pytest.raises(ConfigError) as info:
        load_config(path)
    full = str(info.value)
    assert str(path) in full
    return full.replace(str(path), "<file>")


def test_paper_yaml_loads_with_table_values() -> None:
    cfg = load_config(PAPER)
    # The default is the calibrated set made from this file by `ballscrew-twin calibrate`.
    assert default_config_path().resolve() == PAPER.with_name("paper_screw_calibrated.yaml")
    assert cfg.screw.pitch_radius == 8.0e-3
    assert cfg.screw.ball_radius == 1.5875e-3
    assert cfg.screw.balls_per_nut == 25 and isinstance(cfg.screw.balls_per_nut, int)
    assert cfg.materials.ball.young_modulus == 210e9
    assert cfg.lubricant.viscosity_law == "roelands"
    # Derived quantities against hand computation (MODEL_NOTES: ball mass 0.1316 g).
    assert cfg.ball_mass == pytest.approx(0.1316e-3, abs=0.0001e-3)
    assert cfg.composite_roughness == pytest.approx(math.hypot(41.56e-9, 11.56e-9))


def test_unmodified_copy_loads(tmp_path: Path) -> None:
    """The write/read round trip itself is not what makes the other tests fail."""
    cfg = load_config(write(tmp_path, lambda d: None))
    paper = load_config(PAPER)
    assert cfg != paper  # differs in source only
    assert replace(cfg, source=paper.source) == paper


def _set(section: str, key: str, value: Any) -> Callable[[dict[str, Any]], None]:
    def edit(d: dict[str, Any]) -> None:
        d[section][key] = value

    return edit


def test_nan_rejected(tmp_path: Path) -> None:
    msg = rejected(tmp_path, _set("screw", "lead", float("nan")))
    assert "lead" in msg


def test_negative_radius_rejected(tmp_path: Path) -> None:
    msg = rejected(tmp_path, _set("screw", "ball_radius", -1.5875e-3))
    assert "ball_radius" in msg


def test_conformity_half_rejected_naming_field(tmp_path: Path) -> None:
    msg = rejected(tmp_path, _set("screw", "conformity", 0.5))
    assert "conformity" in msg


def test_conformity_half_rejected(tmp_path: Path) -> None:
    """f = 0.5 means r_s = r_b: no clearance, a centred ball already interferes."""
    msg = rejected(tmp_path, _set("screw", "conformity", 0.5))
    assert "screw" in msg


def test_pitch_radius_in_mm_rejected_with_hint(tmp_path: Path) -> None:
    msg = rejected(tmp_path, _set("screw", "pitch_radius", 8))
    assert "pitch_radius" in msg
    assert "milli" in msg and "SI" in msg


def test_modulus_in_gpa_hint(tmp_path: Path) -> None:
    def edit(d: dict[str, Any]) -> None:
        d["materials"]["ball"]["young_modulus"] = 210e18

    msg = rejected(tmp_path, edit)
    assert "young_modulus" in msg


def test_unknown_key_rejected(tmp_path: Path) -> None:
    msg = rejected(tmp_path, _set("lubricant", "viscosity_at_40C", 0.03))
    assert "viscosity_at_40C" in msg


def test_unknown_section_rejected(tmp_path: Path) -> None:
    msg = rejected(tmp_path, lambda d: d.update(thermal={"x": 1}))
    assert "thermal" in msg


def test_missing_section_rejected(tmp_path: Path) -> None:
    msg = rejected(tmp_path, lambda d: d.pop("contact"))
    assert "contact" in msg


def test_missing_field_rejected(tmp_path: Path) -> None:
    msg = rejected(tmp_path, lambda d: d["screw"].pop("lead"))
    assert "lead" in msg


def test_string_exponent_without_sign_accepted(tmp_path: Path) -> None:
    """YAML 1.1 reads 210.0e9 as a string; the loader must accept it as 210e9."""
    assert isinstance(yaml.safe_load("x: 210.0e9")["x"], str)
    path = tmp_path / "s.yaml"
    text = PAPER.read_text(encoding="utf-8").replace(
        "ball:  {young_modulus: 210.0e9", "ball:  {young_modulus: '210.0e9'"
    )
    assert "'210.0e9'" in text
    path.write_text(text, encoding="utf-8")
    assert load_config(path).materials.ball.young_modulus == 210e9


def test_non_numeric_string_rejected(tmp_path: Path) -> None:
    msg = rejected(tmp_path, _set("screw", "lead", "five mm"))
    assert "lead" in msg


def test_bool_rejected_as_number(tmp_path: Path) -> None:
    msg = rejected(tmp_path, _set("screw", "lead", True))
    assert "lead" in msg


def test_bad_viscosity_law_rejected(tmp_path: Path) -> None:
    msg = rejected(tmp_path, _set("lubricant", "viscosity_law", "vogel"))
    assert "viscosity_law" in msg and "vogel" in msg


@pytest.mark.parametrize("law", ["roelands", "exponential", "walther"])
def test_every_viscosity_law_accepted(tmp_path: Path, law: str) -> None:
    cfg = load_config(write(tmp_path, _set("lubricant", "viscosity_law", law)))
    assert cfg.lubricant.viscosity_law == law


def test_non_integer_ball_count_rejected(tmp_path: Path) -> None:
    msg = rejected(tmp_path, _set("screw", "balls_per_nut", 25.5))
    assert "balls_per_nut" in msg


def test_viscosity_rising_with_temperature_rejected(tmp_path: Path) -> None:
    msg = rejected(tmp_path, _set("lubricant", "viscosity_second", 0.2))
    assert "lubricant" in msg


def test_missing_file(tmp_path: Path) -> None:
    path = tmp_path / "nope.yaml"
    with pytest.raises(ConfigError) as info:
        load_config(path)
    assert str(path) in str(info.value)


def test_poisson_ratio_above_half_gets_the_physical_range_not_a_unit_hint(tmp_path: Path) -> None:
    msg = rejected(tmp_path, lambda d: d["materials"]["ball"].update(poisson_ratio=0.6))
    assert "materials.ball.poisson_ratio" in msg and "between 0 and 0.5" in msg
    assert "milli" not in msg


def test_angle_in_degrees_gets_the_degree_hint(tmp_path: Path) -> None:
    msg = rejected(tmp_path, lambda d: d["screw"].update(outer_containment_angle=80.0))
    assert "outer_containment_angle" in msg and "degrees" in msg and "milli" not in msg


def test_nominal_contact_angle_must_match_the_groove(tmp_path: Path) -> None:
    # Independent oracle: the free contact angle from the table values, written out here.
    s = RAW["screw"]
    clearance = 2.0 * s["conformity"] * s["ball_radius"] - s["ball_radius"]
    free = math.acos(s["centre_offset"] / clearance)
    msg = rejected(tmp_path, lambda d: d["screw"].update(nominal_contact_angle=0.2))
    assert "screw.nominal_contact_angle" in msg and f"{math.degrees(free):.4g} deg" in msg
    for offset_deg in (-1.9, 1.9):  # within the documented 2 deg
        path = write(
            tmp_path,
            lambda d, o=offset_deg: d["screw"].update(nominal_contact_angle=free + math.radians(o)),
        )
        load_config(path)
    for offset_deg in (-2.1, 2.1):
        rejected(
            tmp_path,
            lambda d, o=offset_deg: d["screw"].update(nominal_contact_angle=free + math.radians(o)),
        )


#: Values that are not what any field wants: containers, deep nesting, text, specials.
MALFORMED: tuple[Any, ...] = (
    None,
    True,
    "abc",
    "1e999",
    [1.0, 2.0],
    {"value": 1.0},
    {"a": {"b": {"c": {"d": [1]}}}},
    [[[[[[[[[[1]]]]]]]]]],
    1e300,
    -1e300,
    "x" * 5000,
)


def _leaves(data: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Key paths of every node of a parsed YAML tree (sections and fields)."""
    paths = [prefix] if prefix else []
    if isinstance(data, dict):
        for key, value in data.items():
            paths += _leaves(value, (*prefix, key))
    return paths


def _replaced(data: Any, path: tuple[Any, ...], value: Any) -> Any:
    out = copy.deepcopy(data)
    node = out
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    return out


def test_every_malformed_value_gives_one_line_naming_the_file_and_the_field(
    tmp_path: Path,
) -> None:
    """0 tracebacks: each node of the file replaced by each malformed value either loads or
    raises ConfigError, one line, naming the file and the node's key."""
    path = tmp_path / "malformed.yaml"
    checked = 0
    for keys in _leaves(RAW):
        for value in MALFORMED:
            # libyaml's emitter (the same safe representer): the pure-Python one took a third
            # of the test's time
            text = yaml.dump(_replaced(RAW, keys, value), Dumper=yaml.CSafeDumper)
            path.write_text(text, encoding="utf-8")
            try:
                load_config(path)
            except ConfigError as err:
                msg = str(err)
                assert "\n" not in msg and str(path) in msg, (keys, value, msg)
                assert str(keys[-1]) in msg or keys[-1] == "name", (keys, value, msg)
                assert len(msg) < 600, (keys, value, msg)
                checked += 1
    assert checked > 300


@pytest.mark.parametrize(
    "content",
    [
        b"name: caf\xe9\n",  # Latin-1, not UTF-8
        b"a: " + b"[" * 5000 + b"]" * 5000 + b"\n",  # deeper than the parser's recursion
        b"".join(b" " * i + b"k%d:\n" % i for i in range(3000)),  # 3000 nested mappings
        b"name: [1, 2\nscrew: {\n",  # syntax error
        b"\x00\x01\x02",
        b"- 1\n- 2\n",  # a list at the top
        b"",
    ],
    ids=["latin1", "deep-lists", "deep-maps", "syntax", "binary", "list", "empty"],
)
def test_unparseable_files_give_one_line_naming_the_file(tmp_path: Path, content: bytes) -> None:
    path = tmp_path / "broken.yaml"
    path.write_bytes(content)
    with pytest.raises(ConfigError) as info:
        load_config(path)
    msg = str(info.value)
    assert "\n" not in msg and str(path) in msg and len(msg) < 400


@pytest.mark.parametrize(
    ("field", "degrees"),
    [
        ("outer_containment_angle", 46.0),
        ("outer_containment_angle", 55.0),
        ("inner_containment_angle", 44.0),
        ("inner_containment_angle", 35.0),
    ],
)
def test_a_containment_window_that_clips_the_loaded_contacts_is_refused(
    tmp_path: Path, field: str, degrees: float
) -> None:
    """Within 15 deg of the free contact angle (45 deg) the window would clip the loaded
    contacts: refused naming the parameter and the bound, not left to the solver."""
    msg = rejected(tmp_path, lambda d: d["screw"].update({field: math.radians(degrees)}))
    assert f"screw.{field}" in msg and "free contact angle 44.97 deg" in msg
    assert ("<= 0.52299" if field.startswith("inner") else ">= 1.04659") in msg


def test_the_refused_containment_window_is_one_the_steady_solver_cannot_solve() -> None:
    """The oracle behind the rule: with the window of 46-80 deg (what the check refuses) the
    steady model finds no equilibrium at a point of the envelope; with 10-80 deg it does."""
    config = load_config(None)
    op = OperatingPoint(screw_speed=1.0, temperature=233.15, preload=500.0)
    clipped = replace(
        config,
        screw=replace(config.screw, inner_containment_angle=math.radians(46.0)),
    )
    with pytest.raises(SolverError):
        SteadyStateModel(clipped, mode="symmetric").solve(op)
    assert SteadyStateModel(config, mode="symmetric").solve(op).output.drag_torque > 0.0


def test_the_fingerprint_names_the_physical_parameters_only() -> None:
    import hashlib

    paper = load_config(None)
    # oracle: the digest of the parameter set's repr without its name and source
    plain = replace(paper, name="", source="")
    assert config_fingerprint(paper) == hashlib.sha256(repr(plain).encode()).hexdigest()
    assert config_fingerprint(replace(paper, name="renamed", source="elsewhere.yaml")) == (
        config_fingerprint(paper)
    )
    lighter = replace(paper, screw=replace(paper.screw, ball_radius=paper.screw.ball_radius * 0.99))
    assert config_fingerprint(lighter) != config_fingerprint(paper)
    lying = replace(paper, screw=replace(paper.screw, orientation="horizontal"))
    assert config_fingerprint(lying) != config_fingerprint(paper)
    assert config_fingerprint(lying, any_orientation=True) == config_fingerprint(
        paper, any_orientation=True
    )
