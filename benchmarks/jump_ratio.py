"""Whole default jams against the fast protocol's Newton-jump ratio (a jump from a jammed state shrinks
the predicted phi - phi_J by at most this factor: ``CompressionSettings.newton_ratio`` and
``large_n_newton_ratio``, both set to the ratio measured here).

A long jump decompresses a jammed state far, and the minimisation after it can be an avalanche of
contact changes that FIRE follows for 10^5 iterations (docs/notes/newton-krylov.md, "Why the whole
jams do not follow the single minimisations"); shorter jumps cost more minimisations. Same seeds,
the ratios alternating per seed in one process; ``--summary`` pairs phi_J by seed against the first
ratio (mean difference +- standard error, and a two-sample Kolmogorov-Smirnov test).

    python benchmarks/jump_ratio.py --n 1024 --seeds 1:21 --ratios 10 3 --out docs/notes/jump-ratio.csv
    python benchmarks/jump_ratio.py --n 4096 --seeds 1:6 --ratios 10 3 --out docs/notes/jump-ratio.csv
    timeout 6000 python benchmarks/jump_ratio.py --n 16384 --seeds 1 --ratios 3 --out docs/notes/jump-ratio.csv \\
        --trace docs/notes/jump-ratio-trace-n16384.csv
    python benchmarks/jump_ratio.py --summary docs/notes/jump-ratio.csv

Rows are appended (CPU seconds of this process).
"""

from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

import numpy as np

import jamflow
from jamflow.mechanics.checks import check_packing
from jamflow.protocols.settings import fast_protocol

from common import append_row, check_outputs  # (benchmarks/ is the script's directory)

COLUMNS = ["n", "dim", "seed", "newton_ratio", "phi_j", "minimisations", "iterations", "largest", "checks", "cpu_s"]
TRACE = ["n", "seed", "newton_ratio", "step", "phi", "dphi", "V", "reason", "iterations", "max_force", "cpu_s"]


def seeds_of(text: str) -> list[int]:
    """'1:21' -> 1 .. 20; '3' -> [3]."""
    if ":" in text:
        lo, hi = (int(v) for v in text.split(":"))
        return list(range(lo, hi))
    return [int(text)]


def jam_row(n: int, dim: int, seed: int, ratio: float, trace: Path | None) -> dict:
    c0 = time.process_time()
    observers = ()
    if trace is not None:
        def observe(step):
            r = step["result"]
            append_row(trace, TRACE, dict(n=n, seed=seed, newton_ratio=ratio, step=step["step"],
                                          phi=f"{step['phi']:.12f}", dphi=f"{step['dphi']:.3e}",
                                          V=f"{r.energy_per_particle:.4e}", reason=r.reason, iterations=r.iterations,
                                          max_force=f"{r.max_force:.3e}", cpu_s=f"{time.process_time() - c0:.1f}"))
        observers = (observe,)
    res = jamflow.jam(n=n, dim=dim, sizes="bi:1.4:0.5" if dim == 2 else "mono", seed=seed, observers=observers,
                      settings=fast_protocol(newton_ratio=ratio, large_n_newton_ratio=ratio))
    cpu = time.process_time() - c0
    its = res.history["iterations"]
    checks = check_packing(res.packing, res.energy_per_particle, None, res.settings.v_tol)
    return dict(n=n, dim=dim, seed=seed, newton_ratio=ratio, phi_j=f"{res.phi_j:.12f}", minimisations=len(its),
                iterations=int(its.sum()), largest=int(its.max()), checks=checks.passed, cpu_s=f"{cpu:.2f}")


def summary(path: Path) -> None:
    """Per (n, dim, ratio): CPU s and iterations summed over the seeds both ratios ran, and phi_J
    paired by seed against the first ratio of the file."""
    from scipy.stats import ks_2samp

    rows = list(csv.DictReader(path.open()))
    for key in sorted({(int(r["n"]), int(r["dim"])) for r in rows}):
        sub = [r for r in rows if (int(r["n"]), int(r["dim"])) == key]
        ratios = list(dict.fromkeys(float(r["newton_ratio"]) for r in sub))
        by = {q: {int(r["seed"]): r for r in sub if float(r["newton_ratio"]) == q} for q in ratios}
        base = ratios[0]
        for q in ratios:
            seeds = sorted(set(by[q]) & set(by[base]))
            cpu = sum(float(by[q][s]["cpu_s"]) for s in seeds)
            its = sum(int(by[q][s]["iterations"]) for s in seeds)
            largest = max(int(by[q][s]["largest"]) for s in seeds)
            checks = sum(by[q][s]["checks"] == "True" for s in seeds)
            line = (f"N = {key[0]} ({key[1]}D), ratio {q:g}, seeds {len(seeds)}: {cpu:.1f} CPU s, {its} iterations, "
                    f"largest minimisation {largest}, checks {checks}/{len(seeds)}")
            if q != base and len(seeds) > 1:
                a = np.array([float(by[base][s]["phi_j"]) for s in seeds])
                b = np.array([float(by[q][s]["phi_j"]) for s in seeds])
                d = b - a
                line += (f"; phi_J - phi_J(ratio {base:g}) = {d.mean():+.2e} +- {d.std(ddof=1) / np.sqrt(len(d)):.2e} "
                         f"(s.e.), spread of phi_J {a.std(ddof=1):.2e}, KS p = {ks_2samp(a, b).pvalue:.3f}")
            print(line)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dim", type=int, default=2)
    ap.add_argument("--n", type=int, nargs="+", default=[1024])
    ap.add_argument("--seeds", default="1:6", help="a seed, or LO:HI for LO .. HI-1")
    ap.add_argument("--ratios", type=float, nargs="+", default=[10.0, 3.0])
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--trace", type=Path, default=None, metavar="CSV", help="also a row per minimisation as it ends")
    ap.add_argument("--summary", type=Path, default=None, metavar="CSV", help="only print the summary of this CSV")
    args = ap.parse_args(argv)
    if args.summary is not None:
        summary(args.summary)
        return
    if args.out is None:
        raise SystemExit("error: --out CSV is required (rows are appended)")
    check_outputs(args.out, args.trace)
    for n in args.n:
        for seed in seeds_of(args.seeds):
            for ratio in args.ratios:
                row = jam_row(n, args.dim, seed, ratio, args.trace)
                append_row(args.out, COLUMNS, row)
                print(row, flush=True)


if __name__ == "__main__":
    main()
