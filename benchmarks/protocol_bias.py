"""Does a protocol shortcut bias phi_J? Every variant is run on the same seeds (same random
start) as the chapter's exact protocol; mean phi_J +- standard error per variant, and the
paired difference to the exact protocol, as CSV and a PNG chart.

    python benchmarks/protocol_bias.py --n 256 --seeds 20 --out docs/notes/protocol-bias-n256.csv

Every packing is checked (``jamflow.mechanics.checks.check_packing``: window, force balance, contact
count; the ``checks`` column). To rerun one variant against stored rows of another, start the
CSV with those rows (``--variants fast`` on a file holding the ``seed`` rows).

Variants are entries of VARIANTS (name -> CompressionSettings overrides): adding a shortcut is
one more line. Rows are appended as they finish and skipped when present (resumable).
"""

from __future__ import annotations

import argparse
import csv
import statistics
from pathlib import Path

from jamflow import jam
from jamflow.mechanics.checks import check_packing
from jamflow.protocols.settings import FAST_PROTOCOL, CompressionSettings
from common import scratch  # (benchmarks/ is the script's directory)

VARIANTS = {
    "seed": {},
    "fast": FAST_PROTOCOL,
    "fast, no Newton": {**FAST_PROTOCOL, "newton": False},
    "fast, no growth": {**FAST_PROTOCOL, "dphi_growth": 1.0},
    "fast, growth 1.2": {**FAST_PROTOCOL, "dphi_growth": 1.2},
    "growth only": {"dphi_growth": 2.0},
    "fast, dphi_max 1e-2": {**FAST_PROTOCOL, "dphi_max": 1e-2},
}


def run(n, dim, sizes, variant, seed):
    settings = CompressionSettings(**VARIANTS[variant])
    res = jam(n=n, dim=dim, sizes=sizes, seed=seed, settings=settings)
    checks = check_packing(res.packing, res.energy_per_particle, None, settings.v_tol)  # max force recomputed
    return [variant, n, seed, repr(res.phi_j), res.energy_per_particle, res.max_force, res.minimizations,
            res.iterations, f"{res.seconds:.3f}", res.engine, checks.passed]


def summary(rows):
    """{variant: (mean, standard error, paired mean difference to 'seed', its SE, median seconds, k)}."""
    by = {}
    for r in rows:
        by.setdefault(r["variant"], {})[int(r["seed"])] = (float(r["phi_j"]), float(r["seconds"]))
    out = {}
    for name, d in by.items():
        phi = [v[0] for v in d.values()]
        pairs = [d[s][0] - by["seed"][s][0] for s in d if s in by.get("seed", {})]
        se = statistics.stdev(phi) / len(phi) ** 0.5 if len(phi) > 1 else float("nan")
        dse = statistics.stdev(pairs) / len(pairs) ** 0.5 if len(pairs) > 1 else float("nan")
        out[name] = (statistics.mean(phi), se, statistics.mean(pairs) if pairs else float("nan"), dse,
                     statistics.median(v[1] for v in d.values()), len(phi))
    return out


def chart(stats, path, title):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(stats)
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 3.8))
    ax1.errorbar(range(len(names)), [stats[k][0] for k in names], yerr=[stats[k][1] for k in names], fmt="o", capsize=4)
    ax1.set_xticks(range(len(names)), names, rotation=20, ha="right")
    ax1.set_ylabel(r"mean $\phi_J$ $\pm$ s.e.")
    ax2.bar(range(len(names)), [stats[k][4] for k in names])
    ax2.set_xticks(range(len(names)), names, rotation=20, ha="right")
    ax2.set_ylabel("median seconds per packing (wall, in process)")  # JamResult.seconds
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=256)
    ap.add_argument("--dim", type=int, default=2)
    ap.add_argument("--sizes", default="bi:1.4:0.5")
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--variants", nargs="+", default=["seed", "fast"], choices=list(VARIANTS))
    ap.add_argument("--out", default=str(scratch("protocol-bias.csv")))
    args = ap.parse_args(argv)
    out = Path(args.out)
    done = {(r["variant"], r["seed"]) for r in csv.DictReader(out.open())} if out.exists() else set()
    with out.open("a", newline="") as fh:
        w = csv.writer(fh)
        if not done:
            w.writerow(["variant", "n", "seed", "phi_j", "v", "max_force", "minimizations", "iterations", "seconds",
                        "engine", "checks"])  # checks: window, force balance, contacts (files before s3: no column)
        for seed in range(args.seeds):
            for variant in args.variants:
                if (variant, str(seed)) not in done:
                    w.writerow(run(args.n, args.dim, args.sizes, variant, seed))
                    fh.flush()
    stats = summary(list(csv.DictReader(out.open())))
    for name, (mean, se, diff, dse, sec, k) in stats.items():
        print(f"{name:22s} k={k:3d}  phi_J = {mean:.5f} +- {se:.5f}   paired diff to seed = {diff:+.5f} +- {dse:.5f}"
              f"   median {sec:.2f} s")
    chart(stats, out.with_suffix(".png"), f"N = {args.n}, {args.dim}D, {args.sizes}: bias and cost per protocol")


if __name__ == "__main__":
    main()
