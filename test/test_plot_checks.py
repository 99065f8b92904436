"""The unit check of saved figures (conftest ``saved_figures``) reports what lacks a unit."""

from __future__ import annotations

from pathlib import Path

from conftest import SavedFigures
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure


def test_labels_without_units_are_reported(tmp_path: Path, saved_figures: SavedFigures) -> None:
    fig = Figure()
    good, bad = fig.subplots(2, 1, sharex=True)
    good.plot([0, 1], [0, 1])
    good.set_ylabel("torque [mN m]")
    bad.plot([0, 1], [1, 0])
    bad.set_ylabel("torque")
    bad.set_xlabel("time [s]")
    image = bad.imshow([[0.0, 1.0]])
    fig.colorbar(image, ax=bad, label="speed")
    fig.add_subplot(3, 1, 3)  # nothing drawn: not checked
    FigureCanvasAgg(fig)
    fig.savefig(tmp_path / "f.png")
    problems = saved_figures.missing_units()
    assert len(problems) == 2, problems
    assert "y label 'torque'" in problems[0]
    assert "colour bar label 'speed'" in problems[1]
