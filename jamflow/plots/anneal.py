"""Figure of particle-shape annealing against isotropic compression (chapter section 2.3.3,
Figure 2.18): the mean contact number <z> of the non-floaters and phi_J against the aspect ratio
alpha, one curve per protocol, with the isostatic values 4 (disks) and 6 (ellipses) dotted."""

from __future__ import annotations

from pathlib import Path

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from jamflow.plots.figure import save_figure

STYLES = {"compression": dict(ls="--", marker="o"), "anneal 0.05": dict(ls="-", marker=None),
          "anneal 0.005": dict(ls="none", marker="D", ms=4)}  # the chapter's line styles


def anneal_figure(path, series: dict, title: str = "") -> Path:
    """``series``: {protocol label: (alpha, <z>, its standard error, phi_J, its standard error)},
    arrays over alpha; labels 'compression', 'anneal 0.05', 'anneal 0.005' get the chapter's styles."""
    fig = Figure(figsize=(10, 4), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, 2)
    for label, (alpha, z, z_err, phi, phi_err) in series.items():
        style = STYLES.get(label, dict(ls=":", marker="s"))
        axes[0].errorbar(alpha, z, yerr=z_err, capsize=2, label=label, **style)
        axes[1].errorbar(alpha, phi, yerr=phi_err, capsize=2, label=label, **style)
    axes[0].set_ylabel(r"$\langle z \rangle$ (non-floaters)")
    for isostatic in (4, 6):
        axes[0].axhline(isostatic, ls=":", color="k", lw=0.8)
    axes[1].set_ylabel(r"$\phi_J$")
    for ax in axes:
        ax.set_xlabel(r"aspect ratio $\alpha$")
        ax.legend(fontsize=8)
    fig.suptitle(title)
    return save_figure(fig, path)
