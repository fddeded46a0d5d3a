"""PNG figures for walls, gravity and constant pressure (matplotlib Agg canvas, written atomically).

- ``plot_packing``: a 2D packing with its walls (thick lines at the walled faces), fixed wall
  particles in grey, mobile ones by size, and the contact force network (pairs and smooth-wall
  contacts, line width proportional to the force).
- ``plot_profile``: sigma_zz by planes, the weight above and sigma_xx against height
  (``jamflow.analysis.profile``).
- ``plot_phi_pressure``: phi against the target pressure for an ensemble of pressure
  sequences, with phi_J extrapolated to P -> 0 and the compression protocol's phi_J.
Lengths in small diameters, stresses in eps / diameter^d.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.collections import LineCollection, PatchCollection
from matplotlib.figure import Figure
from matplotlib.patches import Circle

from jamflow.analysis.profile import ProfileResult
from jamflow.model.packing import Packing
from jamflow.model.pairs import overlapping_pairs
from jamflow.model.walls import smooth_wall_contacts
from jamflow.plots.figure import save_figure


def contact_forces(packing: Packing):
    """Segments (M, 2, 2) and force magnitudes (M,) of every contact: mobile pairs (with fixed
    particles too; the minimum image, drawn from i) and smooth-wall contacts (to the face)."""
    i, j, dr, r, sigma = overlapping_pairs(packing)
    if packing.fixed is not None:
        live = ~(packing.fixed[i] & packing.fixed[j])
        i, j, dr, r, sigma = i[live], j[live], dr[live], r[live], sigma[live]
    x = packing.positions
    segs = [np.stack([x[i], x[i] - dr], axis=1)]
    mags = [-packing.potential.dv_dr(r, sigma)]
    for a, side, k, _, push in smooth_wall_contacts(packing):
        end = x[k].copy()
        end[:, a] = packing.box.lengths[a] if side else 0.0
        segs.append(np.stack([x[k], end], axis=1))
        mags.append(push)
    return np.concatenate(segs), np.concatenate(mags)


def plot_packing(packing: Packing, path, title: str = "", network: bool = True) -> Path:
    """A 2D packing with walls and (optionally) its contact force network."""
    if packing.dim != 2 or packing.box.is_triclinic:
        raise ValueError("plot_packing draws 2D packings in orthogonal boxes")
    lx, ly = packing.box.lengths
    fig = Figure(figsize=(5.5, 5.5 * ly / lx + 0.4))
    ax = fig.add_subplot()
    x, d = packing.positions, packing.diameters
    mobile = packing.mobile
    small = d <= d[mobile].min() + 1e-12
    colors = np.where(~mobile, "0.55", np.where(small, "#9ecae1", "#fdae6b"))
    ax.add_collection(PatchCollection([Circle(p, r) for p, r in zip(x, d / 2)], facecolors=colors,
                                      edgecolors="0.3", linewidths=0.3))
    if network:
        segs, mags = contact_forces(packing)
        if len(mags) and mags.max() > 0:
            ax.add_collection(LineCollection(segs, linewidths=0.3 + 2.5 * mags / mags.max(), colors="#b2182b"))
    for a in packing.box.walls:
        line = [[0, 0], [lx, 0]] if a == 1 else [[0, 0], [0, ly]]
        other = [[0, ly], [lx, ly]] if a == 1 else [[lx, 0], [lx, ly]]
        ax.add_collection(LineCollection([line, other], linewidths=3, colors="k"))
    if packing.box.periodic[0]:
        ax.plot([0, 0], [0, ly], ":", color="0.5", lw=0.8)
        ax.plot([lx, lx], [0, ly], ":", color="0.5", lw=0.8)
    if packing.box.periodic[1]:
        ax.plot([0, lx], [0, 0], ":", color="0.5", lw=0.8)
        ax.plot([0, lx], [ly, ly], ":", color="0.5", lw=0.8)
    if packing.gravity > 0:
        ax.annotate("", xy=(1.02 * lx, 0.35 * ly), xytext=(1.02 * lx, 0.6 * ly),
                    arrowprops=dict(arrowstyle="->", lw=1.5), annotation_clip=False)
        ax.text(1.03 * lx, 0.62 * ly, f"g = {packing.gravity:g}", fontsize=7)
    ax.set_xlim(-0.6, lx + 0.6)
    ax.set_ylim(-0.6, ly + 0.6)
    ax.set_aspect("equal")
    ax.set_title(title, fontsize=9)
    ax.set_xlabel("x (small diameters)")
    return save_figure(fig, path, tight=True)


def plot_profile(result: ProfileResult, path, title: str = "", mean=None) -> Path:
    """sigma_zz (planes), the weight above and sigma_xx against height; ``mean`` an optional
    (heights, sigma_zz, sigma_xx) ensemble average drawn as lines."""
    fig = Figure(figsize=(5, 4.5))
    ax = fig.add_subplot()
    ax.plot(result.sigma_zz, result.heights, "o", ms=4, label=r"$\sigma_{zz}$: contacts across the plane")
    ax.plot(result.weight_above, result.heights, "-", color="k", lw=1, label=r"weight above / area, $g\,N(>z)/A$")
    ax.plot(result.sigma_xx, result.heights, "s", ms=3, label=r"$\sigma_{xx}$: slab virial")
    if mean is not None:
        z, szz, sxx = mean
        ax.plot(szz, z, "-", color="C0", alpha=0.6, lw=2, label=r"$\sigma_{zz}$, mean of the ensemble")
        ax.plot(sxx, z, "-", color="C2", alpha=0.6, lw=2, label=r"$\sigma_{xx}$, mean of the ensemble")
    ax.set_xlabel(r"stress ($\epsilon/\sigma^2$)")
    ax.ticklabel_format(axis="x", style="sci", scilimits=(0, 0))
    ax.set_ylabel("height z (small diameters)")
    ax.set_title(title or "pressure profile under gravity", fontsize=9)
    ax.legend(fontsize=7)
    return save_figure(fig, path, tight=True)


def plot_phi_pressure(pressures, phis, phi_j_pressure, bands: dict, path, title: str = "") -> Path:
    """phi(P) of each start (rows of ``phis`` over ``pressures``), its phi - phi_J against P
    (``phi_j_pressure`` per start), and ``bands``: label -> phi_J values of an ensemble, drawn
    as mean +- standard error (the compression protocol, other pressure sequences)."""
    pressures, phis = np.asarray(pressures), np.asarray(phis)
    fig = Figure(figsize=(9, 4))
    ax, bx = fig.add_subplot(1, 2, 1), fig.add_subplot(1, 2, 2)
    for row in phis:
        ax.plot(pressures, row, "-", color="0.7", lw=0.7)
    ax.errorbar(pressures, phis.mean(axis=0), phis.std(axis=0, ddof=1) / np.sqrt(len(phis)), fmt="o-", color="C0",
                label="constant pressure, mean of the starts")
    for k, (label, values) in enumerate(bands.items()):
        m, e = np.mean(values), np.std(values, ddof=1) / np.sqrt(len(values))
        color = f"C{k + 1}"
        ax.axhspan(m - e, m + e, color=color, alpha=0.2)
        ax.axhline(m, color=color, lw=1, label=f"{label}: {m:.5f} $\\pm$ {e:.5f}")
    ax.set_xscale("log")
    ax.set_xlabel(r"target pressure $P$ ($\epsilon/\sigma^2$)")
    ax.set_ylabel(r"$\phi$")
    ax.legend(fontsize=7)
    excess = phis - np.asarray(phi_j_pressure)[:, None]
    for row in excess:
        bx.loglog(pressures, np.where(row > 0, row, np.nan), "-", color="0.7", lw=0.7)
    bx.loglog(pressures, excess.mean(axis=0), "o-", color="C0", label=r"mean $\phi - \phi_J$")
    scale = excess.mean(axis=0)[-1] / pressures[-1]
    bx.loglog(pressures, scale * pressures, "--", color="k", lw=1, label=r"slope 1 ($P \propto \phi - \phi_J$)")
    bx.set_xlabel(r"$P$")
    bx.set_ylabel(r"$\phi - \phi_J$")
    bx.legend(fontsize=7)
    fig.suptitle(title, fontsize=9)
    return save_figure(fig, path, tight=True)
