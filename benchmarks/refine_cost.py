"""Cost of the double-double refinement (jamflow.refine, docs/guide/precision.md) against the float64 onset it starts
from: for each N and seed, ``jamflow.jam(n=N, seed=s)`` then ``jamflow.refine(onset.packing, P)``;
seconds of each (wall clock: label it "under load" on a shared machine), minimisation iterations,
refined states and Newton steps, N_c against N' d - d + 1, contacts opened/closed, max|F| / <f>;
a refinement that fails is a row with its error.

    python benchmarks/refine_cost.py                              (N = 64, 256; seeds 1-3; P = 1e-14)
    python benchmarks/refine_cost.py --n 64 --seeds 1 --out X.csv (the quick mode)
    python benchmarks/refine_cost.py --n 256 --seeds 10           (seeds 1-10)
"""

from __future__ import annotations

import argparse
import sys
import time

import jamflow

from common import merge_rows  # (benchmarks/ is the script's directory)

COLUMNS = ["n", "seed", "target", "onset_seconds", "onset_iterations", "refine_seconds", "states", "newton_steps",
           "n_contacts", "isostatic", "opened", "closed", "force_balance", "pressure", "error"]


def one(n: int, seed: int, target: float) -> dict:
    t0 = time.perf_counter()
    onset = jamflow.jam(n=n, seed=seed, engine="numba")
    t1 = time.perf_counter()
    row = {"n": n, "seed": seed, "target": target, "onset_seconds": f"{t1 - t0:.2f}", "onset_iterations": onset.iterations}
    try:
        r = jamflow.refine(onset.packing, target)
    except jamflow.JammingFailed as err:
        return row | {"refine_seconds": f"{time.perf_counter() - t1:.2f}", "error": str(err)}
    t2 = time.perf_counter()
    opened, closed = r.contact_changes()
    return row | {"refine_seconds": f"{t2 - t1:.2f}", "states": len(r.history["pressure"]),
                  "newton_steps": int(r.history["newton_steps"].sum()), "n_contacts": r.n_contacts,
                  "isostatic": r.isostatic_contacts, "opened": len(opened), "closed": len(closed),
                  "force_balance": f"{r.force_balance:.2e}", "pressure": f"{r.pressure:.6e}"}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, nargs="+", default=[64, 256])
    ap.add_argument("--seeds", type=int, default=3, help="seeds 1 .. SEEDS")
    ap.add_argument("--pressure", type=float, default=1e-14)
    ap.add_argument("--out", default=None, help="CSV to write (default: print only)")
    args = ap.parse_args(argv)
    rows = []
    for n in args.n:
        for seed in range(1, args.seeds + 1):
            rows.append(one(n, seed, args.pressure))
            print("  ".join(f"{k}={v}" for k, v in rows[-1].items()), flush=True)
    if args.out:
        merge_rows(args.out, rows, COLUMNS)  # added to the rows of earlier runs
    return 0


if __name__ == "__main__":
    sys.exit(main())
