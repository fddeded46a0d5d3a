"""Distribution of jamming onsets over an ensemble (chapter section 2.4, Figure 2.14).

Per N: P(phi_J) and P(<z>) histograms, <phi_J> with its standard error, the width
W(N) = standard deviation of phi_J with a bootstrap error (packings resampled with
replacement). Over N: W ~ N^-nu (weighted least squares on log W - log N; seed: nu ~ 0.5 for
spheres, O'Hern, Silbert, Liu & Nagel, PRE 68, 011306, 2003) and the finite-size
extrapolation <phi_J>(N) = phi_inf - a N^-nu (the shift scales as the width, O'Hern et al.
2003), linear in N^-nu at the fitted nu. Errors of nu and phi_inf are the spread of the same
fits over bootstrap replicates of every N at once: statistical errors under the power law; how
well the law fits is the chi^2 per degree of freedom of log W (``OnsetResult.width_chi2``). Tables
of several systems (``jamflow onsets --table``) are drawn together by ``widths_figure``.
"""

from __future__ import annotations

import csv
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from jamflow.plots.figure import save_figure
from jamflow.protocols.pressure import DEFAULT_START_PRESSURE


@dataclass(frozen=True)
class SizeStats:
    """Onset statistics at one N (phi_J dimensionless, <z> contacts per non-floater)."""

    n: int  #: N, particles per packing
    phi: np.ndarray  #: phi_J of every packing
    z: np.ndarray  #: <z> of every packing (non-floaters)
    isostatic: np.ndarray  #: bool per packing
    failed: int  #: recorded failures at this N (not in the statistics)
    width_err: float  #: bootstrap standard error of W

    @property
    def count(self) -> int:
        """Packings at this N."""
        return len(self.phi)

    @property
    def mean_phi(self) -> float:
        """<phi_J>."""
        return float(np.mean(self.phi))

    @property
    def mean_phi_err(self) -> float:
        """Standard error of <phi_J>."""
        return float(np.std(self.phi, ddof=1) / np.sqrt(self.count))

    @property
    def width(self) -> float:
        """W, the standard deviation of phi_J (chapter section 2.4)."""
        return float(np.std(self.phi, ddof=1))


@dataclass(frozen=True)
class Fit:
    """A fitted value with its bootstrap error (nan when too few sizes)."""

    value: float  #: the fitted value
    err: float  #: its bootstrap standard error


@dataclass(frozen=True)
class OnsetResult:
    """Onset statistics of a store at each N and the finite-size fits of W and <phi_J> (chapter section 2.4)."""

    dim: int  #: d
    sizes: list  #: SizeStats, ascending N
    nu: Fit  #: W ~ N^-nu
    amplitude: float  #: W = amplitude * N^-nu
    phi_inf: Fit  #: <phi_J>(N -> infinity)
    shift: float  #: a in <phi_J>(N) = phi_inf - a N^-nu
    n_bootstrap: int  #: bootstrap replicates behind the errors

    @property
    def width_chi2(self) -> float:
        """chi^2 per degree of freedom of the fit W ~ N^-nu (see ``width_chi2``)."""
        return width_chi2(*_width_arrays(self.sizes), self.nu.value, self.amplitude)

    def __repr__(self) -> str:
        """One line: dim, the sizes N, nu and phi_inf with their errors, bootstrap replicates."""
        return (f"OnsetResult(dim={self.dim}, n={[s.n for s in self.sizes]}, nu={self.nu.value:.3f}+-{self.nu.err:.3f}, "
                f"phi_inf={self.phi_inf.value:.5f}+-{self.phi_inf.err:.5f}, n_bootstrap={self.n_bootstrap})")

    def table(self) -> list[dict]:
        """One row per N: packings, failures, <phi_J> and W with errors, <z> and its spread, isostatic fraction."""
        return [dict(n=s.n, packings=s.count, failed=s.failed, mean_phi_j=s.mean_phi, mean_phi_j_err=s.mean_phi_err,
                     width=s.width, width_err=s.width_err, mean_z=float(np.mean(s.z)),
                     sd_z=float(np.std(s.z, ddof=1)), isostatic_fraction=float(np.mean(s.isostatic)))
                for s in self.sizes]


def _width_arrays(sizes):
    """(N, W, error of W) of SizeStats as float arrays."""
    return (np.array([s.n for s in sizes], float), np.array([s.width for s in sizes]),
            np.array([s.width_err for s in sizes]))


def rows_by_size(rows) -> tuple[int, dict]:
    """Group summary.csv rows (status ok) by N; returns (dim, {n: [rows]}) and counts failures."""
    groups, failed, dims = defaultdict(list), defaultdict(int), set()
    for row in rows:
        n = int(row["n"])
        if row["status"] == "ok":
            groups[n].append(row)
            dims.add(int(row["dim"]))
        else:
            failed[n] += 1
    if len(dims) > 1:
        raise ValueError("the summary mixes 2D and 3D packings; analyse them separately")
    if not groups:
        raise ValueError("no finished packings in the summary; run jamflow ensemble first")
    return dims.pop(), {n: (groups[n], failed[n]) for n in sorted(groups)}


def onset_statistics(rows, n_bootstrap: int = 1000, seed: int = 0) -> OnsetResult:
    """Statistics of phi_J and <z> per N and the fits over N (see the module docstring)."""
    if n_bootstrap < 10:
        raise ValueError(f"n_bootstrap must be at least 10, got {n_bootstrap}")
    dim, groups = rows_by_size(rows)
    rng = np.random.default_rng(seed)
    phis = {n: np.array([float(r["phi_j"]) for r in g]) for n, (g, _) in groups.items()}
    small = [n for n, p in phis.items() if len(p) < 3]
    if small:
        raise ValueError(f"N = {', '.join(map(str, small))}: fewer than 3 packings; a width needs more")
    check_distributions(phis)
    boot = {n: _resample(p, n_bootstrap, rng) for n, p in phis.items()}  # (B, count) replicates
    sizes = [SizeStats(n, phis[n], np.array([float(r["mean_z"]) for r in g]), _isostatic(g, dim), failed,
                       float(np.std(np.std(boot[n], axis=1, ddof=1), ddof=1)))
             for n, (g, failed) in groups.items()]
    ns, width, w_err = _width_arrays(sizes)
    nu, amp, phi_inf, shift = _fits(ns, width, w_err,
                                    np.array([s.mean_phi for s in sizes]), np.array([s.mean_phi_err for s in sizes]))
    boot_w = np.array([np.std(boot[int(n)], axis=1, ddof=1) for n in ns])  # (sizes, B)
    boot_mean = np.array([boot[int(n)].mean(axis=1) for n in ns])
    mean_err = np.array([s.mean_phi_err for s in sizes])
    reps = np.array([_fits(ns, boot_w[:, b], w_err, boot_mean[:, b], mean_err) for b in range(n_bootstrap)])
    return OnsetResult(dim, sizes, Fit(nu, _sd(reps[:, 0])), amp, Fit(phi_inf, _sd(reps[:, 2])), shift, n_bootstrap)


def check_distributions(phis: dict) -> None:
    """Refuse phi_J values that give no distribution to fit: unknown ones (NaN: a constant-pressure
    ensemble at one pressure has no phi_J(P->0)) or a zero width (every packing the same value:
    the bootstrap errors vanish and the weighted fits are numerical noise)."""
    for n, p in phis.items():
        missing = int(np.sum(~np.isfinite(p)))
        if missing:
            raise ValueError(f"N = {n}: {missing} of {len(p)} packings have no phi_J (a constant-pressure ensemble at "
                             "one pressure cannot extrapolate to P -> 0); run the ensemble with a --pressure below "
                             f"{DEFAULT_START_PRESSURE:g} (a sequence of pressures), or use --n to leave this N out")
        if np.ptp(p) == 0:
            raise ValueError(f"N = {n}: all {len(p)} packings have phi_J = {float(p[0])!r}, a distribution of zero width: "
                             "no onset statistics to fit (is phi_J the same fixed fraction in every file? rebuild "
                             "the summary with jamflow ensemble --rebuild-summary)")


def _resample(values, n_boot, rng):
    return values[rng.integers(0, len(values), size=(n_boot, len(values)))]


def _sd(x):
    """Half the central 68 % range of bootstrap replicates (the sd for a normal spread; robust to
    the rare degenerate replicate)."""
    x = x[np.isfinite(x)]
    return float(np.diff(np.percentile(x, [15.865, 84.135]))[0] / 2) if len(x) > 1 else float("nan")


def _isostatic(group, dim) -> np.ndarray:
    """N_c = d (N' - 1) + 1 over the non-floaters (chapter section 4.1)."""
    return np.array([int(r["n_contacts"]) == dim * (int(r["n"]) - int(r["floaters"]) - 1) + 1 for r in group])


def _fits(ns, width, width_err, mean, mean_err):
    """(nu, amplitude, phi_inf, shift): log W = log A - nu log N and <phi_J> = phi_inf - a N^-nu,
    both weighted least squares; nan where fewer than 2 sizes (3 for phi_inf)."""
    nu, amplitude = width_fit(ns, width, width_err)
    if len(ns) < 3:
        return nu, amplitude, np.nan, np.nan
    a_slope, phi_inf = np.polyfit(ns ** (-nu), mean, 1, w=1.0 / mean_err)
    return nu, amplitude, float(phi_inf), float(-a_slope)


def width_fit(ns, width, width_err) -> tuple[float, float]:
    """(nu, A) of W = A N^-nu: weighted least squares of log W on log N, each point weighted by
    W / err(W) (the inverse error of log W); nan when fewer than 2 sizes."""
    if len(ns) < 2:
        return np.nan, np.nan
    slope, intercept = np.polyfit(np.log(ns), np.log(width), 1, w=np.asarray(width) / np.asarray(width_err))
    return float(-slope), float(np.exp(intercept))


def width_chi2(ns, width, width_err, nu, amplitude) -> float:
    """chi^2 per degree of freedom of W = A N^-nu in log W (errors err(W) / W); about 1 when the
    power law describes the widths within their errors; nan with fewer than 3 sizes."""
    if len(ns) < 3:
        return float("nan")
    resid = (np.log(width) - np.log(amplitude) + nu * np.log(ns)) * np.asarray(width) / np.asarray(width_err)
    return float(np.sum(resid**2) / (len(ns) - 2))


def histograms(values_by_n: dict, bins: int):
    """Normalised histograms on common edges: (edges, {n: density})."""
    allv = np.concatenate(list(values_by_n.values()))
    edges = np.linspace(allv.min(), allv.max(), bins + 1)
    return edges, {n: np.histogram(v, bins=edges, density=True)[0] for n, v in values_by_n.items()}


def onsets_figure(result: OnsetResult, path, bins: int = 30, published: float | None = None):
    """Four panels: P(phi_J), P(<z>) per N (Figure 2.14), W(N) with the fit, <phi_J> against N^-nu."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullLocator

    fig, ax = plt.subplots(2, 2, figsize=(11, 8.5))
    colors = plt.cm.viridis(np.linspace(0, 0.9, len(result.sizes)))
    for key, axis, label in (("phi", ax[0, 0], r"$\phi_J$"), ("z", ax[0, 1], r"$\langle z \rangle_J$")):
        edges, dens = histograms({s.n: getattr(s, key) for s in result.sizes}, bins)
        centers = 0.5 * (edges[1:] + edges[:-1])
        for s, c in zip(result.sizes, colors):
            axis.plot(centers, dens[s.n], drawstyle="steps-mid", color=c, label=f"N = {s.n} ({s.count})")
        axis.set_xlabel(label)
        axis.set_ylabel(f"P({label})")
        axis.legend(fontsize=8)
    if published is not None:
        ax[0, 0].axvline(published, color="k", ls=":", lw=1)
    ns = np.array([s.n for s in result.sizes], float)
    w = np.array([s.width for s in result.sizes])
    ax[1, 0].errorbar(ns, w, yerr=[s.width_err for s in result.sizes], fmt="o", color="C0", label="W(N), bootstrap errors")
    if np.isfinite(result.nu.value):
        grid = np.geomspace(ns.min(), ns.max(), 50)
        ax[1, 0].plot(grid, result.amplitude * grid ** -result.nu.value, "C1-",
                      label=rf"fit $W \propto N^{{-\nu}}$, $\nu$ = {result.nu.value:.3f} $\pm$ {result.nu.err:.3f}")
    ax[1, 0].set(xscale="log", yscale="log", xlabel="N", ylabel=r"W = sd($\phi_J$)")
    ax[1, 0].set_xticks(ns, [str(int(n)) for n in ns], minor=False)
    ax[1, 0].xaxis.set_minor_locator(NullLocator())
    ax[1, 0].legend(fontsize=8)
    x = ns ** -result.nu.value if np.isfinite(result.nu.value) else 1 / ns
    ax[1, 1].errorbar(x, [s.mean_phi for s in result.sizes], yerr=[s.mean_phi_err for s in result.sizes], fmt="o",
                      color="C0", label=r"$\langle\phi_J\rangle$(N)")
    for s, xi in zip(result.sizes, x):
        ax[1, 1].annotate(f"{s.n}", (xi, s.mean_phi), textcoords="offset points", xytext=(4, 4), fontsize=7)
    if np.isfinite(result.phi_inf.value):
        grid = np.linspace(0, x.max(), 50)
        ax[1, 1].plot(grid, result.phi_inf.value - result.shift * grid, "C1-",
                      label=rf"$\phi_\infty$ = {result.phi_inf.value:.4f} $\pm$ {result.phi_inf.err:.4f}")
    if published is not None:
        ax[1, 1].axhline(published, color="k", ls=":", lw=1, label=f"published {published}")
    ax[1, 1].set(xlabel=rf"$N^{{-\nu}}$", ylabel=r"$\langle\phi_J\rangle$", xlim=(0, None))
    ax[1, 1].legend(fontsize=8)
    fig.suptitle(f"{result.dim}D jamming onsets: {sum(s.count for s in result.sizes)} packings, "
                 f"{result.n_bootstrap} bootstrap replicates")
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path


@dataclass(frozen=True)
class WidthCurve:
    """W(N) of one system from an onsets table (``jamflow onsets --table``), with its fit."""

    label: str  #: the system's name (the file's stem by default)
    n: np.ndarray  #: N of each row
    width: np.ndarray  #: W at each N
    width_err: np.ndarray  #: its bootstrap error
    nu: Fit  #: as the table states it (its error is the table's bootstrap error)
    amplitude: float  #: W = amplitude * N^-nu

    @property
    def chi2(self) -> float:
        """chi^2 per degree of freedom of the fit (``width_chi2``)."""
        return width_chi2(self.n, self.width, self.width_err, self.nu.value, self.amplitude)


WIDTH_COLUMNS = ("n", "width", "width_err", "nu", "nu_err")


def read_width_curve(path, label: str | None = None) -> WidthCurve:
    """W(N) of an onsets table; refuses a file that is not one (a missing column, fewer than 2
    sizes, or a stated nu that is not the fit of its rows). ``label`` defaults to the file's stem."""
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    missing = [c for c in WIDTH_COLUMNS if not rows or c not in rows[0]]
    if missing:
        raise ValueError(f"{path}: no column {', '.join(missing)}: not a table written by jamflow onsets --table")
    if len(rows) < 2:
        raise ValueError(f"{path}: {len(rows)} size(s); W(N) needs at least 2")
    n, width, err = (np.array([float(r[c]) for r in rows]) for c in ("n", "width", "width_err"))
    nu, amplitude = width_fit(n, width, err)
    stated = float(rows[0]["nu"])
    if not abs(nu - stated) <= 1e-9 * max(1.0, abs(stated)):
        raise ValueError(f"{path}: its nu = {stated} is not the fit of its rows (nu = {nu}); was the table edited?")
    label = label if label is not None else Path(path).stem
    return WidthCurve(label, n, width, err, Fit(stated, float(rows[0]["nu_err"])), amplitude)


def widths_figure(curves, path):
    """W(N) of several systems on one log-log plot, each with its fit W = A N^-nu."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullLocator

    fig, ax = plt.subplots(figsize=(6.5, 4.8))
    for k, c in enumerate(curves):
        color = f"C{k}"
        ax.errorbar(c.n, c.width, yerr=c.width_err, fmt="os^Dv"[k % 5], color=color,
                    label=rf"{c.label}: $\nu$ = {c.nu.value:.3f} $\pm$ {c.nu.err:.3f}")
        grid = np.geomspace(c.n.min(), c.n.max(), 50)
        ax.plot(grid, c.amplitude * grid ** -c.nu.value, "-", color=color, lw=1)
    ticks = sorted({int(n) for c in curves for n in c.n})
    ax.set(xscale="log", yscale="log", xlabel="N", ylabel=r"W = sd($\phi_J$)",
           title=r"width of the jamming onsets, fits $W \propto N^{-\nu}$ (bootstrap errors)")
    ax.set_xticks(ticks, [str(n) for n in ticks], minor=False)
    ax.xaxis.set_minor_locator(NullLocator())
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path
