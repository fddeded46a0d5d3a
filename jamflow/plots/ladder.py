"""The pressure-ladder collapse figure (docs/guide/precision.md): the excess contact number Delta z and the shear
modulus G of jammed packings against the pressure p (top row) and, scaled by N, against p N^2
(bottom row), one colour per (d, N), with published power laws drawn as dashed guides and the
crossover p N^2 = 1 (Goodrich, Liu & Nagel, PRL 109, 095704 (2012)) marked."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from jamflow.plots.figure import save_figure


def ladder_figure(path, series: dict, means: dict | None = None, published: dict | None = None,
                  fits: dict | None = None, title: str = "") -> Path:
    """``series``: {label: (N, p, dz, G)} arrays of one ensemble (p > 0; non-positive dz or G are
    left out of the log axes), drawn as faint points; ``means``: {label: (N, p, <dz>, <G>)} the
    ensemble means at each pressure, drawn as lines; ``published``: {"dz": exponent, "G": exponent} drawn dashed through
    the geometric mean of the points with p N^2 >= 10; ``fits``: {(label, "dz" | "G"): (exponent,
    error)} written in the legend."""
    fig = Figure(figsize=(11, 8.5), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(2, 2, squeeze=False)
    names = {"dz": "Delta z", "G": "G"}
    for col, key in enumerate(("dz", "G")):
        for k, (label, (n, p, dz, g)) in enumerate(series.items()):
            y = dz if key == "dz" else g
            good = np.isfinite(y) & (y > 0) & (p > 0)
            fit = (fits or {}).get((label, key))
            text = label if fit is None else f"{label}: slope {fit[0]:.3f} +- {fit[1]:.3f}"
            axes[0, col].plot(p[good], y[good], "o", ms=2.5, alpha=0.5, color=f"C{k}", label=text)
            axes[1, col].plot(p[good] * n[good] ** 2, n[good] * y[good], "o", ms=2.5, alpha=0.5, color=f"C{k}",
                              label=label)
            if means and label in means:
                mn, mp, mdz, mg = means[label]
                m = mdz if key == "dz" else mg
                ok = np.isfinite(m) & (m > 0)
                axes[0, col].plot(mp[ok], m[ok], "-", color=f"C{k}", lw=1.5)
                axes[1, col].plot(mp[ok] * mn[ok] ** 2, mn[ok] * m[ok], "-", color=f"C{k}", lw=1.5,
                                  label=f"{label}: ensemble mean")
        slope = (published or {}).get(key)
        if slope is not None:
            for row in (0, 1):
                xs, ys = [], []
                for n, p, dz, g in series.values():
                    y = dz if key == "dz" else g
                    good = np.isfinite(y) & (y > 0) & (p * n**2 >= 10)
                    xs.append(p[good] * (n[good] ** 2 if row else 1))
                    ys.append(y[good] * (n[good] if row else 1))
                x, y = np.concatenate(xs), np.concatenate(ys)
                if len(x):
                    x0, y0 = np.exp(np.mean(np.log(x))), np.exp(np.mean(np.log(y)))
                    grid = np.geomspace(x.min(), x.max(), 20)
                    axes[row, col].plot(grid, y0 * (grid / x0) ** slope, "k--", lw=1,
                                        label=f"published: {names[key]} ~ p^{slope:g}")
        axes[1, col].axvline(1.0, color="grey", lw=0.8, ls=":", label="p N^2 = 1")
        axes[0, col].set(xscale="log", yscale="log", xlabel="p", ylabel=names[key])
        axes[1, col].set(xscale="log", yscale="log", xlabel="p N^2", ylabel=f"N {names[key]}")
        for row in (0, 1):
            axes[row, col].legend(fontsize=7)
    fig.suptitle(title)
    return save_figure(fig, path)
