"""LAMMPS FIRE against the compiled FIRE (CompiledEngine), side by side in one run.

1. Cost per FIRE iteration: the same overcompressed 2D bidisperse state (phi = 0.85, relaxed
   first so that the pair list is stable, as near jamming), ``--iterations`` FIRE iterations
   per engine, engines interleaved ``--reps`` times; min and median microseconds.
2. Whole packings: ``jam()`` with the default (fast) protocol on each engine, same seeds.
   The engines run the same algorithm but sum forces in a different order, so from the same
   start they may end in different minima (phi_J differs per seed, not in distribution:
   docs/notes/protocol-bias-n1024.csv).

    python benchmarks/engines.py --sizes 256 1024 4096 --jam-n 1024 --jam-seeds 3 --out docs/notes/engines.csv

The numba kernels are compiled (or loaded from cache) before timing. Run it on an otherwise
idle machine: on this project's 2-core machine a busy second core halves single-core speed.
"""

from __future__ import annotations

import argparse
import statistics

from jamflow import jam
from jamflow.engines.lammps.engine import LammpsEngine
from jamflow.engines.compiled.engine import CompiledEngine
from jamflow.minimize.settings import MinimizerSettings
from jamflow.protocols.compression import initial_packing
from jamflow.minimize.rules import minimize
from common import scratch, merge_rows  # (benchmarks/ is the script's directory)

ENGINES = {"lammps": LammpsEngine, "numba": CompiledEngine}


def near_jamming_state(n: int, seed: int = 0):
    start = initial_packing(n, 2, "bi:1.4:0.5", "spring", seed, 0.85)
    with CompiledEngine(start) as eng:
        minimize(eng, MinimizerSettings(force_tol=1e-9, max_iterations=200_000))
        return eng.packing()


def microseconds_per_iteration(engine_cls, packing, iterations: int) -> float:
    with engine_cls(packing) as eng:
        r = minimize(eng, MinimizerSettings(force_tol=1e-300, max_iterations=iterations, window=iterations))
    return r.seconds / r.iterations * 1e6


def per_iteration_rows(sizes, iterations, reps):
    rows = []
    for n in sizes:
        state = near_jamming_state(n)
        times = {name: [] for name in ENGINES}
        for _ in range(reps):
            for name, cls in ENGINES.items():
                times[name].append(microseconds_per_iteration(cls, state, iterations))
        lam, nb = statistics.median(times["lammps"]), statistics.median(times["numba"])
        print(f"N = {n:5d}: us per FIRE iteration  lammps median {lam:7.1f} (min {min(times['lammps']):7.1f})  "
              f"numba median {nb:7.1f} (min {min(times['numba']):7.1f})  ratio {lam / nb:.2f}", flush=True)
        rows.append(["per-iteration", n, "", f"{lam:.2f}", f"{nb:.2f}", f"{lam / nb:.3f}", "", ""])
    return rows


def jam_rows(n, seeds):
    rows = []
    for seed in range(seeds):
        out = {}
        for name in ENGINES:
            r = jam(n=n, seed=seed, engine=name)
            out[name] = r
            print(f"N = {n} seed {seed} {name:6s}: {r.summary()}", flush=True)
        lam, nb = out["lammps"], out["numba"]
        rows.append(["jam", n, seed, f"{lam.seconds:.3f}", f"{nb.seconds:.3f}", f"{lam.seconds / nb.seconds:.3f}",
                     f"{lam.seconds / lam.iterations * 1e6:.2f}",
                     f"{nb.seconds / nb.iterations * 1e6:.2f}"])
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="*", default=[256, 1024, 4096])
    ap.add_argument("--iterations", type=int, default=5000)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--jam-n", type=int, default=1024)
    ap.add_argument("--jam-seeds", type=int, default=0)
    ap.add_argument("--out", default=str(scratch("engines.csv")))
    args = ap.parse_args(argv)
    microseconds_per_iteration(CompiledEngine, near_jamming_state(64), 10)  # compile / load the kernels
    rows = per_iteration_rows(args.sizes, args.iterations, args.reps)
    if args.jam_seeds:
        rows += jam_rows(args.jam_n, args.jam_seeds)
    columns = ["measure", "n", "seed", "lammps", "numba", "ratio", "lammps_us_per_iteration", "numba_us_per_iteration"]
    merge_rows(args.out, [dict(zip(columns, row)) for row in rows], columns)  # added to the rows of earlier runs
    print(f"wrote {args.out} (per-iteration rows: microseconds; jam rows: seconds)")


if __name__ == "__main__":
    main()
