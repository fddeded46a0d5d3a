"""Early decisions (issue 27 item 1): the fast protocol with and without ``early_decisions``
(``jamflow.minimize.stall``) on the same seeds: FIRE iterations by phase, minimisations stopped
"stalled", phi_J (mean +- standard error, the paired difference, and how many seeds land on the
same onset within the window's resolution in phi, ~1e-8), and the packing checks.

    python benchmarks/early_decisions.py --n 256 --seeds 0-19 --out docs/notes/early-decisions-n256.csv
    python benchmarks/early_decisions.py --n 1024 --seeds 1-5 --out docs/notes/early-decisions-n1024.csv
    python benchmarks/early_decisions.py --report docs/notes/early-decisions-n256.csv

Rows are appended as runs end and skipped when present (resumable). Iteration counts do not
depend on the machine's load; ``seconds`` (wall, in process) does.
"""

from __future__ import annotations

import argparse
import statistics

from jamflow import jam
from jamflow.mechanics.checks import check_packing
from jamflow.protocols.settings import fast_protocol

from common import append_row, phase_iterations, read_rows, stats  # (benchmarks/ is the script's directory)

COLUMNS = ["n", "seed", "early", "phi_j", "v", "iterations", "compress", "approach", "final", "stalled",
           "stalled_iterations", "minimizations", "checks", "seconds"]
SAME_ONSET = 1e-8  # |phi_J difference| below this: the same onset (the window's width in phi, chapter step 4)


def run(n: int, seed: int, early: bool) -> dict:
    settings = fast_protocol(early_decisions=early)
    r = jam(n=n, seed=seed, settings=settings)
    h = r.history
    stalled = h["reason"] == b"stalled"
    checks = check_packing(r.packing, r.energy_per_particle, None, settings.v_tol)
    return dict(n=n, seed=seed, early=int(early), phi_j=repr(r.phi_j), v=r.energy_per_particle, iterations=r.iterations,
                **phase_iterations(h, settings.v_tol), stalled=int(stalled.sum()),
                stalled_iterations=int(h["iterations"][stalled].sum()), minimizations=r.minimizations,
                checks=checks.passed, seconds=f"{r.seconds:.3f}")


def report(rows) -> None:
    by = {(int(r["early"]), int(r["seed"])): r for r in rows}
    seeds = sorted(s for e, s in by if e == 0 and (1, s) in by)
    if not seeds:
        print("no seed with both runs yet")
        return
    for early in (0, 1):
        runs = [by[early, s] for s in seeds]
        mean, se, k = stats(float(r["phi_j"]) for r in runs)
        med = {c: statistics.median(int(r[c]) for r in runs) for c in ("iterations", "compress", "approach", "final")}
        total = sum(int(r["iterations"]) for r in runs)
        print(f"early={early}: k={k} phi_J = {mean:.6f} +- {se:.6f}; iterations total {total:,}, median "
              f"{med['iterations']:,.0f} (compress {med['compress']:,.0f} / approach {med['approach']:,.0f} / final "
              f"{med['final']:,.0f}); stalled minimisations {sum(int(r['stalled']) for r in runs)}; checks passed "
              f"{sum(r['checks'] == 'True' for r in runs)}/{k}")
    diffs = [float(by[1, s]["phi_j"]) - float(by[0, s]["phi_j"]) for s in seeds]
    dmean, dse, _ = stats(diffs)
    ratio = [int(by[1, s]["iterations"]) / int(by[0, s]["iterations"]) for s in seeds]
    same = sum(abs(d) < SAME_ONSET for d in diffs)
    print(f"paired phi_J difference (early - not) {dmean:+.2e} +- {dse:.2e}; same onset (|d| < {SAME_ONSET:g}) "
          f"{same}/{len(seeds)}; iterations early/not median {statistics.median(ratio):.3f} "
          f"(min {min(ratio):.3f}, max {max(ratio):.3f})")
    for s, d, q in zip(seeds, diffs, ratio):
        print(f"  seed {s}: d phi_J = {d:+.2e}, iterations x {q:.3f}")


def seed_list(text: str) -> list[int]:
    """'0-19' or '1,2,5' -> seeds."""
    if "-" in text:
        lo, hi = text.split("-")
        return list(range(int(lo), int(hi) + 1))
    return [int(s) for s in text.split(",")]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=256)
    ap.add_argument("--seeds", type=seed_list, default=seed_list("1-5"))
    ap.add_argument("--out", default="docs/notes/early-decisions.csv")
    ap.add_argument("--report", metavar="CSV", help="only summarise this CSV")
    args = ap.parse_args(argv)
    if args.report:
        return report(read_rows(args.report))
    done = {(r["n"], r["seed"], r["early"]) for r in read_rows(args.out)}
    for seed in args.seeds:
        for early in (0, 1):
            if (str(args.n), str(seed), str(early)) not in done:
                append_row(args.out, COLUMNS, run(args.n, seed, bool(early)))
    report([r for r in read_rows(args.out) if int(r["n"]) == args.n])


if __name__ == "__main__":
    main()
