"""Microseconds per FIRE iteration of the compiled engine: the ellipse kernel (every contact
method) against the disk kernel at the same N, and LAMMPS's damped dynamics with the plugin
(microseconds per step) for scale.

    flock /tmp/jamflow-bench.lock python benchmarks/ellipse_kernel_speed.py --out docs/notes/ellipse-kernel-speed.csv

Two states per case: ``random``, a random overcompressed start (2D, 2:1 bidisperse, size ratio
1.4, phi = 0.9; every listed pair overlaps, particles travel, the pair list is rebuilt often)
and ``minimum``, that start minimised by FIRE (max force 1e-10) and compressed by 1e-4 (contacts
as in a packing above onset, few rebuilds). Each runs a fixed number of iterations (the force
tolerance is set unreachably low), best of ``--repeat``; CPU time of this process
(time.process_time; LAMMPS runs in process), pair-list rebuilds included. The load average is
recorded with each row.
"""

from __future__ import annotations

import argparse
import os
import time

from jamflow.engines.compiled.engine import CompiledEngine
from jamflow.engines.lammps.engine import LammpsEngine
from jamflow.minimize.settings import MinimizerSettings
from jamflow.model.packing import random_packing
from jamflow.model.potentials import Spring
from jamflow.model.shapes import SPHERE, Ellipsoid
from jamflow.model.sizes import parse_sizes
from jamflow.minimize.rules import minimize
from common import scratch, merge_rows  # (benchmarks/ is the script's directory)

CASES = [("disk", None), ("ellipse", "exact"), ("ellipse", "cleaver"), ("ellipse", "linear"),
         ("ellipse", "quadratic")]


def start(n, shape, state="random", seed=1):
    p = random_packing(n, 2, parse_sizes("bi:1.4:0.6667"), 0.9, seed, Spring(), shape)
    if state == "random":
        return p
    with CompiledEngine(p) as eng:
        minimize(eng, MinimizerSettings(force_tol=1e-10))
        return eng.packing().scaled_to_phi(p.phi * (1 + 1e-4))


def time_fire(p, iterations):
    settings = MinimizerSettings(force_tol=1e-300, max_iterations=iterations, window=iterations)
    with CompiledEngine(p) as eng:
        minimize(eng, MinimizerSettings(force_tol=1e-300, max_iterations=10, window=10))  # compile, first list
        t = time.process_time()
        r = minimize(eng, settings)
        return 1e6 * (time.process_time() - t) / r.iterations


def time_lammps_md(p, steps):
    settings = MinimizerSettings(method="md", force_tol=1e-300, max_iterations=steps, window=steps)
    with LammpsEngine(p) as eng:
        t = time.process_time()
        r = minimize(eng, settings)
        return 1e6 * (time.process_time() - t) / r.iterations


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, nargs="+", default=[128, 512, 2048])
    ap.add_argument("--alpha", type=float, default=1.6)
    ap.add_argument("--iterations", type=int, default=2000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", default=str(scratch("ellipse-kernel-speed.csv")))
    args = ap.parse_args(argv)
    rows = []
    for n in args.n:
        for state in ("random", "minimum"):
            base = None
            for kind, method in CASES:
                shape = SPHERE if kind == "disk" else Ellipsoid(args.alpha, method)
                p = start(n, shape, state)
                us = min(time_fire(p, args.iterations) for _ in range(args.repeat))
                base = us if kind == "disk" else base
                rows.append(dict(n=n, state=state, engine="numba FIRE", shape=kind, contact=method or "",
                                 alpha=args.alpha if method else 1, us_per_iteration=f"{us:.2f}",
                                 ratio_to_disk=f"{us / base:.2f}", load=f"{os.getloadavg()[0]:.1f}"))
                print(rows[-1], flush=True)
            p = start(n, Ellipsoid(args.alpha), state)
            us = min(time_lammps_md(p, args.iterations) for _ in range(args.repeat))
            rows.append(dict(n=n, state=state, engine="LAMMPS md (plugin)", shape="ellipse", contact="exact",
                             alpha=args.alpha, us_per_iteration=f"{us:.2f}", ratio_to_disk=f"{us / base:.2f}",
                             load=f"{os.getloadavg()[0]:.1f}"))
            print(rows[-1], flush=True)
    merge_rows(args.out, rows)  # added to the rows of earlier runs


if __name__ == "__main__":
    main()
