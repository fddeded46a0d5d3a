"""Figures of the stability analysis, drawn with matplotlib's Agg canvas and written
atomically: (a) sorted frequencies omega_i vs i / (d N') (chapter Figure 2.16a); for particles
that turn, every nontrivial mode sqrt(|e_i| / M) on a log scale, coloured by its branch (the
chapter's three branches of Figure 2.17: 1 zero/quartic, 2 rotational, 3 translational) or by
its translational fraction, with the zero threshold; (b) D(omega) pooled over packings and
normalised to integral 1 over omega (Figure 2.16b; for shapes also its translational part),
(c) distribution of z_i (Figure 2.20) with the pooled <z> and floater fraction,
(d) the energy change along the profiled nontrivial modes, |Delta V(delta)| (Figure 2.15c,
log-log), coloured by behaviour. One meaning per colour across the panels: red = zero/quartic
(branch 1 in (a), quartic profiles in (d)), orange = rotational, green = translational, blue =
quadratic, black = flat, light grey = data without a character (all modes, z_i). omega =
sqrt(e / M) is in sqrt(eps / m) / diameter with M = N m (the whole packing's mass, floaters
included, m = 1) unless ``Spectrum(mass=...)`` set another M: the axes say which M, and a
caption under each figure says what omega is (``omega_caption``; docs: reference/conventions)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from jamflow.analysis.modes import BRANCH_NAMES, branch_labels
from jamflow.mechanics.contacts import pooled_contacts
from jamflow.plots.figure import save_figure

COLOURINGS = ("branches", "fraction")  # panel (a) of shapes that turn: discrete branch labels, or the continuous fraction
BRANCH_COLOURS = {1: "C3", 2: "C1", 3: "C2"}  # zero/quartic red, rotational orange, translational green
BRANCH_LEGEND = {1: BRANCH_NAMES[0] + " (quartic)", 2: BRANCH_NAMES[1], 3: BRANCH_NAMES[2]}
NEUTRAL = "0.7"  # data without a character: D(omega) of all modes, the z_i bars
FRACTION_CMAP = "viridis"  # 0 (rotation) dark purple .. 1 (translation) yellow: neither red nor blue
OMEGA_UNITS = r"[$\sqrt{\epsilon/(m\sigma^2)}$]"  # sigma: the small diameter


def modes_figure(path, spectra, dos=None, contacts=(), stabilities=(), colour: str = "branches") -> Path:
    """Write the four-panel PNG ``path``; ``dos`` may be None (incomplete spectra). ``colour``:
    panel (a) of particles that turn coloured by ``"branches"`` (discrete labels, with a legend;
    spectra without labels -- incomplete -- fall back to the fraction) or by the translational
    ``"fraction"`` (a colour bar)."""
    if colour not in COLOURINGS:
        raise ValueError(f"colour must be one of {', '.join(COLOURINGS)}, got {colour!r}")
    from matplotlib.backends.backend_agg import FigureCanvasAgg  # here: the command imports COLOURINGS at start-up
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10, 8), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(2, 2)
    _sorted_frequencies(axes[0, 0], spectra, colour)
    _density_of_states(axes[0, 1], dos, spectra)
    _z_distribution(axes[1, 0], contacts)
    _energy_profiles(axes[1, 1], stabilities)
    fig.suptitle(f"{len(spectra)} packing(s), e_min = {spectra[0].e_min:g}" if spectra else "")
    if spectra:
        fig.supxlabel(omega_caption(spectra), fontsize=9)
    return save_figure(fig, path)


def omega_label(spectra, symbol=r"\omega") -> str:
    """An axis label for frequencies: ``symbol`` with its units and the M it is normalised by."""
    masses = {s.mass for s in spectra}
    default = all(s.mass == s.dynamical.n_total for s in spectra)
    m = "M = N m" if default or not masses else f"M = {masses.pop():g} m" if len(masses) == 1 else "M per packing"
    return rf"${symbol}$, {m}  {OMEGA_UNITS}"


def omega_caption(spectra) -> str:
    """The figure's caption of the frequency axes: what omega is and which M divides it."""
    masses = {s.mass for s in spectra}
    if all(s.mass == s.dynamical.n_total for s in spectra):
        m = r"$M = N m$: the mass of the whole packing ($N$ particles, floaters included; $m = 1$)"
    elif len(masses) == 1:
        m = rf"$M = {masses.pop():g}\,m$, set with --mass or Spectrum(mass=...) ($m = 1$)"
    else:
        m = r"$M$ per packing, set with --mass or Spectrum(mass=...)"
    return (r"$\omega = \sqrt{e / M}$, $e$ the eigenvalues of the dynamical matrix ($\epsilon/\sigma^2$), "
            r"in $\sqrt{\epsilon/(m\sigma^2)}$" "\n" + m)


def sorted_modes_figure(path, spectra, title: str = "", colour: str = "branches") -> Path:
    """One panel: panel (a) of ``modes_figure`` alone (for particles that turn, each mode coloured
    by its branch or by its translational ``colour``-ing, as there)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg  # here, as in modes_figure
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.4, 4.6), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    _sorted_frequencies(ax, spectra, colour)
    ax.set_title(title, fontsize=9)
    if spectra:
        fig.supxlabel(omega_caption(spectra), fontsize=7)
    return save_figure(fig, path)


def _sorted_frequencies(ax, spectra, colour="branches"):
    if any(s.dynamical.packing.shape.oriented for s in spectra):
        by_branch = colour == "branches" and all(branch_labels(s) is not None for s in spectra)
        (sorted_modes_by_branch if by_branch else sorted_modes_with_character)(ax, spectra)
        return
    for s in spectra:
        omega = s.frequencies
        ax.plot(np.arange(1, len(omega) + 1) / s.n_dof, omega, lw=0.8, alpha=0.6)
    ax.set(xlabel="i / (d N')", ylabel=omega_label(spectra, r"\omega_i"), title="(a) sorted frequencies")


def _nontrivial_sorted(s) -> np.ndarray:
    """Indices of every mode but the d trivial translations (the d smallest |e|), by ascending e."""
    order = np.argsort(np.abs(s.eigenvalues), kind="stable")[s.dim:]
    return order[np.argsort(s.eigenvalues[order], kind="stable")]


def _sorted_axes(ax, spectra, title):
    """Axes of panel (a) for particles that turn: log omega, the dashed zero threshold."""
    if spectra:
        ax.axhline(np.sqrt(spectra[0].e_min / spectra[0].mass), color="k", ls="--", lw=0.8,
                   label=r"$\sqrt{e_{\min}/M}$ (zero threshold)")
    ax.set(yscale="log", xlabel=r"$i / (d_f N')$", ylabel=omega_label(spectra, r"\sqrt{|e_i| / M}"), title=title)


def sorted_modes_with_character(ax, spectra):
    """sqrt(|e_i| / M) of every mode but the d lowest (the translations), sorted, against
    i / (d_f N'), coloured by translational fraction (0: rotation, 1: translation; colour bar);
    dashed: the zero threshold e_min."""
    points = None
    for s in spectra:
        order = _nontrivial_sorted(s)
        omega = np.sqrt(np.abs(s.eigenvalues[order]) / s.mass)
        fraction = s.translational_fraction  # None only for a spectrum computed without vectors: grey
        colour = fraction[order] if fraction is not None else np.full(len(order), 0.5)
        points = ax.scatter(np.arange(1, len(order) + 1) / s.n_dof, omega, c=colour, cmap=FRACTION_CMAP, vmin=0,
                            vmax=1, s=6, lw=0)
    _sorted_axes(ax, spectra, "(a) sorted modes and their character")
    if spectra:
        ax.legend(loc="lower right", fontsize=8)
        ax.figure.colorbar(points, ax=ax, label="translational fraction (0: rotation, 1: translation)")


def sorted_modes_by_branch(ax, spectra):
    """sqrt(|e_i| / M) of every nontrivial mode, sorted, against i / (d_f N'), coloured by its
    branch (``jamflow.analysis.modes.branch_labels``: 1 zero/quartic, 2 rotational, 3
    translational; the chapter's Figure 2.17), with a legend naming each branch; dashed: the
    zero threshold. Every spectrum needs its labels (complete, with translational fractions)."""
    for k, s in enumerate(spectra):
        labels = branch_labels(s)
        if labels is None:
            raise ValueError("colouring by branch needs complete spectra of particles that turn, with their "
                             "translational fractions")
        order = _nontrivial_sorted(s)
        x = np.arange(1, len(order) + 1) / s.n_dof
        omega = np.sqrt(np.abs(s.eigenvalues[order]) / s.mass)
        for b in BRANCH_COLOURS:
            on = labels[order] == b
            ax.scatter(x[on], omega[on], color=BRANCH_COLOURS[b], s=6, lw=0, label=BRANCH_LEGEND[b] if k == 0 else None)
    _sorted_axes(ax, spectra, "(a) sorted modes: the three branches")
    if spectra:
        ax.legend(loc="lower right", fontsize=8, markerscale=2)


def _density_of_states(ax, dos, spectra=()):
    """D(omega) normalised over all modes (``DensityOfStatesResult.normalized``: integral 1, or the
    fraction of modes in range when omega_max leaves some out), and its translational part."""
    integral = "1" if dos is None or dos.n_in_range == dos.n_modes else f"{dos.fraction_in_range:.3g}"
    ax.set(xlabel=omega_label(spectra), ylabel=rf"$D(\omega)$, normalised: $\int D\,d\omega = {integral}$",
           title="(b) density of states")
    if dos is None:
        ax.text(0.5, 0.5, "needs complete spectra", ha="center", transform=ax.transAxes)
        return
    ax.stairs(dos.normalized, dos.edges, fill=True, color=NEUTRAL, label="all modes")
    if dos.translational is not None and np.any(dos.rotational > 1e-12 * dos.density.max()):
        ax.stairs(dos.translational * dos.n_packings / dos.n_modes, dos.edges, color=BRANCH_COLOURS[3],
                  label="translational part")
        ax.legend(loc="upper left", fontsize=8)
    shown = "" if dos.n_in_range == dos.n_modes else f" ({dos.n_in_range} in range)"
    ax.text(0.98, 0.95, f"{dos.n_packings} packing(s), {dos.n_modes} modes{shown}", ha="right", va="top",
            transform=ax.transAxes)


def _z_distribution(ax, contacts):
    ax.set(xlabel="$z_i$", ylabel="fraction of non-floaters", title="(c) contact numbers")
    if not contacts:
        return
    width = max(len(c.z_distribution()[1]) for c in contacts)
    frac = np.mean([np.pad(c.z_distribution()[1], (0, width - len(c.z_distribution()[1]))) for c in contacts], 0)
    ax.bar(np.arange(width), frac, color=NEUTRAL)
    pooled = pooled_contacts(contacts)
    ax.text(0.98, 0.95, rf"pooled $\langle z\rangle$ = {pooled.mean_z:.4f}" + "\n"
            f"floaters {pooled.n_floaters}/{pooled.n} ({pooled.floater_fraction:.4f})", ha="right", va="top",
            transform=ax.transAxes)


_BEHAVIOUR_COLOURS = {"quadratic": "C0", "quartic": BRANCH_COLOURS[1], "flat": "k"}
ENERGY_LABEL = r"$\frac{1}{2}\,|\Delta V(\delta) + \Delta V(-\delta)|$ ($\epsilon$)"  # the symmetric part


def _energy_profiles(ax, stabilities):
    ax.set(xscale="log", yscale="log", xlabel=r"$\delta$ (mode amplitude, diameters)", ylabel=ENERGY_LABEL,
           title="(d) along the lowest nontrivial modes")
    labelled = set()
    for st in stabilities:
        for p in st.profiles:
            kind = p.behaviour.replace("negative ", "")
            colour = _BEHAVIOUR_COLOURS.get(kind, "C4")
            label = None if kind in labelled else kind
            labelled.add(kind)
            ax.plot(p.deltas, np.abs(p.delta_v) + 1e-300, marker=".", lw=0.8, alpha=0.6, color=colour, label=label)
    if stabilities:
        st = stabilities[0]
        guide = 0.5 * abs(st.mode_eigenvalue) * st.deltas**2
        ax.plot(st.deltas, guide, "k--", lw=1, label=r"$e_1 \delta^2 / 2$ (first packing)")
        ax.legend(loc="lower right", fontsize=8)
