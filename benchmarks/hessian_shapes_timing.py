"""CPU seconds to build the sparse dynamical matrix (``jamflow.mechanics.hessian.hessian``) of
random overlapping packings of every shape against N (the cost depends on the number of
overlapping pairs, not on whether the packing is jammed): disks, dimers (2 sites), trimers
(3 sites, 3D), ellipses (alpha 1.5) and prolate spheroids (alpha 1.5), bidisperse bi:1.4:0.5,
at packing fractions with a few contacts per particle. Prints N, d_f N, overlapping pairs (site
pairs for bodies), nonzeros, CPU seconds (median of 3).

Usage: OPENBLAS_NUM_THREADS=1 python benchmarks/hessian_shapes_timing.py [--sizes 256 1024 4096]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from jamflow.mechanics.hessian import hessian
from jamflow.model.packing import random_packing
from jamflow.model.pairs import overlapping_pairs, overlapping_sites
from jamflow.model.shapes import SPHERE, Ellipsoid, RigidBody
from jamflow.model.sizes import parse_sizes

SHAPES = {  # name -> (dim, shape, phi)
    "disk": (2, SPHERE, 0.86),
    "dimer-2d": (2, RigidBody([[0, 0], [0.5, 0]], [1, 1], "dimer:1.5"), 0.86),
    "ellipse": (2, Ellipsoid(1.5), 0.86),
    "trimer-3d": (3, RigidBody([[0, 0, 0], [0.6, 0, 0], [0.3, 0.45, 0]], [1, 0.9, 0.8], "trimer"), 0.65),
    "spheroid": (3, Ellipsoid(1.5), 0.65),
}


def cpu(fn, repeat=3):
    times = []
    for _ in range(repeat):
        t0 = time.process_time()
        out = fn()
        times.append(time.process_time() - t0)
    return out, float(np.median(times))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[256, 1024, 4096])
    ap.add_argument("--shapes", nargs="+", default=list(SHAPES))
    args = ap.parse_args(argv)
    print(f"{'shape':>10} {'N':>6} {'d_f N':>7} {'pairs':>7} {'nnz':>9} {'CPU s':>7}")
    for name in args.shapes:
        dim, shape, phi = SHAPES[name]
        for n in args.sizes:
            p = random_packing(n, dim, parse_sizes("bi:1.4:0.5"), phi, seed=n, shape=shape)
            pairs = len((overlapping_sites(p) if shape.kind == "rigid" else overlapping_pairs(p))[0])
            m, seconds = cpu(lambda: hessian(p))
            print(f"{name:>10} {n:>6} {m.shape[0]:>7} {pairs:>7} {m.nnz:>9} {seconds:7.2f}", flush=True)


if __name__ == "__main__":
    main()
