"""Figures of the stability analysis, drawn with matplotlib's Agg canvas and written
atomically: (a) sorted frequencies omega_i vs i / (d N') (chapter Figure 2.16a); for particles
that turn, every nontrivial mode sqrt(|e_i| / M) on a log scale coloured by its translational
fraction, with the zero threshold, so the branches and their character show (Figure 2.17);
(b) D(omega) averaged over packings (Figure 2.16b; for shapes also its translational part),
(c) distribution of z_i (Figure 2.20), (d) the energy change along the profiled nontrivial
modes, |Delta V(delta)| (Figure 2.15c, log-log), coloured by behaviour."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from jamflow.plots.figure import save_figure


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
    return save_figure(fig, path)


def sorted_modes_figure(path, spectra, title: str = "") -> Path:
    """One panel: ``sorted_modes_with_character`` of ``spectra`` (particles that turn)."""
    fig = Figure(figsize=(6.4, 4.6), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    sorted_modes_with_character(ax, spectra)
    ax.set_title(title, fontsize=9)
    return save_figure(fig, path)


def _sorted_frequencies(ax, spectra):
    if any(s.dynamical.packing.shape.oriented for s in spectra):
        sorted_modes_with_character(ax, spectra)
        return
    for s in spectra:
        omega = s.frequencies
        ax.plot(np.arange(1, len(omega) + 1) / s.n_dof, omega, lw=0.8, alpha=0.6)
    ax.set(xlabel="i / (d N')", ylabel=r"$\omega_i$", title="(a) sorted frequencies")


def sorted_modes_with_character(ax, spectra):
    """sqrt(|e_i| / M) of every mode but the d lowest (the translations), sorted, against
    i / (d_f N'), coloured by translational fraction; dashed: the zero threshold e_min."""
    points = None
    for s in spectra:
        order = np.argsort(np.abs(s.eigenvalues))[s.dim:]
        order = order[np.argsort(s.eigenvalues[order])]
        omega = np.sqrt(np.abs(s.eigenvalues[order]) / s.mass)
        fraction = s.translational_fraction  # None only for a spectrum computed without vectors: grey
        colour = fraction[order] if fraction is not None else np.full(len(order), 0.5)
        points = ax.scatter(np.arange(1, len(order) + 1) / s.n_dof, omega, c=colour, cmap="coolwarm_r", vmin=0,
                            vmax=1, s=6, lw=0)
    if spectra:
        ax.axhline(np.sqrt(spectra[0].e_min / spectra[0].mass), color="k", ls="--", lw=0.8,
                   label=r"$\sqrt{e_{\min}/M}$ (zero threshold)")
        ax.legend(loc="lower right", fontsize=8)
        ax.figure.colorbar(points, ax=ax, label="translational fraction (0: rotation)")
    ax.set(yscale="log", xlabel=r"$i / (d_f N')$", ylabel=r"$\sqrt{|e_i| / M}$",
           title="(a) sorted modes and their character")


def _density_of_states(ax, dos):
    ax.set(xlabel=r"$\omega$", ylabel=r"$D(\omega)$ per packing", title="(b) density of states")
    if dos is None:
        ax.text(0.5, 0.5, "needs complete spectra", ha="center", transform=ax.transAxes)
        return
    ax.stairs(dos.density, dos.edges, fill=True, alpha=0.5, label="all modes")
    if dos.translational is not None and np.any(dos.rotational > 1e-12 * dos.density.max()):
        ax.stairs(dos.translational, dos.edges, color="C3", label="translational part")
        ax.legend(loc="upper left", fontsize=8)
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


_BEHAVIOUR_COLOURS = {"quadratic": "C0", "quartic": "C3", "flat": "0.5"}


def _energy_profiles(ax, stabilities):
    ax.set(xscale="log", yscale="log", xlabel=r"$\delta$", ylabel=r"$|\Delta V|$ (symmetric part)",
           title="(d) along the lowest nontrivial modes")
    labelled = set()
    for st in stabilities:
        for p in st.profiles:
            kind = p.behaviour.replace("negative ", "")
            colour = _BEHAVIOUR_COLOURS.get(kind, "C2")
            label = None if kind in labelled else kind
            labelled.add(kind)
            ax.plot(p.deltas, np.abs(p.delta_v) + 1e-300, marker=".", lw=0.8, alpha=0.6, color=colour, label=label)
    if stabilities:
        st = stabilities[0]
        guide = 0.5 * abs(st.mode_eigenvalue) * st.deltas**2
        ax.plot(st.deltas, guide, "k--", lw=1, label=r"$e_1 \delta^2 / 2$ (first packing)")
        ax.legend(loc="lower right", fontsize=8)
