"""Writing a figure: a PNG written atomically (``support.files.atomic_path``), so an interrupted
run leaves the last good picture and no partial file."""

from __future__ import annotations

from pathlib import Path

from matplotlib.backends.backend_agg import FigureCanvasAgg

from jamflow.support.files import atomic_path


def save_png(fig, path, dpi: int = 120, tight: bool = False) -> Path:
    """Write ``fig`` (a matplotlib Figure) to ``path`` as PNG, atomically; returns the path.
    ``tight``: lay it out with ``tight_layout`` on an Agg canvas first."""
    if tight:
        FigureCanvasAgg(fig)
        fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=dpi)
    return Path(path)
