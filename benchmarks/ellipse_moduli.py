"""Shear modulus G of ellipse packings against phi - phi_J (seed Figure 2.33: G ~ dphi for ellipses
at small dphi, G ~ dphi^(1/2) for disks), a small sample: 2D 2:1 bidisperse ellipses (major-axis
ratio 1.4), each seed jammed at onset (``jam``), compressed by each DPHI (``compress_above``) and
measured by ``jamflow.analysis.moduli.Moduli`` (strain sweeps and the Hessian route with rotations).

    python benchmarks/ellipse_moduli.py --n 32 --alphas 1.0 1.6 --seeds 2 --dphi 1e-4 1e-3 1e-2 --out docs/ellipse-moduli.csv
    python benchmarks/ellipse_moduli.py --report docs/ellipse-moduli.csv

One row per packing; a (alpha, seed, dphi) already in the CSV is skipped (the run resumes).
``--report`` prints the table and the fitted exponent of G against dphi per alpha.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from jamflow import jam
from jamflow.analysis.moduli import Moduli
from jamflow.protocols.above import compress_above

from ellipse_ensembles import SIZES, read_rows, run_or_report, stats, write_rows  # (benchmarks/ is the script's directory)

COLUMNS = ["alpha", "seed", "n", "dphi", "phi_j", "G", "G_hessian", "B", "B_hessian", "cpu_seconds", "load"]


def run(args) -> None:
    out = Path(args.out)
    rows = read_rows(out)
    done = {(float(r["alpha"]), int(r["seed"]), float(r["dphi"])) for r in rows}
    for alpha in args.alphas:
        for seed in tqdm(range(args.seeds), desc=f"alpha {alpha:g}", unit="packing"):
            todo = [d for d in args.dphi if (alpha, seed, d) not in done]
            if not todo:
                continue
            onset = jam(n=args.n, sizes=SIZES, seed=seed, shape=f"ellipse:{alpha:g}")
            for dphi in todo:
                t = time.process_time()
                above = compress_above(onset.packing, dphi)
                m = Moduli().compute(above.packing)
                rows.append(dict(alpha=alpha, seed=seed, n=args.n, dphi=dphi, phi_j=onset.phi_j, G=m.G,
                                 G_hessian=m.hessian.G, B=m.B, B_hessian=m.hessian.B,
                                 cpu_seconds=round(time.process_time() - t, 1), load=os.getloadavg()[0]))
                write_rows(out, rows, COLUMNS)


def report(path: Path) -> None:
    rows = read_rows(path)
    print("| alpha | dphi | packings | <G> +- s.e. (sweeps) | <G> (Hessian) | <B> +- s.e. | max |G_sweep/G_hessian - 1| |")
    print("|---|---|---|---|---|---|---|")
    for alpha in sorted({float(r["alpha"]) for r in rows}):
        g = [r for r in rows if float(r["alpha"]) == alpha]
        dphis = sorted({float(r["dphi"]) for r in g})
        means = []
        for d in dphis:
            h = [r for r in g if float(r["dphi"]) == d]
            G, G_se, k = stats(r["G"] for r in h)
            B, B_se, _ = stats(r["B"] for r in h)
            rel = max(abs(float(r["G"]) / float(r["G_hessian"]) - 1) for r in h)
            means.append(G)
            print(f"| {alpha:g} | {d:g} | {k} | {G:.3e} +- {G_se:.1e} | {np.mean([float(r['G_hessian']) for r in h]):.3e} "
                  f"| {B:.3e} +- {B_se:.1e} | {rel:.1e} |")
        if len(dphis) > 1 and min(means) > 0:
            slope = np.polyfit(np.log(dphis), np.log(means), 1)[0]
            print(f"alpha {alpha:g}: G ~ dphi^{slope:.2f} over dphi {dphis[0]:g} .. {dphis[-1]:g}")


def add_arguments(ap) -> None:
    ap.add_argument("--n", type=int, default=32)
    ap.add_argument("--alphas", type=float, nargs="+", default=[1.0, 1.6])
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--dphi", type=float, nargs="+", default=[1e-4, 1e-3, 1e-2])


def main() -> None:
    run_or_report(__doc__, add_arguments, run, report, "docs/ellipse-moduli.csv")


if __name__ == "__main__":
    main()
