"""Writing a figure to a PNG file."""

from __future__ import annotations

from pathlib import Path

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ..errors import BallscrewTwinError


def save_png(fig: Figure, path: str | Path, dpi: int = 110) -> Path:
    """Render ``fig`` with the Agg canvas into ``path`` (its folder created).

    Raises:
        BallscrewTwinError: the file cannot be written (one line naming it).
    """
    file = Path(path)
    FigureCanvasAgg(fig)
    try:
        file.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(file, dpi=dpi)
    except OSError as err:
        raise BallscrewTwinError(f"{file}: cannot write plot ({err.strerror})") from err
    return file
