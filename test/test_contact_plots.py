"""Contact states per sphere (``drag --plot``): the loaded groove of each side, the file, units."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import SavedFigures

from ballscrew_twin.cli import main
from ballscrew_twin.plots.contact_states import loaded_contacts

PNG = b"\x89PNG\r\n\x1a\n"


def test_each_side_shows_its_loaded_half_groove() -> None:
    # sphere 7 (master): S2 and N1 loaded; sphere 9 (master): only the screw side touches;
    # sphere 3 (slave): S1 and N2 loaded. Half grooves 0..3 = S1, S2, N1, N2.
    sphere = np.array([7, 7, 7, 7, 9, 9, 9, 9, 3, 3, 3, 3])
    nut = np.array([0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1])
    half_groove = np.tile(np.arange(4), 3)
    in_contact = np.array([0, 1, 1, 0, 1, 0, 0, 0, 1, 0, 0, 1], dtype=bool)
    force = np.array([0.0, 80.0, 81.0, 0.0, 5.0, 0.0, 0.0, 0.0, 60.0, 0.0, 0.0, 61.0])
    angle = np.linspace(0.7, 0.9, 12)
    film = np.arange(12) * 1e-9
    tallian = np.arange(12) * 0.1
    states = loaded_contacts(sphere, nut, half_groove, in_contact, force, angle, film, tallian)
    # spheres in increasing id: 3 (slave), 7, 9 (master); numbered within their nut
    assert states.nut.tolist() == [1, 0, 0]
    assert states.index.tolist() == [0, 0, 1]
    np.testing.assert_array_equal(states.normal_force[0], [60.0, 61.0])
    np.testing.assert_array_equal(states.normal_force[1], [80.0, 81.0])
    assert states.normal_force[2, 0] == 5.0 and np.isnan(states.normal_force[2, 1])
    np.testing.assert_array_equal(states.contact_angle[1], angle[[1, 2]])
    np.testing.assert_array_equal(states.film_thickness[0], film[[8, 11]])
    np.testing.assert_array_equal(states.tallian[2, :1], tallian[[4]])


@pytest.mark.parametrize("mode", ["symmetric", "full"])
def test_drag_plot_is_written_with_units(
    mode: str, tmp_path: Path, saved_figures: SavedFigures, capsys: pytest.CaptureFixture[str]
) -> None:
    png = tmp_path / "sub" / "contacts.png"
    args = ["--preload", "1500", "--speed", "100", "--temperature", "20", "--mode", mode]
    assert main(["drag", *args, "--plot", str(png)]) == 0
    assert png.read_bytes().startswith(PNG)
    assert saved_figures.paths() == [str(png)]
    assert saved_figures.missing_units() == []
    fig = saved_figures.saved[0][0]
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert labels == [
        "normal force F_n [N]",
        "contact angle [deg]",
        "film thickness h [nm]",
        "Tallian parameter Λ [-]",
    ]
    # both nuts, both sides: 4 lines a panel
    assert all(len(ax.lines) == 4 for ax in fig.axes)
    points = len(fig.axes[0].lines[0].get_xdata())
    assert points == (2 if mode == "symmetric" else 25)
    assert f"wrote {png}" in capsys.readouterr().out


def test_drag_plot_needs_the_steady_model(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    args = ["--preload", "1500", "--speed", "100", "--temperature", "20", "--model", "zhou"]
    assert main(["drag", *args, "--plot", str(tmp_path / "c.png")]) == 2
    assert "--model steady" in capsys.readouterr().err
    assert not (tmp_path / "c.png").exists()
