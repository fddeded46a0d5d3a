"""The sorted normal-mode frequencies of ellipse packings at several aspect ratios (chapter Figure
2.17): 2D bidisperse ellipses (2:1, major-axis ratio 1.4), one packing per alpha at onset, the
dynamical matrix with rotations (jamflow.mechanics.hessian), its three branches
(jamflow.analysis.modes.branches) and each mode's translational fraction.

    python benchmarks/ellipse_spectra.py --n 120 --alphas 1.02 1.06 1.1 1.2 1.4 1.8 --out docs/notes/ellipse-spectra.csv
    python benchmarks/ellipse_spectra.py --report docs/notes/ellipse-spectra.csv

One row per mode (alpha, seed, index i / (3 N'), eigenvalue, omega = sqrt(|e| / M), translational
fraction, branch); an alpha already in the CSV is skipped (the run resumes). ``--report`` prints
the branch table of docs/notes/ellipses.md and draws docs/notes/ellipse-spectra.png.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from jamflow import jam
from jamflow.analysis.modes import Spectrum, branch_labels
from jamflow.mechanics.checks import check_packing

from common import ELLIPSE_SIZES as SIZES, pyplot, read_rows, run_or_report, save_figure, write_rows  # (benchmarks/ is the script's directory)

COLUMNS = ["alpha", "seed", "n", "n_kept", "phi_j", "mean_z", "checks_passed", "index", "x", "eigenvalue", "omega",
           "translational", "branch", "cpu_seconds", "load"]


def one(alpha: float, seed: int, n: int) -> list[dict]:
    t = time.process_time()
    res = jam(n=n, sizes=SIZES, shape=f"ellipse:{alpha:g}", seed=seed)
    checks = check_packing(res.packing, res.energy_per_particle, None, 1e-16)
    spec = Spectrum().compute(res.packing)
    cpu = time.process_time() - t
    fraction = spec.translational_fraction
    label = np.array(["trivial", "1", "2", "3"])[branch_labels(spec)]
    omega = np.sqrt(np.abs(spec.eigenvalues) / spec.mass)
    base = dict(alpha=alpha, seed=seed, n=n, n_kept=spec.dynamical.contacts.n_kept, phi_j=res.phi_j,
                mean_z=checks.mean_z, checks_passed=checks.passed, cpu_seconds=round(cpu, 1), load=os.getloadavg()[0])
    return [dict(base, index=k, x=(k + 1) / spec.n_dof, eigenvalue=spec.eigenvalues[k], omega=omega[k],
                 translational=fraction[k], branch=label[k]) for k in range(spec.n_dof)]


def run(args) -> None:
    out = Path(args.out)
    rows = read_rows(out)
    done = {float(r["alpha"]) for r in rows}
    for alpha in tqdm([a for a in args.alphas if a not in done], desc="spectra", unit="packing"):
        rows += one(alpha, args.seed, args.n)
        write_rows(out, rows, COLUMNS)


def report(path: Path) -> None:
    rows = read_rows(path)
    alphas = sorted({float(r["alpha"]) for r in rows})
    print("| alpha | N' | phi_J | <z> | checks | branch 1: modes, omega | branch 2: modes, omega, transl. | "
          "branch 3: modes, omega, transl. |")
    print("|---|---|---|---|---|---|---|---|")
    for a in alphas:
        g = [r for r in rows if float(r["alpha"]) == a]
        cells = []
        for b in "123":
            m = [r for r in g if r["branch"] == b]
            if not m:
                cells.append("0")
                continue
            w = [float(r["omega"]) for r in m]
            t = np.mean([float(r["translational"]) for r in m])
            cells.append(f"{len(m)}, {min(w):.1e}..{max(w):.1e}" + (f", {t:.2f}" if b != "1" else f" ({t:.2f})"))
        r0 = g[0]
        print(f"| {a:g} | {r0['n_kept']} | {float(r0['phi_j']):.4f} | {float(r0['mean_z']):.3f} | "
              f"{'passed' if r0['checks_passed'] == 'True' else 'FAILED'} | " + " | ".join(cells) + " |")
    chart(rows, alphas, path.with_suffix(".png"))


def chart(rows, alphas, path: Path) -> None:
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    colors = plt.cm.viridis(np.linspace(0, 0.9, len(alphas)))
    for a, c in zip(alphas, colors):
        g = [r for r in rows if float(r["alpha"]) == a and r["branch"] != "trivial"]
        x = [float(r["x"]) for r in g]
        axes[0].semilogy(x, [float(r["omega"]) for r in g], ".", ms=3, color=c, label=f"alpha = {a:g}")
        axes[1].plot(x, [float(r["translational"]) for r in g], ".", ms=3, color=c)
    axes[0].set(xlabel=r"$i / (3N')$", ylabel=r"$\omega_i = \sqrt{|e_i| / M}$",
                title="sorted frequencies (cf. chapter Figure 2.17)")
    axes[1].set(xlabel=r"$i / (3N')$", ylabel="translational fraction of mode i", ylim=(-0.02, 1.02),
                title="mode character (branches 1, 2 rotational; 3 translational)")
    axes[1].axhline(0.5, ls=":", color="k", lw=0.8)
    axes[0].legend(fontsize=7, markerscale=3)
    n = rows[0]["n"]
    fig.suptitle(f"2D bidisperse ellipses at onset, N = {n}, one packing per alpha (quartic modes: branch 1)")
    save_figure(fig, path)


def add_arguments(ap) -> None:
    ap.add_argument("--alphas", type=float, nargs="+", default=[1.02, 1.06, 1.1, 1.2, 1.4, 1.8])
    ap.add_argument("--n", type=int, default=120)
    ap.add_argument("--seed", type=int, default=0)

def main(argv=None) -> None:
    run_or_report(__doc__, add_arguments, run, report, "docs/notes/ellipse-spectra.csv", argv)


if __name__ == "__main__":
    main()
