"""The two routes that jam ellipses, as distributions (docs/notes/ellipses.md): compiled FIRE over
translations and rotations against LAMMPS damped dynamics (fix nve/asphere + fix langevin at
T = 0 with angmom), from the same random starts (same seed), 2D 2:1 bidisperse ellipses
(major-axis ratio 1.4), default protocol.

    flock /tmp/jamflow-bench.lock python benchmarks/ellipse_routes.py --n 32 --alpha 1.6 --seeds 20 \
        --out docs/notes/ellipse-routes.csv
    python benchmarks/ellipse_routes.py --report docs/notes/ellipse-routes.csv

Each row is ``ellipse_ensembles.one`` (the independent brute-force check, contacts, CPU seconds
of the process: the LAMMPS library runs in it) plus ``jamflow.mechanics.checks.check_packing`` of the
packing (window, force and torque balance, contact count). Rows are written as they finish and
skipped when present (the run resumes). ``--report`` prints the table of docs/notes/ellipses.md (means,
paired differences, a two-sample Kolmogorov-Smirnov test and the Wilcoxon signed-rank test of the
pairs) and draws docs/notes/ellipse-routes.png.
"""

from __future__ import annotations

import statistics
import tempfile
from pathlib import Path

import numpy as np
from tqdm import tqdm

from jamflow.mechanics.checks import check_packing
from jamflow.io.packing_file import load_packing

from common import ELLIPSE_COLUMNS as COLUMNS, ellipse_row as one, pyplot, read_rows, run_or_report, save_figure, stats, write_rows  # (benchmarks/)

ENGINES = ("numba", "lammps")
LABELS = {"numba": "compiled FIRE", "lammps": "LAMMPS damped dynamics"}
ROUTE_COLUMNS = COLUMNS + ["checks_passed", "check_problems"]


def checked(engine: str, alpha: float, seed: int, n: int) -> dict:
    """One packing of ``engine`` from seed ``seed``'s start, with its packing checks."""
    with tempfile.TemporaryDirectory() as tmp:
        row = one(engine, alpha, seed, n, Path(tmp))
        packing = load_packing(Path(tmp) / f"{engine}-alpha{alpha:g}-seed{seed}.h5")
    checks = check_packing(packing, v_tol=1e-16)
    return {**row, "checks_passed": checks.passed, "check_problems": " | ".join(checks.problems())}


def run(args) -> None:
    out = Path(args.out)
    rows = read_rows(out)
    done = {(r["engine"], int(r["seed"])) for r in rows}
    todo = [(s, e) for s in range(args.seeds) for e in ENGINES if (e, s) not in done]
    for seed, engine in tqdm(todo, desc=f"ellipse routes N = {args.n}", unit="packing"):
        rows.append(checked(engine, args.alpha, seed, args.n))
        write_rows(out, rows, ROUTE_COLUMNS)


def paired(rows) -> tuple[list[int], dict]:
    """Seeds jammed by both routes and each route's rows by seed."""
    by = {e: {int(r["seed"]): r for r in rows if r["engine"] == e} for e in ENGINES}
    return sorted(set(by["numba"]) & set(by["lammps"])), by


def report(path: Path) -> None:
    from scipy.stats import ks_2samp, wilcoxon

    rows = read_rows(path)
    seeds, by = paired(rows)
    n, alpha = rows[0]["n"], float(rows[0]["alpha"])
    print(f"N = {n}, alpha = {alpha:g}, seeds {seeds[0]}-{seeds[-1]} ({len(seeds)} pairs)\n")
    print("| route | packings | <phi_J> +- s.e. | std phi_J | <z> +- s.e. | checks passed | worst max F, max tau/d_k "
          "(brute) | final minimisation capped | median CPU s / packing | median iterations |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for e in ENGINES:
        g = [by[e][s] for s in seeds]
        phi, se, k = stats(r["phi_j"] for r in g)
        z, z_se, _ = stats(r["mean_z"] for r in g)
        print(f"| {LABELS[e]} | {k} | {phi:.4f} +- {se:.4f} | {statistics.stdev(float(r['phi_j']) for r in g):.4f} | "
              f"{z:.3f} +- {z_se:.3f} | {sum(r['checks_passed'] == 'True' for r in g)}/{k} | "
              f"{max(float(r['brute_max_force']) for r in g):.1e}, {max(float(r['brute_max_torque']) for r in g):.1e} | "
              f"{sum(r['final_reason'] == 'iteration-cap' for r in g)}/{k} | {statistics.median(float(r['cpu_seconds']) for r in g):.1f} | "
              f"{statistics.median(int(r['iterations']) for r in g):.0f} |")
    a = np.array([float(by["numba"][s]["phi_j"]) for s in seeds])
    b = np.array([float(by["lammps"][s]["phi_j"]) for s in seeds])
    za = np.array([float(by["numba"][s]["mean_z"]) for s in seeds])
    zb = np.array([float(by["lammps"][s]["mean_z"]) for s in seeds])
    d, dz = b - a, zb - za
    same = int(np.sum(np.abs(d) < 1e-6))
    print(f"\nLAMMPS - compiled, paired: phi_J {d.mean():+.4f} +- {d.std(ddof=1) / len(d) ** 0.5:.4f} "
          f"(|diff| < 1e-6 in {same}/{len(d)}: the same packing), <z> {dz.mean():+.3f} +- "
          f"{dz.std(ddof=1) / len(dz) ** 0.5:.3f}")
    print(f"two-sample KS (phi_J): D = {ks_2samp(a, b).statistic:.3f}, p = {ks_2samp(a, b).pvalue:.2f}; "
          f"Wilcoxon signed-rank of the pairs: p = {wilcoxon(b, a).pvalue:.2f}")
    cpu = {e: np.array([float(by[e][s]["cpu_seconds"]) for s in seeds]) for e in ENGINES}
    print(f"CPU per packing: compiled {np.median(cpu['numba']):.1f} s, LAMMPS {np.median(cpu['lammps']):.1f} s (median), "
          f"ratio of totals {cpu['lammps'].sum() / cpu['numba'].sum():.1f}; loads "
          f"{min(float(r['load']) for r in rows):.1f}-{max(float(r['load']) for r in rows):.1f}")
    chart(seeds, a, b, d, path.with_suffix(".png"), n, alpha)


def chart(seeds, a, b, d, path: Path, n, alpha) -> None:
    plt = pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(13, 4))
    for values, e, marker in ((a, "numba", "o"), (b, "lammps", "s")):
        x = np.sort(values)
        axes[0].step(x, np.arange(1, len(x) + 1) / len(x), where="post", label=f"{LABELS[e]} ({len(x)})")
    axes[0].set_xlabel(r"$\phi_J$")
    axes[0].set_ylabel("cumulative fraction")
    axes[0].legend(fontsize=8)
    axes[1].plot(a, b, "o")
    lo, hi = min(a.min(), b.min()), max(a.max(), b.max())
    axes[1].plot([lo, hi], [lo, hi], "k:", lw=0.8)
    axes[1].set_xlabel(r"$\phi_J$ compiled FIRE")
    axes[1].set_ylabel(r"$\phi_J$ LAMMPS damped dynamics (same start)")
    axes[2].bar(seeds, d)
    axes[2].axhline(d.mean(), color="k", lw=0.8, label=f"mean {d.mean():+.4f} +- {d.std(ddof=1) / len(d) ** 0.5:.4f}")
    axes[2].set_xlabel("seed")
    axes[2].set_ylabel(r"$\Delta\phi_J$ = LAMMPS - compiled")
    axes[2].legend(fontsize=8)
    fig.suptitle(f"2D bidisperse ellipses (2:1, 1.4), alpha = {alpha:g}, N = {n}: the two routes from the same starts")
    save_figure(fig, path)


def add_arguments(ap) -> None:
    ap.add_argument("--n", type=int, default=32)
    ap.add_argument("--alpha", type=float, default=1.6)
    ap.add_argument("--seeds", type=int, default=20)


def main(argv=None) -> None:
    run_or_report(__doc__, add_arguments, run, report, "docs/notes/ellipse-routes.csv", argv)


if __name__ == "__main__":
    main()
