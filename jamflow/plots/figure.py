"""Writing a figure: PNG, SVG or PDF by the file's suffix, written atomically
(``support.files.atomic_path``), so an interrupted run leaves the last good picture and no
partial file."""

from __future__ import annotations

from pathlib import Path

from jamflow.support.files import atomic_path

FORMATS = {".png": "png", ".svg": "svg", ".pdf": "pdf"}  # a figure file's suffix -> what matplotlib writes


def figure_format(path) -> str:
    """The format the suffix of ``path`` asks for; a ValueError (before any work) for another suffix."""
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        raise ValueError(f"cannot draw {path}: a figure is written as {', '.join(FORMATS)} (from its suffix), not "
                         f"{suffix or 'a file without a suffix'}; name it e.g. {Path(path).with_suffix('.png').name}")
    return FORMATS[suffix]


def save_figure(fig, path, dpi: int = 120, tight: bool = False) -> Path:
    """Write ``fig`` (a matplotlib Figure) to ``path`` atomically, in the format its suffix asks
    for (PNG, SVG or PDF); returns the path. ``tight``: lay it out with ``tight_layout`` on an Agg
    canvas first."""
    from matplotlib.backends.backend_agg import (
        FigureCanvasAgg,  # here: commands check a figure's name without matplotlib
    )

    fmt = figure_format(path)
    if tight:
        FigureCanvasAgg(fig)
        fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format=fmt, dpi=dpi)
    return Path(path)
