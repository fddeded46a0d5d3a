"""Shear modulus G of ellipse packings against phi - phi_J (chapter Figure 2.33: G ~ dphi for ellipses
at small dphi, G ~ dphi^(1/2) for disks): 2D 2:1 bidisperse ellipses (major-axis ratio 1.4), each
seed at onset (``jam``, or the kept packings of ``ellipse_ensembles.py --keep`` with ``--from``),
compressed by each DPHI (``compress_above``) and measured by ``jamflow.protocols.moduli.Moduli``
(strain sweeps and the Hessian route with rotations) or, with ``--hessian-only``, by the Hessian
route alone (``HessianModuli``; the two agree to 6e-8 on the packings where both ran).

    python benchmarks/ellipse_moduli.py --n 32 --alphas 1.6 --seeds 3 --dphi 1e-4 1e-3 1e-2 --out docs/notes/ellipse-moduli.csv
    python benchmarks/ellipse_moduli.py --n 128 --alphas 1.0 1.2 1.6 2.0 --seeds 20 --dphi 1e-5 1e-4 1e-3 1e-2 1e-1 \
        --hessian-only --from /tmp/ee_runs/numba --out docs/notes/ellipse-moduli-128.csv
    python benchmarks/ellipse_moduli.py --report docs/notes/ellipse-moduli-128.csv

One row per packing; a (alpha, seed, dphi) already in the CSV is skipped (the run resumes). Each
row also records what tells a negative G apart: the Hessian's negative eigenvalues (a saddle),
its lowest nonzero eigenvalue, the contacts added and removed by the compression (against the
onset packing's, pairs of particles), the residual shear stress Sigma = -P_xy and the pressure.
``--report`` prints the table, the diagnosis of the G < 0 packings and, where the medians are
positive, the fitted exponent of the median G against dphi per alpha; it draws the CSV's PNG.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from jamflow import jam
from jamflow.mechanics.contacts import Contacts
from jamflow.mechanics.elastic import HessianModuli
from jamflow.protocols.moduli import Moduli
from jamflow.io.packing_file import load_packing
from jamflow.protocols.above import compress_above
from jamflow.protocols.outcome import JammingFailed

from common import ELLIPSE_SIZES as SIZES, pyplot, read_rows, run_or_report, save_figure, stats, write_rows  # (benchmarks/)

COLUMNS = ["alpha", "seed", "n", "dphi", "phi_j", "G", "G_hessian", "B", "B_hessian", "cpu_seconds", "load", "route",
           "G_affine", "n_negative", "lowest_eigenvalue", "n_contacts_onset", "n_contacts", "contacts_added",
           "contacts_removed", "shear_stress", "pressure"]


def onset(args, alpha: float, seed: int):
    """The onset packing of (alpha, seed): kept by ellipse_ensembles.py, or jammed here."""
    if args.source:
        return load_packing(Path(args.source) / f"numba-alpha{alpha:g}-seed{seed}.h5")
    return jam(n=args.n, sizes=SIZES, seed=seed, shape=f"ellipse:{alpha:g}").packing


def pairs(packing) -> set:
    c = Contacts().compute(packing)
    return set(zip(c.i.tolist(), c.j.tolist()))


def measure(packing, dphi: float, hessian_only: bool, before: set) -> dict:
    """The moduli at phi + dphi; a compression that rearranges into an unjammed packing (its own
    phi_J lies higher) is a row with route 'unjammed' and no moduli."""
    try:
        above = compress_above(packing, dphi)
    except JammingFailed:
        return dict(route="unjammed", **{k: float("nan") for k in ("G", "G_hessian", "B", "B_hessian")})
    p = above.packing
    if hessian_only:
        h, G, B = HessianModuli().compute(p), float("nan"), float("nan")
    else:
        m = Moduli().compute(p)
        h, G, B = m.hessian, m.G, m.B
    after = pairs(p)
    tensor = np.asarray(above.pressure_tensor)
    return dict(G=G, G_hessian=h.G, B=B, B_hessian=h.B, route="hessian" if hessian_only else "sweeps+hessian",
                G_affine=h.G_affine, n_negative=h.n_negative, lowest_eigenvalue=h.lowest_eigenvalue,
                n_contacts_onset=len(before), n_contacts=len(after), contacts_added=len(after - before),
                contacts_removed=len(before - after), shear_stress=-tensor[0, 1], pressure=np.trace(tensor) / len(tensor))


def run(args) -> None:
    out = Path(args.out)
    rows = read_rows(out)
    done = {(float(r["alpha"]), int(r["seed"]), float(r["dphi"])) for r in rows}
    todo = [(a, s) for a in args.alphas for s in range(args.seeds) if any((a, s, d) not in done for d in args.dphi)]
    for alpha, seed in tqdm(todo, desc=f"moduli N = {args.n}", unit="packing"):
        start = onset(args, alpha, seed)
        before = pairs(start)
        for dphi in [d for d in args.dphi if (alpha, seed, d) not in done]:
            t = time.process_time()
            row = measure(start, dphi, args.hessian_only, before)
            rows.append(dict(alpha=alpha, seed=seed, n=start.n, dphi=dphi, phi_j=start.phi, **row,
                             cpu_seconds=round(time.process_time() - t, 2), load=os.getloadavg()[0]))
            write_rows(out, rows, COLUMNS)


def _g(row) -> float:
    """The measured G: the sweeps' where they ran, else the Hessian route's."""
    return float(row["G"]) if row.get("G") not in (None, "", "nan") else float(row["G_hessian"])


def report(path: Path) -> None:
    every = read_rows(path)
    rows = [r for r in every if r.get("route") != "unjammed"]
    lost = [r for r in every if r.get("route") == "unjammed"]
    if lost:
        print(f"unjammed by the compression (the minimisation rearranged it below V_min): {len(lost)} of {len(every)}: "
              + ", ".join(f"alpha {float(r['alpha']):g} seed {r['seed']} dphi {float(r['dphi']):g}" for r in lost) + "\n")
    print("| alpha | dphi | packings | <G> +- s.e. | median G | G < 0 | <B> +- s.e. | <P> | max abs(G_sweep / G_hessian - 1) |")
    print("|---|---|---|---|---|---|---|---|---|")
    medians = {}
    for alpha in sorted({float(r["alpha"]) for r in rows}):
        g = [r for r in rows if float(r["alpha"]) == alpha]
        for d in sorted({float(r["dphi"]) for r in g}):
            h = [r for r in g if float(r["dphi"]) == d]
            G, G_se, k = stats(_g(r) for r in h)
            B, B_se, _ = stats(r["B_hessian"] for r in h)
            swept = [abs(float(r["G"]) / float(r["G_hessian"]) - 1) for r in h if r.get("route", "sweeps+hessian") != "hessian"]
            medians.setdefault(alpha, []).append((d, float(np.median([_g(r) for r in h]))))
            pressure = np.mean([float(r["pressure"]) for r in h]) if h[0].get("pressure") else float("nan")
            agree = f"{max(swept):.0e}" if swept else "-"
            print(f"| {alpha:g} | {d:g} | {k} | {G:.2e} +- {G_se:.1e} | {medians[alpha][-1][1]:.2e} | "
                  f"{sum(_g(r) < 0 for r in h)}/{k} | {B:.3f} +- {B_se:.3f} | {pressure:.1e} | {agree} |")
    for alpha, m in medians.items():
        d, g = np.array(m).T
        if len(d) > 1 and np.all(g > 0):
            slope = np.polyfit(np.log(d), np.log(g), 1)[0]
            print(f"alpha {alpha:g}: median G ~ dphi^{slope:.2f} over dphi {d[0]:g} .. {d[-1]:g}")
    diagnosed = [r for r in rows if r.get("n_negative", "") != ""]
    negative = [r for r in diagnosed if _g(r) < 0]
    if negative:
        lost = lambda g: sum(int(r["contacts_removed"]) > 0 for r in g)
        ratio = [_g(r) / float(r["pressure"]) for r in negative]
        print(f"\nG < 0 in {len(negative)} of {len(diagnosed)}: saddles (negative eigenvalue) "
              f"{sum(int(r['n_negative']) > 0 for r in negative)}; contacts of the onset packing lost in the compression "
              f"{lost(negative)}/{len(negative)} (G > 0: {lost(diagnosed) - lost(negative)}/{len(diagnosed) - len(negative)}); "
              f"lowest eigenvalue {min(float(r['lowest_eigenvalue']) for r in negative):.1e} .. "
              f"{max(float(r['lowest_eigenvalue']) for r in negative):.1e}; G / P {min(ratio):.2f} .. {max(ratio):.2f}; "
              f"|Sigma| / P {min(abs(float(r['shear_stress'])) / float(r['pressure']) for r in negative):.1e} .. "
              f"{max(abs(float(r['shear_stress'])) / float(r['pressure']) for r in negative):.1e}")
    chart(rows, path.with_suffix(".png"))


def chart(rows, path: Path) -> None:
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    alphas = sorted({float(r["alpha"]) for r in rows})
    for k, alpha in enumerate(alphas):
        colour = f"C{k}"
        g = [r for r in rows if float(r["alpha"]) == alpha]
        d = np.array([float(r["dphi"]) for r in g]) * (1 + 0.06 * (k - len(alphas) / 2))
        G = np.array([_g(r) for r in g])
        axes[0].plot(d[G > 0], G[G > 0], "o", color=colour, ms=3, alpha=0.4)
        axes[0].plot(d[G < 0], -G[G < 0], "x", color=colour, ms=4, alpha=0.6)
        dphis = sorted({float(r["dphi"]) for r in g})
        med = [np.median([_g(r) for r in g if float(r["dphi"]) == x]) for x in dphis]
        axes[0].plot([x for x, m in zip(dphis, med) if m > 0], [m for m in med if m > 0], "-", color=colour,
                     label=fr"$\alpha$ = {alpha:g} (median)")
        B = [np.mean([float(r["B_hessian"]) for r in g if float(r["dphi"]) == x]) for x in dphis]
        axes[1].plot(dphis, B, "o-", color=colour, label=fr"$\alpha$ = {alpha:g}")
    x = np.array([1e-5, 1e-1])
    axes[0].plot(x, 0.05 * x, "k-", lw=0.8, label="slope 1")
    axes[0].plot(x, 0.05 * x ** 0.5, "k--", lw=0.8, label="slope 1/2")
    axes[0].set(xscale="log", yscale="log", xlabel=r"$\phi - \phi_J$", ylabel=r"$G$ (o), $-G$ where $G<0$ (x)")
    axes[1].set(xscale="log", xlabel=r"$\phi - \phi_J$", ylabel=r"$B$ (Hessian route)")
    for ax in axes:
        ax.legend(fontsize=7)
    n = sorted({r["n"] for r in rows})
    fig.suptitle(f"2D bidisperse ellipses, N = {', '.join(n)}: moduli against phi - phi_J (cf. chapter Figure 2.33)")
    save_figure(fig, path)


def add_arguments(ap) -> None:
    ap.add_argument("--n", type=int, default=32)
    ap.add_argument("--alphas", type=float, nargs="+", default=[1.0, 1.6])
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--dphi", type=float, nargs="+", default=[1e-4, 1e-3, 1e-2])
    ap.add_argument("--hessian-only", action="store_true", help="G and B from the Hessian route only (no sweeps)")
    ap.add_argument("--from", dest="source", default=None, metavar="DIR",
                    help="onset packings kept by ellipse_ensembles.py (numba-alphaA-seedS.h5) instead of jamming")


def main(argv=None) -> None:
    run_or_report(__doc__, add_arguments, run, report, "docs/notes/ellipse-moduli.csv", argv)


if __name__ == "__main__":
    main()
