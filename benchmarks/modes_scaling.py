"""Timing of the stability analysis against N (2D bidisperse disks above jamming, phi = 0.86).

For each N: a random packing minimised with LAMMPS FIRE, then wall-clock seconds of
Contacts, DynamicalMatrix, the dense spectrum (all modes; up to --dense-max particles), the
sparse shift-invert spectrum (lowest 32 modes) and Stability (Delta V profile). Set
OPENBLAS_NUM_THREADS=1 on a shared machine: threaded LAPACK under load was 30x slower here.

Usage: OPENBLAS_NUM_THREADS=1 python benchmarks/modes_scaling.py [--sizes 256 1024 4096] [--dense-max 1024]
"""

from __future__ import annotations

import argparse
import time

from jamflow.mechanics.contacts import Contacts
from jamflow.mechanics.dynamical_matrix import DynamicalMatrix
from jamflow.analysis.modes import Spectrum, Stability
from jamflow.engines.lammps.engine import LammpsEngine
from jamflow.model.packing import random_packing
from jamflow.model.sizes import parse_sizes
from jamflow.minimize.rules import minimize


def timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", default=[256, 1024, 4096])
    ap.add_argument("--dense-max", type=int, default=1024)
    args = ap.parse_args(argv)
    print(f"{'N':>6} {'contacts':>9} {'hessian':>8} {'dense':>8} {'sparse32':>9} {'stability':>9}  lowest e (sparse)")
    for n in args.sizes:
        start = random_packing(n, 2, parse_sizes("bi:1.4:0.5"), 0.86, seed=n)
        with LammpsEngine(start) as eng:
            minimize(eng)
            packing = eng.packing()
        _, t_contacts = timed(lambda: Contacts().compute(packing))
        dyn, t_hessian = timed(lambda: DynamicalMatrix().compute(packing))
        dense = "-"
        if n <= args.dense_max:
            _, t_dense = timed(lambda: Spectrum(method="dense").from_matrix(dyn))
            dense = f"{t_dense:8.2f}"
        sparse, t_sparse = timed(lambda: Spectrum(method="sparse", n_modes=32).from_matrix(dyn))
        _, t_stab = timed(lambda: Stability().compute(packing, sparse))
        print(f"{n:>6} {t_contacts:9.3f} {t_hessian:8.3f} {dense:>8} {t_sparse:9.2f} {t_stab:9.3f}  "
              f"{sparse.lowest_nonzero:.3e}", flush=True)


if __name__ == "__main__":
    main()
