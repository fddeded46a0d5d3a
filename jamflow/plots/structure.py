"""PNG figures of the structure analysis (matplotlib Agg canvas, written atomically).

Each function takes result objects from ``structure``, ``order`` and ``correlations`` and a
path; r is in units of <sigma^2>^(1/2), k in units of 1/<sigma^2>^(1/2).
"""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np
from matplotlib.colors import Normalize
from matplotlib.figure import Figure
from matplotlib.ticker import NullFormatter

from jamflow.analysis.correlations import BondCorrelationResult, ExponentialFit
from jamflow.analysis.structure import RDFResult, StructureFactorResult
from jamflow.plots.figure import save_figure


def _legend(ax) -> None:
    if ax.get_legend_handles_labels()[1]:
        ax.legend(fontsize=7)


def _semilog(ax, x, y, **style) -> None:
    """Log-y line of the positive values only (a perfect crystal has C(r) = 0 exactly)."""
    y = np.where(np.asarray(y) > 0, y, np.nan)
    if np.any(np.isfinite(y)):
        ax.set_yscale("log")
        ax.plot(x, y, **style)
    else:
        ax.text(0.05, 0.5, f"{style.get('label', 'values')} <= 0 everywhere", transform=ax.transAxes)


def _envelope(ax, fit: ExponentialFit, label: str) -> None:
    if len(fit.r_points):
        ax.semilogy(fit.r_points, fit.y_points, "o", label=f"local maxima ({label})")
    if np.isfinite(fit.xi):
        r = np.linspace(fit.r_points.min(), fit.r_points.max(), 50)
        ax.semilogy(r, fit.amplitude * np.exp(-r / fit.xi), "--",
                    label=f"exp(-r/xi), xi = {fit.xi:.2f} +- {fit.xi_stderr:.2f}")
    elif fit.reason:
        ax.text(0.05, 0.05, f"no fit: {fit.reason}", transform=ax.transAxes)


def plot_rdf(rdf: RDFResult, path, *, r_min: float | None = None, fit: ExponentialFit | None = None,
             title: str = "") -> Path:
    """g(r) (and partials) with the first minimum; right panel: envelope of g - 1 and its fit.
    The y axis reaches above the highest peak of every curve drawn; the total g(r) is drawn on top
    of the partials."""
    fig = Figure(figsize=(10, 4) if fit is not None else (5.5, 4))
    ax, env = fig.subplots(1, 2) if fit is not None else (fig.subplots(), None)
    curves = [rdf.g]
    for a in range(len(rdf.species)):
        for b in range(a, len(rdf.species)):
            ax.plot(rdf.r, rdf.partial[a, b], lw=0.7, alpha=0.8, label=f"g {rdf.species[a]:g}-{rdf.species[b]:g}")
            curves.append(rdf.partial[a, b])
    ax.plot(rdf.r, rdf.g, lw=1.4, color="k", label="g(r), all pairs", zorder=5)
    ax.axhline(1.0, color="0.6", lw=0.5)
    if r_min is not None:
        ax.axvline(r_min, color="tab:red", ls=":", label=f"r_min = {r_min:.2f}")
    r_peak, g_peak = rdf.first_peak(r_min)
    top = max(float(np.nanmax(c, initial=0.0)) for c in curves)
    ax.set_ylim(0, 1.05 * max(top, 1.0))
    ax.set(xlabel="r / <sigma^2>^1/2", ylabel="g(r)",
           title=f"{title} first peak {g_peak:.3g} at {r_peak:.3f} (dr = {rdf.dr:g})")
    _legend(ax)
    if fit is not None:
        _envelope(env, fit, "g - 1")
        env.set(xlabel="r / <sigma^2>^1/2", ylabel="g(r) - 1 maxima")
        _legend(env)
    return save_figure(fig, path, tight=True)


def plot_structure_factor(sk: StructureFactorResult, path, *, title: str = "") -> Path:
    """Shell-averaged S(k) on log-log axes (low-k behaviour visible)."""
    fig = Figure(figsize=(5.5, 4))
    ax = fig.subplots()
    ax.loglog(sk.k, sk.s, ".-", lw=0.7, ms=3)
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.axhline(1.0, color="0.6", lw=0.5)
    ax.set(xlabel="k <sigma^2>^1/2", ylabel="S(k)", title=f"{title} ({sk.n_packings} packing(s))")
    return save_figure(fig, path, tight=True)


def plot_bond_correlations(corr: BondCorrelationResult, path, *, title: str = "") -> Path:
    """|<q6(r) q6*(0)>|, <|q6(r)||q6(0)|> (Figure 2.27) and the maxima of C(r) with the fit (2.28a)."""
    fig = Figure(figsize=(10, 4))
    ax, env = fig.subplots(1, 2)
    _semilog(ax, corr.r, np.abs(corr.complex_corr), label="|<q(r) q*(0)>|")
    _semilog(ax, corr.r, corr.magnitude_corr, label="<|q(r)| |q(0)|>")
    ax.axhline(abs(corr.baseline), color="0.6", ls=":", label=f"all-pairs value {corr.baseline:.3g}")
    ax.set(xlabel="r / <sigma^2>^1/2", ylabel=f"q{corr.l} correlation", title=title)
    _legend(ax)
    _semilog(env, corr.r, corr.c, color="0.7", lw=0.7, label="C(r)")
    _envelope(env, corr.fit, "C")
    env.set(xlabel="r / <sigma^2>^1/2", ylabel="C(r)")
    _legend(env)
    return save_figure(fig, path, tight=True)


def plot_order(labels: Sequence[str], values: dict, path, *, title: str = "") -> Path:
    """The order parameters (``values``: name -> array over the packings ``labels``): one bar
    per parameter at its mean over packings, each packing a dot on it, the spread (s.d.) as an
    error bar."""
    fig = Figure(figsize=(max(4.5, 1.2 * len(values) + 2), 4))
    ax = fig.subplots()
    x = np.arange(len(values))
    for k, column in enumerate(values.values()):
        column = np.asarray(column, float)
        mean = np.nanmean(column)
        spread = np.nanstd(column, ddof=1) if np.sum(np.isfinite(column)) > 1 else 0.0
        ax.bar(k, mean, width=0.6, color=f"C{k}", alpha=0.4, yerr=spread, capsize=4)
        jitter = np.linspace(-0.2, 0.2, len(column)) if len(column) > 1 else np.zeros(1)
        ax.plot(k + jitter, column, "o", color=f"C{k}", ms=4)
        ax.text(k, 1.0, f"{mean:.3f}", ha="center", va="bottom", fontsize=8)
    ax.set_xticks(x, list(values))
    ax.set(ylabel="order parameter", ylim=(-0.02, 1.1),
           title=f"{title}  {len(labels)} packing(s)" + (f": {labels[0]}" if len(labels) == 1 else ""))
    return save_figure(fig, path, tight=True)


def plot_bond_order_map(packing, order, path, *, title: str = "") -> Path:
    """2D snapshot (as Figure 2.23): disks coloured by the phase of psi_6 (hue), shaded by
    |psi_6|; isolated particles grey. ``order`` is a BondOrderResult of ``packing``."""
    from matplotlib.collections import EllipseCollection

    if packing.dim != 2:
        raise ValueError("the bond-order map is drawn for 2D packings only")
    pos = packing.box.wrap(packing.positions)
    psi = order.particle_order[:, 0]
    import matplotlib.cm as cm

    phase = Normalize(-180.0, 180.0)  # arg psi_6 in degrees -> hue, the colour key's norm
    colors = cm.hsv(phase(np.degrees(np.angle(psi))))
    colors[:, 3] = np.clip(np.abs(psi), 0.15, 1.0)
    colors[order.n_neighbours == 0] = (0.6, 0.6, 0.6, 1.0)
    fig = Figure(figsize=(6, 6 * packing.box.lengths[1] / packing.box.lengths[0] + 0.3))
    ax = fig.subplots()
    d = packing.diameters
    ax.add_collection(EllipseCollection(d, d, np.zeros(packing.n), units="xy", offsets=pos,
                                        offset_transform=ax.transData, facecolors=colors, edgecolors="k",
                                        linewidths=0.2))
    corners = packing.box.to_cartesian(np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]], float))
    ax.plot(corners[:, 0], corners[:, 1], "k-", lw=0.5)
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.set_axis_off()
    ax.set_title(f"{title} Q6 global {order.global_order:.2f}, local {order.local_order:.2f}", fontsize=9)
    key = cm.ScalarMappable(norm=phase, cmap="hsv")
    bar = fig.colorbar(key, ax=ax, shrink=0.7, label="arg psi_6 (degrees; hue); opacity |psi_6|; grey: no neighbours")
    bar.set_ticks([-180, -90, 0, 90, 180])
    return save_figure(fig, path, tight=True)
