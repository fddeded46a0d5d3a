"""Figures of the moduli, drawn with matplotlib's Agg canvas and written atomically.

- ``stress_strain_figure``: one packing's sweeps: |Sigma - Sigma_0| against |gamma| and |P - P_0|
  against |ln phi/phi_0| on log axes (chapter Figure 2.31: linear over decades) with the fitted
  line, the Hessian line, the linear regime (filled) and the yield marked; the deviation of the
  central slopes from the Hessian modulus (round-off ~1/a at small a, curvature ~a^2 at large a,
  the window between them: the chapter's remark on Figure 2.32); Sigma(gamma) on linear axes.
- ``family_figure``: Sigma - Sigma_0 against gamma for one packing per phi - phi_J (Figures
  2.31a/2.32), yields marked.
- ``scaling_figure``: ensemble means of G, B, P and G/B against phi - phi_J on log axes with
  error bars and the fitted power laws (Figures 2.31b, 2.33).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from jamflow.mechanics.strains import STRAINS
from jamflow.plots.figure import save_figure


def _new(figsize, rows, cols):
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig, fig.subplots(rows, cols, squeeze=False)


def _log_response(ax, sweep, hessian_modulus):
    """|R - R0| against |a| for both signs; fit and Hessian lines; linear regime filled; yield."""
    strain = sweep.strain
    a, dr = sweep.strains, sweep.responses - sweep.base_response
    linear_max = sweep.linear_max
    for sign, marker, size in ((1, "o", 7), (-1, "s", 4)):
        pick = np.sign(a) == sign
        x, y = np.abs(a[pick]), np.abs(dr[pick])
        inside = x <= (linear_max if np.isfinite(linear_max) else -1)
        ax.loglog(x[inside], y[inside], marker, ms=size, color="C0" if sign > 0 else "C1",
                  label=f"{'+' if sign > 0 else '-'}{strain.strain_name}, linear regime")
        ax.loglog(x[~inside], y[~inside], marker, ms=size, mfc="none", color="C0" if sign > 0 else "C1",
                  label=f"{'+' if sign > 0 else '-'}{strain.strain_name}, outside")
    grid = np.geomspace(np.abs(a[a != 0]).min(), np.abs(a).max(), 50)
    if np.isfinite(sweep.modulus):
        ax.loglog(grid, abs(sweep.modulus) * grid, "k-", lw=1,
                  label=f"fit {strain.modulus} = {sweep.modulus:.6g} +- {sweep.error:.1g}")
    if np.isfinite(hessian_modulus):
        ax.loglog(grid, abs(hessian_modulus) * grid, "k--", lw=1, label=f"Hessian {hessian_modulus:.6g}")
    if np.isfinite(sweep.yield_strain):
        ax.axvline(sweep.yield_strain, color="C3", ls=":", label=f"yield {sweep.yield_strain:.1e} ({sweep.yield_reason})")
    ax.set(xlabel=f"|{strain.strain_name}|", ylabel=f"|{strain.response_name} - {strain.response_name}_0|",
           title=f"({'a' if strain.kind == 'shear' else 'b'}) {strain.kind}")
    ax.legend(fontsize=7)


def _slope_deviation(ax, result):
    for k, strain in enumerate(STRAINS):
        sweep = result.sweep(strain)
        dev = np.abs(sweep.central_slopes / result.hessian.modulus(strain) - 1)
        ax.loglog(sweep.amplitudes, np.maximum(dev, 1e-16), "o-", color=f"C{k}", ms=4,
                  label=f"{strain.modulus}: central slope / Hessian - 1")
        if np.isfinite(sweep.yield_strain):
            ax.axvline(sweep.yield_strain, color=f"C{k}", ls=":")
    ax.axhline(1e-6, color="gray", lw=0.8, ls="--", label="1e-6")
    ax.set(xlabel="amplitude", ylabel="|relative deviation|", title="(c) linear window: round-off vs curvature")
    ax.legend(fontsize=7)


def _linear_axes(ax, sweep):
    a, dr = sweep.strains, sweep.responses - sweep.base_response
    ax.plot(a, dr, "o-", ms=4, label="relaxed")
    if np.isfinite(sweep.modulus):
        ax.plot(a, sweep.modulus * a, "k-", lw=1, label="linear fit")
    if np.isfinite(sweep.yield_strain):
        for s in (1, -1):
            ax.axvline(s * sweep.yield_strain, color="C3", ls=":")
    ax.set(xlabel=sweep.strain.strain_name, ylabel=f"{sweep.strain.response_name} - {sweep.strain.response_name}_0",
           title="(d) shear stress-strain, linear axes")
    ax.ticklabel_format(axis="both", style="sci", scilimits=(-2, 2))
    ax.legend(fontsize=7)


def stress_strain_figure(path, result, title: str = "") -> Path:
    """Four panels of one packing's moduli (module docstring)."""
    fig, axes = _new((11, 8.5), 2, 2)
    for ax, strain in zip(axes[0], STRAINS):
        _log_response(ax, result.sweep(strain), result.hessian.modulus(strain))
    _slope_deviation(axes[1, 0], result)
    _linear_axes(axes[1, 1], result.shear)
    fig.suptitle(f"{title}  phi = {result.phi:.8f}, P = {result.pressure:.3e}")
    return save_figure(fig, path)


def family_figure(path, curves: dict, title: str = "") -> Path:
    """Sigma - Sigma_0 against gamma > 0 (log and linear stress axes) for {label: (gamma, Sigma,
    yield strain)} (arrays of one shear sweep, gamma = 0 included)."""
    fig, axes = _new((11, 4.5), 1, 2)
    for k, (label, (a, stress, y_strain)) in enumerate(curves.items()):
        a, stress = np.asarray(a), np.asarray(stress)
        up, dr = a > 0, stress - stress[a == 0][0]
        axes[0, 0].loglog(a[up], np.abs(dr[up]), "o-", ms=3, color=f"C{k}", label=label)
        axes[0, 1].plot(a[up], dr[up], "o-", ms=3, color=f"C{k}", label=label)
        if np.isfinite(y_strain):
            axes[0, 0].plot([y_strain], [np.abs(dr[up])[np.argmin(np.abs(a[up] - y_strain))]], "x", color=f"C{k}",
                            ms=10, mew=2)
    axes[0, 0].set(xlabel="gamma", ylabel="|Sigma - Sigma_0|", title="(a) log axes; x: yield")
    axes[0, 1].set(xlabel="gamma", ylabel="Sigma - Sigma_0", xscale="log", title="(b) linear stress axis")
    axes[0, 0].legend(fontsize=7)
    fig.suptitle(title)
    return save_figure(fig, path)


def scaling_figure(path, table: dict, fits: dict, title: str = "", published: dict | None = None) -> Path:
    """``table``: {potential: {quantity: (dphi, mean, standard error)}} for quantities G, B, P,
    G/B; ``fits``: {(potential, quantity): (exponent, error, prefactor)}; ``published``:
    {potential: {quantity: exponent}}, drawn dashed through the data's geometric mean."""
    fig, axes = _new((11, 8.5), 2, 2)
    labels = {"G": "G", "B": "B", "P": "P", "G/B": "G / B"}
    for ax, quantity in zip(axes.ravel(), ("G", "B", "P", "G/B")):
        for k, (potential, rows) in enumerate(table.items()):
            x, y, err = rows[quantity]
            ax.errorbar(x, y, yerr=err, fmt="o", ms=4, color=f"C{k}", capsize=2, label=potential)
            fit = fits.get((potential, quantity))
            if fit:
                exponent, error, prefactor = fit
                ax.plot(x, prefactor * x**exponent, "-", color=f"C{k}", lw=1,
                        label=f"{potential}: slope {exponent:.3f} +- {error:.3f}")
            slope = (published or {}).get(potential, {}).get(quantity)
            good = np.isfinite(y) & (y > 0)
            if slope is not None and good.any():
                x0, y0 = np.exp(np.mean(np.log(x[good]))), np.exp(np.mean(np.log(y[good])))
                ax.plot(x, y0 * (x / x0) ** slope, "--", color=f"C{k}", lw=0.8, alpha=0.6,
                        label=f"{potential}: published slope {slope:g}")
        ax.set(xscale="log", yscale="log", xlabel="phi - phi_J", ylabel=labels[quantity], title=labels[quantity])
        ax.legend(fontsize=7)
    fig.suptitle(title)
    return save_figure(fig, path)
