"""Figures and tables of docs/notes/nmers.md from the ensembles of benchmarks/nmer_ensembles.py.

    python benchmarks/nmer_figures.py --csv docs/notes/nmers/ensembles.csv docs/notes/nmers/ensembles3d.csv \
        --q6 docs/notes/nmers/q6-256.csv --routes docs/notes/nmers/routes.csv --out docs/notes/nmers

- ``q6-alpha.png`` / ``q6.csv`` rows: Q6 (global, ``jamflow.analysis.order.BondOrder`` on the body
  centres, neighbours within the first minimum of the ensemble's g(r)) against alpha for
  monodisperse 2D dimers, one series per N (chapter Figure 2.25, dashed line: N = 256); mean and
  standard error per alpha.
- ``packings-figure-2-26.png``: seed 0 at alpha = 1.04, 1.1, 1.2, 1.3, 1.4, 1.6 (chapter Figure
  2.26) from the largest N that has it, coloured by the director angle.
- ``phi-z-alpha.png``: phi_J and <z> (site contacts among non-floaters) against alpha, 2D and 3D,
  mean and standard error, with the isostatic values 2 d_f and 2 d.
- ``acceptance.png`` and the acceptance table (docs/notes/nmers.md): per packing the
  largest force and generalized torque on non-floaters (numpy reference, all site pairs), and
  the zero modes beyond d against the free rotations of one-site bodies; per set how many
  packings are in the window, pass ``jamflow.mechanics.checks``, have exactly d zero modes as they stand,
  and exactly d once the free rotations are set aside (``analysis.free_rotations``).
- ``routes.png``: phi_J of the same starts jammed by the compiled FIRE and by LAMMPS's damped
  rigid bodies (paired).
Prints the tables that docs/notes/nmers.md quotes.
"""

from __future__ import annotations

import argparse
import csv
import math
from collections import defaultdict
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from jamflow.analysis.order import BondOrder, first_minimum  # noqa: E402
from jamflow.analysis.structure import RDF  # noqa: E402
from jamflow.support.files import atomic_path
from jamflow.io.packing_file import load_packing  # noqa: E402
from jamflow.plots.drawing import draw_into  # noqa: E402
from common import NMER_F_LIMIT as F_LIMIT, scratch  # noqa: E402  (benchmarks/ is the script's directory)

FIGURE_2_26 = (1.04, 1.1, 1.2, 1.3, 1.4, 1.6)
CHAPTER_N = 256  # Figure 2.25's system size
Q6_MARKERS = "os^D"  # one marker per N, so the series stay apart where they overlap
MIN_NEIGHBOURS = 3  # Q6 of fewer neighbours within the first minimum of g(r) measures bond alignment, not order


def rows(path) -> list[dict]:
    with open(path) as fh:
        return list(csv.DictReader(fh))


def alpha_of(row) -> float:
    return float(row["shape"].split(":")[-1])


def mean_err(values) -> tuple[float, float]:
    v = np.asarray(values, float)
    return float(v.mean()), float(v.std(ddof=1) / math.sqrt(len(v))) if len(v) > 1 else math.nan


def grouped(table, key):
    out = defaultdict(list)
    for r in table:
        out[key(r)].append(r)
    return dict(sorted(out.items()))


def save(fig, path: Path) -> None:
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)


def plot_bodies(path: Path) -> None:
    """The bodies of the --shape specs with their reference lengths (chapter Figure 2.9 b-d)."""
    from matplotlib.patches import Circle

    from jamflow.model.shapes import parse_shape

    specs = [("nmer:2:1.6", "nmer:2:1.6\nlinear dimer, alpha = L/D = 1.6"), ("nmer:3:2.4", "nmer:3:2.4\nlinear trimer, alpha = 2.4"),
             ("dimer:1.5:0.6", "dimer:1.5:0.6\nasymmetric, alpha = L/D1, s = D2/D1"),
             ("trimer:2:0.3", "trimer:2:0.3\nbent, alpha = L/D = 2, c = h/L = 0.3")]
    fig, axes = plt.subplots(1, 4, figsize=(11, 2.8))
    for ax, (spec, title) in zip(axes, specs):
        body = parse_shape(spec, 2)
        ends = np.argsort(body.sites[:, 0])[[0, -1]] if not spec.startswith("trimer") else [0, 2]
        u = body.sites[ends[1]] - body.sites[ends[0]]
        u /= np.linalg.norm(u)
        turn = np.array([[u[0], u[1]], [-u[1], u[0]]])  # draw with the end-to-end line along x
        sites = body.sites @ turn.T
        sites -= 0.5 * (sites[ends[0]] + sites[ends[1]]) * np.array([1, 0]) + np.array([0, sites[ends[0], 1]])
        for (x, y), d in zip(sites, body.site_diameters):
            ax.add_patch(Circle((x, y), d / 2, facecolor="0.8", edgecolor="k", lw=0.8))
        left = sites[:, 0] - body.site_diameters / 2
        right = sites[:, 0] + body.site_diameters / 2
        y0 = -0.75
        ax.annotate("", (left.min(), y0), (right.max(), y0), arrowprops=dict(arrowstyle="<->", lw=0.8))
        ax.text(0.5 * (left.min() + right.max()), y0 - 0.12, "L", ha="center", va="top", fontsize=9)
        if spec.startswith("trimer"):
            ax.annotate("", (sites[1, 0], 0.0), (sites[1, 0], sites[1, 1]), arrowprops=dict(arrowstyle="<->", lw=0.8))
            ax.text(sites[1, 0] + 0.05, 0.5 * sites[1, 1], "h", fontsize=9)
            ax.plot(sites[[0, 2], 0], [0, 0], "k:", lw=0.7)
        ax.set_title(title, fontsize=8)
        ax.set_aspect("equal")
        ax.set_xlim(-1.6, 1.6)
        ax.set_ylim(-1.1, 1.1)
        ax.set_axis_off()
    fig.tight_layout()
    save(fig, path)


def q6_cutoff(packings) -> float:
    """The first minimum of the centres' g(r) (r_max 2.5: N = 32 cells are 5.5 wide), at the
    finest bin width (0.02, 0.05, 0.1) where it is significant for these few packings; NaN if none is."""
    for dr in (0.02, 0.05, 0.1):
        try:
            return first_minimum(RDF(dr=dr, r_max=2.5).compute(packings))
        except ValueError:
            continue
    return math.nan  # no significant first minimum: no neighbour shell to measure Q6 on


def q6_table(q6_rows) -> list[tuple]:
    """(N, alpha, mean Q6, stderr, r_min, packings, mean neighbours within r_min) per N and alpha
    from the packing files; packings that are not balanced (``balanced``) left out (main() lists them)."""
    out = []
    for (n, alpha), group in sorted(grouped(q6_rows, lambda r: (int(r["n"]), alpha_of(r))).items()):
        group = [r for r in group if balanced(r)]
        if not group:
            continue
        packings = [load_packing(r["file"]) for r in group]
        r_min = q6_cutoff(packings)
        if math.isnan(r_min):
            out.append((n, alpha, math.nan, math.nan, r_min, len(packings), 0.0))
            continue
        results = [BondOrder(r_min=r_min).compute(p) for p in packings]
        values = [r.global_order for r in results]
        neighbours = float(np.mean([r.n_neighbours.mean() for r in results]))
        out.append((n, alpha, *mean_err(values), r_min, len(values), neighbours))
    return out


def plot_q6(table, path: Path) -> None:
    fig, ax = plt.subplots(figsize=(5, 3.6))
    for k, n in enumerate(sorted({t[0] for t in table})):
        shown = [t for t in table if t[0] == n and t[6] >= MIN_NEIGHBOURS]
        a, m, e = (np.array([t[j] for t in shown]) for j in (1, 2, 3))
        ax.errorbar(a, m, yerr=e, fmt=Q6_MARKERS[k % len(Q6_MARKERS)] + "--", color=f"C{k}", capsize=3,
                    ms=7 if n == CHAPTER_N else 5, lw=1.6 if n == CHAPTER_N else 1.0,
                    label=f"2D monodisperse dimers, N = {n}" + (" (chapter's N)" if n == CHAPTER_N else ""))
    ax.axvline(1.2, color="0.6", lw=0.8, ls=":")
    ax.text(1.21, 0.02, "chapter: amorphous for alpha > 1.2", fontsize=7, color="0.4", va="bottom")
    ax.set_xlabel("alpha = L / D")
    ax.set_ylabel("Q6 (global, body centres)")
    ax.set_ylim(0, None)
    ax.set_title("Q6 against aspect ratio (chapter Figure 2.25, dashed)", fontsize=9)
    ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    save(fig, path)


def plot_packings(q6_rows, path: Path) -> None:
    """Seed 0 at the alphas of Figure 2.26, from the largest N that has it."""
    first = {}
    for r in sorted((r for r in q6_rows if r["seed"] == "0"), key=lambda r: int(r["n"])):
        first[alpha_of(r)] = r
    fig, axes = plt.subplots(2, 3, figsize=(9, 6.3))
    for ax, alpha, label in zip(axes.ravel(), FIGURE_2_26, "abcdef"):
        if alpha not in first:
            ax.set_axis_off()
            continue
        p = load_packing(first[alpha]["file"])
        draw_into(ax, p, color_by="orientation", contacts=False)
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_title(f"({label}) alpha = {alpha:g}, N = {p.n}, phi_J = {p.phi:.4f}", fontsize=9)
    fig.suptitle("Jammed packings of monodisperse 2D dimers (chapter Figure 2.26); colour: director angle mod pi",
                 fontsize=9)
    fig.tight_layout()
    save(fig, path)


def balanced(row) -> bool:
    """Force and generalized-torque balance on non-floaters below F_LIMIT (the reference's)."""
    return float(row["max_force"]) < F_LIMIT and float(row["max_torque"]) < F_LIMIT


def alpha_table(ens_rows) -> dict:
    """{(dim, N): [(alpha, phi mean, err, z mean, err, z corrected mean, err, packings, sizes)]},
    packings that are not balanced (``balanced``) left out (main() lists them)."""
    out = defaultdict(list)
    key = lambda r: (int(r["dim"]), int(r["n"]), r["sizes"], alpha_of(r))  # noqa: E731
    for (dim, n, sizes, alpha), group in sorted(grouped(ens_rows, key).items()):
        if group[0]["engine"] != "numba":
            continue
        group = [r for r in group if balanced(r)]
        if not group:
            continue
        phi = [float(r["phi_j"]) for r in group]
        n_kept = [int(r["n"]) - int(r["floaters"]) for r in group]
        z = [2 * int(r["contacts"]) / k for r, k in zip(group, n_kept)]
        zc = [2 * (int(r["contacts"]) + int(r["free_rotations"])) / k for r, k in zip(group, n_kept)]
        out[dim, n].append((alpha, *mean_err(phi), *mean_err(z), *mean_err(zc), len(group), sizes))
    return dict(out)


def plot_alpha(table, path: Path) -> None:
    fig, axes = plt.subplots(2, 2, figsize=(8.5, 6), sharex=True)
    for col, dim in enumerate((2, 3)):
        series = sorted(n for d, n in table if d == dim)
        for k, n in enumerate(series):
            t = np.array([row[:7] for row in table[dim, n]], float)
            label = f"N = {n}, {table[dim, n][0][-1]}"
            axes[0, col].errorbar(t[:, 0], t[:, 1], yerr=t[:, 2], fmt="os"[k % 2] + "-", capsize=3, color=f"C{k}",
                                  label=label)
            axes[1, col].errorbar(t[:, 0], t[:, 3], yerr=t[:, 4], fmt="os"[k % 2] + "-", capsize=3, color=f"C{k}",
                                  label=f"<z>, site contacts ({label})")
            axes[1, col].errorbar(t[:, 0], t[:, 5], yerr=t[:, 6], fmt="os"[k % 2] + ":", capsize=3, ms=4,
                                  color=f"C{k}", mfc="none", label=f"<z> + free rotations ({label})")
        if not series:
            continue
        axes[0, col].set_title(f"{dim}D dimers", fontsize=9)
        axes[0, col].set_ylabel("phi_J")
        axes[0, col].legend(fontsize=7)
        d_f = 3 if dim == 2 else 5
        axes[1, col].axhline(2 * d_f, color="0.5", lw=0.8, ls="--")
        axes[1, col].axhline(2 * dim, color="0.5", lw=0.8, ls=":")
        x0 = min(row[0] for n in series for row in table[dim, n])
        axes[1, col].text(x0, 2 * d_f + 0.1, "2 d_f (alpha > 1)", fontsize=7, color="0.4")
        axes[1, col].text(x0, 2 * dim + 0.1, "2 d (disks/spheres)", fontsize=7, color="0.4")
        axes[1, col].set_xlabel("alpha = L / D")
        axes[1, col].set_ylabel("<z>")
        axes[1, col].legend(fontsize=6, loc="lower right")
    fig.tight_layout()
    save(fig, path)


def paired_routes(route_rows) -> dict:
    """{N: (seeds, {engine: phi_J array}, {engine: CPU s array})} for the seeds both engines jammed."""
    out = {}
    for n, group in sorted(grouped(route_rows, lambda r: int(r["n"])).items()):
        by = grouped(group, lambda r: r["engine"])
        if set(by) != {"numba", "lammps"}:
            continue
        seeds = sorted(set(r["seed"] for r in by["numba"]) & set(r["seed"] for r in by["lammps"]), key=int)
        row = {e: {r["seed"]: r for r in by[e]} for e in by}
        phi = {e: np.array([float(row[e][s]["phi_j"]) for s in seeds]) for e in by}
        cpu = {e: np.array([float(row[e][s]["cpu_seconds"]) for s in seeds]) for e in by}
        out[n] = (seeds, phi, cpu)
    return out


def plot_routes(route_rows, path: Path) -> list[tuple]:
    """Paired phi_J of the same starts by both routes; returns per N (N, packings, compiled mean,
    err, LAMMPS mean, err, paired difference mean, err, compiled CPU s mean, LAMMPS CPU s mean)."""
    pairs = paired_routes(route_rows)
    if not pairs:
        return []
    fig, axes = plt.subplots(1, 2, figsize=(8.5, 3.6))
    lo = min(min(v.min() for v in phi.values()) for _, phi, _ in pairs.values())
    hi = max(max(v.max() for v in phi.values()) for _, phi, _ in pairs.values())
    summary = []
    for k, (n, (seeds, phi, cpu)) in enumerate(pairs.items()):
        axes[0].plot(phi["numba"], phi["lammps"], "os"[k % 2], ms=4, color=f"C{k}", label=f"N = {n}")
        summary.append((n, len(seeds), *mean_err(phi["numba"]), *mean_err(phi["lammps"]),
                        *mean_err(phi["lammps"] - phi["numba"]), cpu["numba"].mean(), cpu["lammps"].mean()))
    axes[0].plot([lo, hi], [lo, hi], "k:", lw=0.8)
    axes[0].set_xlabel("phi_J, compiled FIRE")
    axes[0].set_ylabel("phi_J, LAMMPS damped rigid bodies")
    axes[0].legend(fontsize=8)
    n, (seeds, phi, _) = max(pairs.items())
    bins = np.linspace(lo, hi, 12)
    axes[1].hist(phi["numba"], bins, alpha=0.6, label="compiled FIRE")
    axes[1].hist(phi["lammps"], bins, alpha=0.6, label="LAMMPS damped")
    axes[1].set_xlabel(f"phi_J (N = {n})")
    axes[1].set_ylabel("packings")
    axes[1].legend(fontsize=8)
    fig.suptitle("Same starts jammed by both routes, 2D dimers alpha = 1.5, bidisperse", fontsize=9)
    fig.tight_layout()
    save(fig, path)
    return summary


def stability_table(stab_rows) -> list[tuple]:
    """Per (dim, alpha): packings, extra zero modes = free rotations, N_c + free = N_c,iso,
    free rotations (range), lowest nonzero eigenvalue (range), Delta V power along it (range)."""
    out = []
    for (dim, alpha), group in grouped(stab_rows, lambda r: (int(r["dim"]), alpha_of(r))).items():
        extra = [int(r["extra_zero"]) for r in group]
        free = [int(r["free_rotations"]) for r in group]
        iso = [int(r["contacts"]) + int(r["free_rotations"]) - int(r["isostatic_count"]) for r in group]
        low = [float(r["lowest_nonzero"]) for r in group if r["lowest_nonzero"]]
        power = [float(r["power_lowest"]) for r in group if r["power_lowest"]]
        out.append((dim, alpha, len(group), sum(e == f for e, f in zip(extra, free)), sum(v == 0 for v in iso),
                    min(iso), max(iso), min(free), max(free), min(low), max(low), min(power), max(power)))
    return out


ACCEPTANCE_SETS = ((2, 1.2), (2, 1.5), (2, 2.0), (3, 1.5))  # the acceptance sets: 20 packings each
ACCEPTANCE_N = 128


def acceptance_rows(ens_rows, dim: int, alpha: float) -> list[dict]:
    return [r for r in ens_rows if int(r["dim"]) == dim and alpha_of(r) == alpha and r["engine"] == "numba"
            and int(r["n"]) == ACCEPTANCE_N]


def acceptance_table(ens_rows, stab_rows) -> list[tuple]:
    """Per issue set (dim, alpha): packings, in window, max force, max torque, below F_LIMIT,
    passed jamflow.mechanics.checks, exactly d zero modes as they stand, exactly d beside the free
    rotations, free rotations (min..max), worst zero-space residual."""
    stab = {r["file"]: r for r in stab_rows}
    out = []
    for dim, alpha in ACCEPTANCE_SETS:
        group = acceptance_rows(ens_rows, dim, alpha)
        checked = [stab[r["file"]] for r in group if r["file"] in stab]
        if not group:
            continue
        force = [float(r["max_force"]) for r in group]
        torque = [float(r["max_torque"]) for r in group]
        free = [int(s["free_rotations"]) for s in checked] or [0]
        out.append((dim, alpha, len(group), sum(1e-16 < float(r["v"]) < 2e-16 for r in group), max(force), max(torque),
                    sum(f < F_LIMIT and t < F_LIMIT for f, t in zip(force, torque)), len(checked),
                    sum(s["checks_passed"] == "True" for s in checked), sum(int(s["n_zero"]) == dim for s in checked),
                    sum(int(s["unexplained_zero"]) == 0 and float(s["zero_residual"]) < 1e-6 for s in checked),
                    min(free), max(free), max((float(s["zero_residual"]) for s in checked), default=math.nan)))
    return out


def plot_acceptance(ens_rows, stab_rows, path: Path) -> None:
    stab = {r["file"]: r for r in stab_rows}
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    for k, (dim, alpha) in enumerate(ACCEPTANCE_SETS):
        group = acceptance_rows(ens_rows, dim, alpha)
        if not group:
            continue
        x = k + np.linspace(-0.25, 0.25, len(group))
        axes[0].semilogy(x - 0.05, [float(r["max_force"]) for r in group], "o", ms=3, color="C0",
                         label="max |F|" if k == 0 else None)
        axes[0].semilogy(x + 0.05, [float(r["max_torque"]) for r in group], "s", ms=3, color="C1",
                         label="max |tau_a / d_k|" if k == 0 else None)
        checked = [stab[r["file"]] for r in group if r["file"] in stab]
        free = np.array([int(s["free_rotations"]) for s in checked])
        extra = np.array([int(s["n_zero"]) - dim for s in checked])
        axes[1].plot(free + 0.08 * (k - 1.5), extra, "o", ms=4, label=f"{dim}D alpha = {alpha:g}")
    axes[0].axhline(F_LIMIT, color="k", ls=":", lw=0.8)
    axes[0].set_xticks(range(len(ACCEPTANCE_SETS)), [f"{d}D alpha={a:g}" for d, a in ACCEPTANCE_SETS], fontsize=8)
    axes[0].set_ylabel("non-floaters, numpy reference")
    axes[0].set_title("force and torque balance (dotted: 1e-12)", fontsize=9)
    axes[0].legend(fontsize=7)
    top = max(axes[1].get_xlim()[1], axes[1].get_ylim()[1])
    axes[1].plot([0, top], [0, top], "k:", lw=0.8)
    axes[1].set_xlabel("free rotations of one-site bodies")
    axes[1].set_ylabel("zero modes - d")
    axes[1].set_title("zero modes beyond the d translations", fontsize=9)
    axes[1].legend(fontsize=7)
    fig.suptitle("Acceptance sets, N = 128 dimers", fontsize=9)
    fig.tight_layout()
    save(fig, path)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--csv", nargs="+", default=["docs/notes/nmers/ensembles.csv", "docs/notes/nmers/ensembles3d.csv",
                                                "docs/notes/nmers/sweep3d.csv"])
    ap.add_argument("--q6", default="docs/notes/nmers/q6-256.csv")
    ap.add_argument("--routes", default="docs/notes/nmers/routes.csv")
    ap.add_argument("--stability", default="docs/notes/nmers/stability.csv")
    ap.add_argument("--out", default=str(scratch("nmers/")))
    args = ap.parse_args(argv)
    out = Path(args.out)
    plot_bodies(out / "bodies.png")
    if Path(args.q6).exists():
        q6_rows = rows(args.q6)
        table = q6_table(q6_rows)
        print(f"N  alpha  Q6_global  stderr  r_min  packings  neighbours (< {MIN_NEIGHBOURS}: not plotted)")
        for t in table:
            print(f"{t[0]}  {t[1]:<6g} {t[2]:.4f}  {t[3]:.4f}  {t[4]:.3f}  {t[5]}  {t[6]:.2f}")
        for r in q6_rows:
            if not balanced(r):
                print(f"Q6: left out, not balanced: {r['shape']} N={r['n']} seed {r['seed']} ({r['reason']})")
        plot_q6(table, out / "q6-alpha.png")
        plot_packings(q6_rows, out / "packings-figure-2-26.png")
    ens = [r for path in args.csv if Path(path).exists() for r in rows(path)]
    if ens:
        table = alpha_table(ens)
        for r in ens:
            if not balanced(r):
                print(f"left out, not balanced: {r['shape']} {r['dim']}D N={r['n']} seed {r['seed']} max|F| "
                      f"{float(r['max_force']):.1e} max|tau/d_k| {float(r['max_torque']):.1e} ({r['reason']})")
        print("dim alpha  phi_J  stderr  <z>  stderr  <z>+free  stderr  n  sizes")
        for (dim, n), t in table.items():
            for r in t:
                print(f"{dim} N={n}  {r[0]:<5g} {r[1]:.5f} {r[2]:.5f}  {r[3]:.3f} {r[4]:.3f}  {r[5]:.3f} {r[6]:.3f}  {r[7]}  {r[8]}")
        plot_alpha(table, out / "phi-z-alpha.png")
    if Path(args.stability).exists():
        print("dim alpha packings extra_zero=free N_c+free=iso (min..max of N_c+free-iso) free lowest_e power")
        for s in stability_table(rows(args.stability)):
            print(f"{s[0]} {s[1]:<5g} {s[2]}  {s[3]}/{s[2]}  {s[4]}/{s[2]} ({s[5]}..{s[6]})  {s[7]}..{s[8]}  "
                  f"{s[9]:.2e}..{s[10]:.2e}  {s[11]:.3f}..{s[12]:.3f}")
    if ens and Path(args.stability).exists():
        stab_rows = rows(args.stability)
        print("acceptance: dim alpha packings in_window max|F| max|tau| both<1e-12 checked checks_passed "
              "n_zero=d n_zero=d+free free(min..max) worst_residual")
        for t in acceptance_table(ens, stab_rows):
            print(f"{t[0]} {t[1]:<4g} {t[2]}  {t[3]}  {t[4]:.1e} {t[5]:.1e}  {t[6]}  {t[7]}  {t[8]}  {t[9]}  {t[10]}  "
                  f"{t[11]}..{t[12]}  {t[13]:.1e}")
        plot_acceptance(ens, stab_rows, out / "acceptance.png")
    if Path(args.routes).exists():
        print("routes: N packings compiled(phi_J +- se) lammps(phi_J +- se) paired lammps-compiled (+- se) "
              "CPU s per packing compiled lammps")
        for s in plot_routes(rows(args.routes), out / "routes.png"):
            print("{} {}  {:.5f} +- {:.5f}  {:.5f} +- {:.5f}  {:+.5f} +- {:.5f}  {:.2f} {:.2f}".format(*s))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
