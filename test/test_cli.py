"""The ``ballscrew-twin`` command line: SI output, unit conversion at the edge, clear errors."""

import json
import math

import pytest

from ballscrew_twin.cli import main


def test_drag_json_is_si_and_converts_rpm_and_celsius(capsys: pytest.CaptureFixture[str]) -> None:
    assert (
        main(["drag", "--preload", "1500", "--speed", "100", "--temperature", "20", "--json"]) == 0
    )
    data = json.loads(capsys.readouterr().out)
    assert data["operating_point"]["screw_speed_rad_s"] == pytest.approx(100 * 2 * math.pi / 60)
    assert data["operating_point"]["temperature_K"] == pytest.approx(293.15)
    assert data["drag_torque_Nm"] > 0.0
    assert {c["half_groove"] for c in data["contacts"]} == {"S1", "S2", "N1", "N2"}
    total = sum(data["breakdown_Nm"].values())
    assert total == pytest.approx(data["drag_torque_Nm"], rel=1e-9)


def test_drag_text_report_for_catalogue(capsys: pytest.CaptureFixture[str]) -> None:
    assert (
        main(
            [
                "drag",
                "--preload",
                "3000",
                "--speed",
                "100",
                "--temperature",
                "20",
                "--model",
                "zhou",
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert "drag torque" in out and "0.0383" in out


@pytest.mark.parametrize(
    ("args", "word"),
    [
        (["--preload", "-1", "--speed", "100", "--temperature", "20"], "preload"),
        (["--preload", "nan", "--speed", "100", "--temperature", "20"], "preload"),
        (["--preload", "10", "--speed", "100", "--temperature", "-300"], "temperature"),
        (
            [
                "--preload",
                "10",
                "--speed",
                "1",
                "--temperature",
                "20",
                "--config",
                "/nonexistent.yaml",
            ],
            "nonexistent",
        ),
    ],
)
def test_bad_input_gives_named_error(
    capsys: pytest.CaptureFixture[str], args: list[str], word: str
) -> None:
    assert main(["drag", *args]) == 2
    err = capsys.readouterr().err
    assert "error" in err and word in err
