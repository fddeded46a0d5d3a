"""Checks and stability of the kept ellipse packings of benchmarks/ellipse_ensembles.py: for each
packing file, jamflow.mechanics.checks (window, force and torque balance, contact count), the spectrum of
the dynamical matrix with rotations, zero modes against d, quartic modes against the missing
contacts N' d_f - d + 1 - N_c (Mailman et al., PRL 102, 255501 (2009)) and the three branches,
all through `jamflow modes`' own per-file analysis (jamflow.cli.commands.modes.analyse_file).

    python benchmarks/ellipse_ensemble_modes.py /tmp/ee_runs/numba/*.h5 --out docs/notes/ellipse-ensembles-modes.csv
    python benchmarks/ellipse_ensemble_modes.py --report docs/notes/ellipse-ensembles-modes.csv

A file already in the CSV is skipped (the run resumes). CPU seconds are the process's.
"""

from __future__ import annotations

import os
import re
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from jamflow.analysis.modes import Spectrum, branches
from jamflow.mechanics.checks import check_packing
from jamflow.cli.commands.modes import analyse_file
from jamflow.io.packing_file import load_packing, read_checks

from common import pyplot, read_rows, run_or_report, save_figure, write_rows  # (benchmarks/ is the script's directory)

COLUMNS = ["file", "alpha", "seed", "n", "checks_passed", "problems", "in_window", "max_force", "n_kept",
           "n_contacts", "missing_contacts", "n_zero", "n_extra_zero", "n_negative", "n_quartic", "classification",
           "lowest_nonzero", "branch1", "branch2", "branch3", "cpu_seconds", "load"]


def one(path: Path, stability_seeds: int) -> dict:
    """One packing; the quartic-mode profiling (Stability, ~50 CPU s at N = 128) only for seeds
    below ``stability_seeds``, the spectrum and checks for all."""
    t = time.process_time()
    alpha, seed = re.search(r"alpha([\d.]+)-seed(\d+)", path.name).groups()
    packing = load_packing(path)
    stored = read_checks(path)
    checks = check_packing(packing, v_tol=stored.v_tol if stored else 1e-16)
    stab = analyse_file(path, Spectrum())[2] if int(seed) < stability_seeds else None
    spec = Spectrum().compute(packing)  # with eigenvectors (analyse_file returns them dropped)
    found = branches(spec) or []
    cpu = time.process_time() - t
    c = spec.dynamical.contacts
    return dict(file=path.name, alpha=float(alpha), seed=int(seed), n=packing.n, checks_passed=checks.passed,
                problems="; ".join(checks.problems()), in_window=checks.in_window, max_force=checks.max_force,
                n_kept=c.n_kept, n_contacts=c.n_contacts, missing_contacts=max(-c.excess_contacts, 0),
                n_zero=spec.n_zero, n_extra_zero=spec.n_extra_zero, n_negative=spec.n_negative,
                n_quartic="" if stab is None else stab.n_quartic, classification="" if stab is None else stab.label,
                lowest_nonzero=spec.lowest_nonzero,
                **{f"branch{k}": b.count for k, b in enumerate(found, 1)}, cpu_seconds=round(cpu, 1),
                load=os.getloadavg()[0])


def run(args) -> None:
    out = Path(args.out)
    rows = read_rows(out)
    done = {r["file"] for r in rows}
    for path in tqdm([Path(f) for f in args.files if Path(f).name not in done], desc="modes", unit="packing"):
        rows.append(one(path, args.stability_seeds))
        write_rows(out, rows, COLUMNS)


def report(path: Path) -> None:
    rows = read_rows(path)
    print("| alpha | packings | checks passed | exactly d zero modes | extra zero modes = missing contacts | "
          "quartic modes = missing contacts (profiled) | missing contacts, min .. max (mean) | no negative modes | class |")
    print("|---|---|---|---|---|---|---|---|---|")
    for alpha in sorted({float(r["alpha"]) for r in rows}):
        g = [r for r in rows if float(r["alpha"]) == alpha]
        k = len(g)
        missing = [int(r["missing_contacts"]) for r in g]
        count = lambda f: sum(bool(f(r)) for r in g)  # noqa: E731
        profiled = [r for r in g if r["n_quartic"] != ""]
        classes = sorted({r["classification"] for r in profiled})
        print(f"| {alpha:g} | {k} | {count(lambda r: r['checks_passed'] == 'True')}/{k} | "
              f"{count(lambda r: int(r['n_zero']) == 2)}/{k} | "
              f"{count(lambda r: int(r['n_extra_zero']) == int(r['missing_contacts']))}/{k} | "
              f"{sum(int(r['n_quartic']) == int(r['missing_contacts']) for r in profiled)}/{len(profiled)} | "
              f"{min(missing)} .. {max(missing)} ({np.mean(missing):.1f}) | "
              f"{count(lambda r: int(r['n_negative']) == 0)}/{k} | {', '.join(classes)} |")
    chart(rows, path.with_suffix(".png"))


def chart(rows, path: Path) -> None:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(5, 4.5))
    for alpha, marker in zip(sorted({float(r["alpha"]) for r in rows}), "osD^v"):
        g = [r for r in rows if float(r["alpha"]) == alpha and r["n_quartic"] != ""]
        ax.plot([int(r["missing_contacts"]) for r in g], [int(r["n_quartic"]) for r in g], marker, mfc="none",
                label=f"alpha = {alpha:g}")
    top = max(int(r["missing_contacts"]) for r in rows) + 2
    ax.plot([0, top], [0, top], "k:", lw=0.8, label="equality")
    ax.set(xlabel=r"missing contacts $N' d_f - d + 1 - N_c$", ylabel="quartic modes (Delta V ~ delta^4)",
           title=f"2D bidisperse ellipses, N = {rows[0]['n']}")
    ax.legend(fontsize=8)
    save_figure(fig, path)


def add_arguments(ap) -> None:
    ap.add_argument("files", nargs="*", help="packing files (ellipse_ensembles.py --keep)")
    ap.add_argument("--stability-seeds", type=int, default=5,
                    help="profile the quartic modes (jamflow modes' Stability) for seeds below this only")

def main(argv=None) -> None:
    run_or_report(__doc__, add_arguments, run, report, "docs/notes/ellipse-ensembles-modes.csv", argv)


if __name__ == "__main__":
    main()
