"""Figures of quasistatic shear (chapter section 2.2), drawn with matplotlib's Agg canvas and
written atomically: a shear path (phi_J(gamma) with the contact changes marked, Figure 2.6;
the shear stress Sigma = -P_xy and Sigma / P along it) and the map of geometric families
(phi_J(gamma) of every family, Figure 2.7)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import NullFormatter, ScalarFormatter

from jamflow.plots.figure import save_figure

MAX_LABELS = 12


def shear_path_figure(path, columns: dict, title: str = "") -> Path:
    """Three panels against gamma: phi_J, Sigma = -P_xy, Sigma / P; steps where the contact
    network changed are marked (red), with the numbers of contacts removed/added when there
    are at most MAX_LABELS of them (in rows along the top of the phi_J panel, ``_step_labels``)."""
    fig = Figure(figsize=(7, 8), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(3, 1, sharex=True)
    g, changed = columns["gamma"], columns["changed"].astype(bool)
    panels = ((columns["phi_j"], r"$\phi_J$"), (columns["shear_stress"], r"$\Sigma = -P_{xy}$"),
              (columns["shear_stress"] / columns["pressure"], r"$\Sigma / P$"))
    for ax, (y, label) in zip(axes, panels):
        ax.plot(g, y, ".-", ms=2, lw=0.8, color="k")
        ax.plot(g[changed], y[changed], "o", ms=5, mfc="none", color="tab:red")
        for x in g[changed]:
            ax.axvline(x, color="tab:red", lw=0.5, alpha=0.4)
        ax.set_ylabel(label)
    axes[-1].set_xlabel(r"shear strain $\gamma$")
    axes[0].set_title(title or f"{len(g) - 1} steps, contact network changed at {int(changed.sum())} "
                               "(red: contacts removed/added)")
    if 0 < changed.sum() <= MAX_LABELS:
        steps = np.flatnonzero(changed)
        _step_labels(fig, axes[0], g[steps], [f"-{columns['n_removed'][k]}/+{columns['n_added'][k]}" for k in steps])
    return save_figure(fig, path)


def _step_labels(fig, ax, xs, texts, fontsize: float = 7, pad: float = 3.0) -> None:
    """Write ``texts`` above the strains ``xs`` in rows along the top of ``ax``: each label is
    centred on its step, moved inside the axes where it would leave them, and put in the first
    row where it keeps ``pad`` pixels from its left neighbour, so no two overlap; the y range
    grows to leave the rows above the data, and a thin line joins each label to its step."""
    fig.canvas.draw()  # the layout: the axes' size in pixels and the labels' widths
    renderer, frame = fig.canvas.get_renderer(), ax.get_window_extent()
    ends, placed = [], []  # right edge (pixels) of the last label of each row; (x, text, left, row)
    height = 0.0
    for x, text in sorted(zip(xs, texts)):
        probe = ax.text(0, 0, text, fontsize=fontsize, transform=None)
        extent = probe.get_window_extent(renderer)
        probe.remove()
        height = max(height, extent.height)
        centre = ax.transData.transform((x, 0.0))[0]
        left = min(max(centre - extent.width / 2, frame.x0 + pad), frame.x1 - pad - extent.width)
        row = next((r for r, end in enumerate(ends) if left >= end + pad), len(ends))
        ends[row:row + 1] = [left + extent.width]
        placed.append((x, text, left, row))
    step = (height + pad) / frame.height  # one row, in axes fraction
    band = len(ends) * step + pad / frame.height
    low, high = ax.get_ylim()
    ax.set_ylim(low, low + (high - low) / (1.0 - band))
    for x, text, left, row in placed:
        ax.annotate(text, xy=(x, 1.0 - band), xycoords=("data", "axes fraction"),
                    xytext=((left - frame.x0) / frame.width, 1.0 - pad / frame.height - row * step),
                    textcoords="axes fraction", ha="left", va="top", fontsize=fontsize, color="tab:red",
                    bbox=dict(fc="white", ec="none", pad=0.3), zorder=3 + row,  # over the lines of the rows above
                    arrowprops=dict(arrowstyle="-", color="tab:red", lw=0.4, alpha=0.5, shrinkA=0, shrinkB=0))


def families_figure(path, families, mirror_of=None, convergence=(), richness=None, title: str = "",
                    well_sampled: int = 2) -> Path:
    """(a) phi_J(gamma) of every family (Figure 2.7), the dashed line at gamma = 1/2; families met
    by >= ``well_sampled`` sampled paths in colour, the others thin grey; (b) the well-sampled
    families met in [0, 1/2] (black) with the mirror images gamma -> 1 - gamma of those met in
    [1/2, 1] (red, dashed), when the sampling covers both halves; (c) distinct families against
    the number of starts per grid point."""
    fig = Figure(figsize=(12, 8), layout="constrained")
    FigureCanvasAgg(fig)
    grid = fig.add_gridspec(2, 2)
    chart, half, count = fig.add_subplot(grid[0, :]), fig.add_subplot(grid[1, 0]), fig.add_subplot(grid[1, 1])
    seen = families.sightings()
    for f in range(families.count):
        strong = seen[f] >= well_sampled
        for g, phi in _runs(*families.curve(f)[:2], families.step):
            chart.plot(g, phi, lw=1.1 if strong else 0.4, color=f"C{f % 10}" if strong else "0.75",
                       zorder=2 if strong else 1)
            if not strong:
                continue
            if g.min() <= 0.5 + 1e-9:
                half.plot(g, phi, lw=0.9, color="k")
            if mirror_of is not None and g.max() >= 0.5 - 1e-9:
                half.plot(1.0 - g, phi, lw=0.9, ls="--", color="tab:red")
    chart.axvline(0.5, ls="--", color="0.4", lw=1)
    chart.set(xlabel=r"$\gamma$", ylabel=r"$\phi_J$", title=title or f"(a) {families.count} geometric families")
    half.set(xlim=(-0.01, 0.51), xlabel=r"$\gamma$", ylabel=r"$\phi_J$",
             title=f"(b) met by >= {well_sampled} paths: in [0, 1/2] (black), mirrored from [1/2, 1] (red)")
    if convergence:
        k, half_count, all_count = np.array(convergence).T
        count.plot(k, all_count, "o-", color="k", label="families met at any strain")
        count.plot(k, half_count, "s--", color="0.4", label="families met in [0, 1/2]")
        if richness is not None:
            count.axhline(richness["chao1"], ls=":", color="tab:blue",
                          label=f"Chao1 estimate of all: {richness['chao1']:.0f}")
        count.set(xscale="log", yscale="log", xlabel="random starts per grid point", ylabel="distinct families",
                  title="(c) convergence with the number of starts")
        for axis in (count.xaxis, count.yaxis):
            axis.set_major_formatter(ScalarFormatter())
            axis.set_minor_formatter(NullFormatter())
        count.legend(fontsize=8)
    return save_figure(fig, path)


def _runs(gamma, phi, step):
    """Split a family's curve where strains were skipped (breaks of the solid line)."""
    cut = np.flatnonzero(np.diff(gamma) > 1.5 * step) + 1
    return [(g, p) for g, p in zip(np.split(gamma, cut), np.split(phi, cut))]


def richness_figure(path, panels) -> Path:
    """One panel per sampling, ``panels`` = [(title, rows of analysis.families.by_starts)]:
    distinct families found against the random starts per grid point K (all, and in the half
    the row's ``half`` counts), with the Chao1 and jackknife estimates of all and their standard
    errors; the y axis ends 30 % above the largest-K estimates (small-K error bars clipped)."""
    fig = Figure(figsize=(5.5 * len(panels), 4.5), layout="constrained")
    FigureCanvasAgg(fig)
    for ax, (title, rows) in zip(np.atleast_1d(fig.subplots(1, len(panels))), panels):
        k = np.array([r["starts"] for r in rows])
        ax.plot(k, [r["total"] for r in rows], "o-", color="k", label="found, any strain")
        ax.plot(k, [r["half"] for r in rows], "s--", color="0.5", label="found, first half")
        for key, label, colour in (("chao1", "Chao1", "tab:blue"), ("jack1", "jackknife 1", "tab:orange"),
                                   ("jack2", "jackknife 2", "tab:green")):
            ax.errorbar(k, [r[key] for r in rows], yerr=[r[f"{key}_se"] for r in rows], fmt="^:", ms=4,
                        capsize=2, color=colour, label=f"{label} +- s.e.")
        last = rows[-1]  # the small-K error bars are clipped: the axis follows the largest K
        top = 1.3 * max(last[key] + last[f"{key}_se"] for key in ("chao1", "jack1", "jack2"))
        ax.set(xlabel="random starts per grid point K", ylabel="geometric families", title=title, ylim=(0, top))
        ax.legend(fontsize=8)
    return save_figure(fig, path)
