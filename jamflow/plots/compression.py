"""Figure of one isotropic compression (chapter section 2.1, Figure 2.3): the packing fraction
after every minimisation against the minimisation's number, compressions and decompressions of
shrinking size homing in on phi_J, and the energy per particle V on log axes with the window
V_tol < V < 2 V_tol that ends the protocol."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from jamflow.plots.figure import save_figure


def compression_figure(path, result, title: str = "") -> Path:
    """Two panels from ``result.history`` (a ``JamResult``): (a) phi, (b) V, per minimisation."""
    history, v_tol = result.history, result.settings.v_tol
    step = np.arange(1, len(history["phi"]) + 1)
    fig = Figure(figsize=(9, 3.6), layout="constrained")
    FigureCanvasAgg(fig)
    left, right = fig.subplots(1, 2)
    left.plot(step, history["phi"], "o-", ms=3, lw=0.8)
    left.axhline(result.phi_j, color="k", ls="--", lw=0.8, label=f"phi_J = {result.phi_j:.8f}")
    left.set(xlabel="minimisation", ylabel="phi", title="(a) packing fraction")
    left.legend(fontsize=8)
    energy = np.asarray(history["energy_per_particle"], float)
    right.semilogy(step, np.where(energy > 0, energy, np.nan), "o-", ms=3, lw=0.8)
    right.axhspan(v_tol, 2 * v_tol, color="tab:green", alpha=0.3, label="V_tol < V < 2 V_tol")
    right.set(xlabel="minimisation", ylabel="V (energy per particle)", title="(b) V at each minimum (V = 0 not drawn)")
    right.legend(fontsize=8)
    fig.suptitle(title or f"N = {result.packing.n}: {len(step)} minimisations to onset")
    return save_figure(fig, path)
