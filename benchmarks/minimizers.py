"""Time one 2D bidisperse packing per minimiser (FIRE, CG, damped MD) and size.

    python benchmarks/minimizers.py --n 256 1024 --protocol seed --out docs/minimizers.csv

Reports seconds, minimisations, total minimiser iterations and phi_J, one row per run
(appended; rows already present are skipped, so an interrupted sweep resumes). A run
that exceeds --max-seconds is stopped and recorded as such.
"""

from __future__ import annotations

import argparse
import csv
import multiprocessing as mp
from pathlib import Path

from jamflow import jam
from jamflow.minimize.settings import METHODS, MinimizerSettings
from jamflow.protocols.settings import PROTOCOLS


def one_run(queue, n, method, protocol, seed):
    settings = PROTOCOLS[protocol](minimizer=MinimizerSettings(method=method))
    r = jam(n=n, dim=2, sizes="bi:1.4:0.5", seed=seed, settings=settings)
    queue.put([f"{r.seconds:.3f}", r.minimizations, r.iterations, repr(r.phi_j), r.energy_per_particle, r.max_force])


def timed(n, method, protocol, seed, limit):
    queue = mp.Queue()
    proc = mp.Process(target=one_run, args=(queue, n, method, protocol, seed))
    proc.start()
    proc.join(limit)
    if proc.is_alive():
        proc.terminate()
        return [f">{limit}", "", "", "", "", ""]
    return queue.get() if not queue.empty() else ["failed", "", "", "", "", ""]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, nargs="+", default=[256, 1024])
    ap.add_argument("--methods", nargs="+", default=list(METHODS))
    ap.add_argument("--protocol", choices=sorted(PROTOCOLS), default="fast")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--max-seconds", type=float, default=600.0)
    ap.add_argument("--out", default="docs/minimizers.csv")
    args = ap.parse_args()
    out = Path(args.out)
    done = {(r["n"], r["method"], r["protocol"]) for r in csv.DictReader(out.open())} if out.exists() else set()
    with out.open("a", newline="") as fh:
        w = csv.writer(fh)
        if not done:
            w.writerow(["n", "method", "protocol", "seed", "seconds", "minimizations", "iterations", "phi_j", "v", "max_force"])
        for n in args.n:
            for method in args.methods:
                if (str(n), method, args.protocol) in done:
                    continue
                row = [n, method, args.protocol, args.seed, *timed(n, method, args.protocol, args.seed, args.max_seconds)]
                w.writerow(row)
                fh.flush()
                print(*row, flush=True)


if __name__ == "__main__":
    main()
