"""Wall-clock cost of the structure analyses (float64 jamflow vs freud float32 where freud has it).

Usage: ``python benchmarks/structure_timing.py [--n 1024 4096]``. Random packings at phi = 0.84
(2D) / 0.64 (3D) stand in for jammed ones (the pair counts are what matters). Prints one line
per measurement; timings vary by 2x on a shared machine.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from jamflow.analysis.correlations import BondCorrelation
from jamflow.analysis.order import BondOrder
from jamflow.analysis.structure import RDF, StructureFactor
from jamflow.model.packing import random_packing
from jamflow.model.sizes import parse_sizes


def timed(label, fn, repeat=3):
    best = min(_once(fn) for _ in range(repeat))
    print(f"{label:55s} {best * 1e3:9.1f} ms", flush=True)


def _once(fn):
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--n", type=int, nargs="+", default=[1024, 4096])
    args = parser.parse_args(argv)
    import freud

    for dim, phi in ((2, 0.84), (3, 0.64)):
        for n in args.n:
            p = random_packing(n, dim, parse_sizes("bi:1.4:0.5"), phi, 0)
            tag = f"{dim}D N={n}"
            timed(f"{tag} g(r) to r = 4 (dr 0.02)", lambda: RDF(dr=0.02, r_max=4.0).compute(p))
            timed(f"{tag} g(r) to half box width", lambda: RDF(dr=0.02).compute(p), repeat=1)
            fbox = p.box.to_freud()
            pts = p.positions if dim == 3 else np.column_stack([p.positions, np.zeros(n)])
            pts = fbox.wrap(pts.astype(np.float32))

            def freud_rdf():
                freud.density.RDF(bins=250, r_max=4.0 * 1.2).compute((fbox, pts))

            timed(f"{tag} freud RDF to r = 4.8 (float32)", freud_rdf)
            timed(f"{tag} S(k), k_max = 20", lambda: StructureFactor(k_max=20.0).compute(p), repeat=1)
            timed(f"{tag} Q6 global/local (r_min 1.3)", lambda: BondOrder(r_min=1.3).compute(p))
            timed(f"{tag} q6 correlations to half box width", lambda: BondCorrelation(r_min=1.3).compute(p),
                  repeat=1)


if __name__ == "__main__":
    main()
