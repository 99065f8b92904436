"""Scene files: profiles against hand-computed values, validation messages, shipped examples."""

import math
from pathlib import Path

import pytest
import yaml

from ballscrew_twin.errors import ConfigError
from ballscrew_twin.params import default_config_path
from ballscrew_twin.scene import load_scene, scene_from_mapping

SCENES = sorted((default_config_path().parent / "scenes").glob("*.yaml"))


def base(**changes: object) -> dict:
    data: dict = {
        "name": "t",
        "duration": 2.0,
        "output_rate": 10.0,
        "commands": {"speed": 10.0, "temperature": 293.15, "preload": 1000.0},
        "tolerance": {"drag_torque": 0.01},
    }
    data.update(changes)
    return data


@pytest.mark.parametrize("path", SCENES, ids=[p.stem for p in SCENES])
def test_shipped_scenes_load(path: Path) -> None:
    scene = load_scene(path)
    assert scene.duration > 0.0
    assert len(scene.output_times()) >= 2
    if scene.config is not None:
        assert scene.config.is_file()


def test_at_least_one_scene_of_each_kind_is_shipped() -> None:
    scenes = [load_scene(p) for p in SCENES]
    assert any(s.has_faults for s in scenes)
    assert any(s.wants("per_sphere") for s in scenes)
    assert any(s.orientation == "horizontal" for s in scenes)


def test_piecewise_linear_plus_smooth_step_by_hand() -> None:
    scene = scene_from_mapping(
        base(
            commands={
                "speed": {"points": [[0.0, 0.0], [1.0, 100.0]]},
                "temperature": 300.0,
                "preload": {
                    "points": [[0.0, 500.0]],
                    "steps": [{"time": 0.5, "duration": 1.0, "change": 1000.0}],
                },
            }
        )
    )
    assert scene.speed(0.25) == pytest.approx(25.0)
    assert scene.speed(1.7) == pytest.approx(100.0)  # held after the last breakpoint
    # cubic smooth step 3 s^2 - 2 s^3 at s = 0.5 is 0.5, at s = 0.25 is 0.15625
    assert scene.preload(1.0) == pytest.approx(500.0 + 500.0)
    assert scene.preload(0.75) == pytest.approx(500.0 + 156.25)
    assert scene.preload(0.2) == 500.0
    assert scene.axial_load(1.0) == 0.0
    op = scene.operating_point(0.5)
    assert (op.screw_speed, op.temperature, op.preload) == pytest.approx((50.0, 300.0, 500.0))
    assert scene.range("speed") == (0.0, 100.0)
    assert scene.range("preload") == pytest.approx((500.0, 1500.0))


def test_speed_range_through_zero_and_output_times() -> None:
    scene = scene_from_mapping(
        base(
            commands={
                "speed": {"points": [[0.0, -50.0], [2.0, 30.0]]},
                "temperature": 300.0,
                "preload": 0.0,
            }
        )
    )
    assert scene.speed_magnitude_range() == (0.0, 50.0)
    times = scene.output_times()
    assert len(times) == 21
    assert times[-1] == pytest.approx(2.0)


@pytest.mark.parametrize(
    ("changes", "words"),
    [
        (
            {"commands": {"speed": 10.0, "temperature": 20.0, "preload": 0.0}},
            ["temperature", "kelvin"],
        ),
        (
            {"commands": {"speed": 3000.0 * 2 * math.pi, "temperature": 300.0, "preload": 0.0}},
            ["speed", "rad/s"],
        ),
        (
            {"commands": {"speed": 10.0, "temperature": 300.0, "preload": float("nan")}},
            ["preload", "finite"],
        ),
        ({"commands": {"speed": 10.0, "temperature": 300.0}}, ["preload", "missing"]),
        (
            {"commands": {"speed": 10.0, "temperature": 300.0, "preload": 0.0, "torque": 1.0}},
            ["torque"],
        ),
        ({"duration": -1.0}, ["duration", "s"]),
        ({"outputs": ["drag", "spheres"]}, ["outputs", "spheres"]),
        ({"tolerance": {"drag_torque": 5}}, ["per cent"]),
        ({"tolerance": {"drag_torque": 0.01, "speed": 0.1}}, ["tolerance", "speed"]),
        ({"outputs": ["per_sphere"]}, ["contact_force", "missing"]),
        ({"orientation": "diagonal"}, ["orientation"]),
        ({"colour": "red"}, ["colour"]),
        (
            {
                "faults": {
                    "spalls": [{"half_groove": "X9", "centre": 0, "width": 0.1, "depth": 1e-6}]
                }
            },
            ["half_groove"],
        ),
    ],
)
def test_bad_fields_are_named(changes: dict, words: list[str]) -> None:
    with pytest.raises(ConfigError) as err:
        scene_from_mapping(base(**changes), "my_scene.yaml")
    message = str(err.value)
    assert "my_scene.yaml" in message
    for word in words:
        assert word in message


def test_breakpoints_must_increase_and_sum_must_stay_in_range() -> None:
    bad_order = {
        "speed": {"points": [[1.0, 0.0], [0.5, 1.0]]},
        "temperature": 300.0,
        "preload": 0.0,
    }
    with pytest.raises(ConfigError, match=r"points\[1\]\[0\].*later"):
        scene_from_mapping(base(commands=bad_order))
    negative = {
        "speed": 1.0,
        "temperature": 300.0,
        "preload": {"points": [[0.0, 100.0]], "steps": [{"time": 1.0, "change": -200.0}]},
    }
    with pytest.raises(ConfigError, match=r"preload.*-100.*t = 1"):
        scene_from_mapping(base(commands=negative))


def test_unreadable_and_corrupt_files(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="cannot read"):
        load_scene(tmp_path / "missing.yaml")
    corrupt = tmp_path / "corrupt.yaml"
    corrupt.write_text("name: [unclosed\n")
    with pytest.raises(ConfigError, match="not valid YAML"):
        load_scene(corrupt)
    good = tmp_path / "good.yaml"
    good.write_text(yaml.safe_dump(base(config="screw.yaml")))
    assert load_scene(good).config == tmp_path / "screw.yaml"
