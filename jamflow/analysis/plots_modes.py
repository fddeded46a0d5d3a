"""Figures of the stability analysis, drawn with matplotlib's Agg canvas and written
atomically: (a) sorted frequencies omega_i vs i / (d N') (seed Figure 2.16a), (b) D(omega)
averaged over packings (Figure 2.16b), (c) distribution of z_i (Figure 2.20), (d) the energy
change along the lowest nontrivial mode, |Delta V(delta)| (Figure 2.15c, log-log)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ..io import atomic_path


def modes_figure(path, spectra, dos=None, contacts=(), stabilities=()) -> Path:
    """Write the four-panel PNG ``path``; ``dos`` may be None (incomplete spectra)."""
    fig = Figure(figsize=(10, 8), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(2, 2)
    _sorted_frequencies(axes[0, 0], spectra)
    _density_of_states(axes[0, 1], dos)
    _z_distribution(axes[1, 0], contacts)
    _energy_profiles(axes[1, 1], stabilities)
    fig.suptitle(f"{len(spectra)} packing(s), e_min = {spectra[0].e_min:g}" if spectra else "")
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=120)
    return Path(path)


def _sorted_frequencies(ax, spectra):
    for s in spectra:
        omega = s.frequencies
        ax.plot(np.arange(1, len(omega) + 1) / s.n_dof, omega, lw=0.8, alpha=0.6)
    ax.set(xlabel="i / (d N')", ylabel=r"$\omega_i$", title="(a) sorted frequencies")


def _density_of_states(ax, dos):
    ax.set(xlabel=r"$\omega$", ylabel=r"$D(\omega)$ per packing", title="(b) density of states")
    if dos is None:
        ax.text(0.5, 0.5, "needs complete spectra", ha="center", transform=ax.transAxes)
        return
    ax.stairs(dos.density, dos.edges, fill=True, alpha=0.5)
    ax.text(0.98, 0.95, f"{dos.n_packings} packing(s)", ha="right", va="top", transform=ax.transAxes)


def _z_distribution(ax, contacts):
    ax.set(xlabel="$z_i$", ylabel="fraction of non-floaters", title="(c) contact numbers")
    if not contacts:
        return
    width = max(len(c.z_distribution()[1]) for c in contacts)
    frac = np.mean([np.pad(c.z_distribution()[1], (0, width - len(c.z_distribution()[1]))) for c in contacts], 0)
    ax.bar(np.arange(width), frac)
    mean_z = np.mean([c.mean_z for c in contacts])
    ax.text(0.98, 0.95, rf"$\langle z\rangle$ = {mean_z:.4f}", ha="right", va="top", transform=ax.transAxes)


def _energy_profiles(ax, stabilities):
    ax.set(xscale="log", yscale="log", xlabel=r"$\delta$", ylabel=r"$|\Delta V|$ (symmetric part)",
           title="(d) along the lowest nontrivial mode")
    for st in stabilities:
        ax.plot(st.deltas, np.abs(st.delta_v) + 1e-300, marker=".", lw=0.8, alpha=0.6)
    if stabilities:
        st = stabilities[0]
        guide = 0.5 * abs(st.mode_eigenvalue) * st.deltas**2
        ax.plot(st.deltas, guide, "k--", lw=1, label=r"$e_1 \delta^2 / 2$ (first packing)")
        ax.legend(loc="lower right")
