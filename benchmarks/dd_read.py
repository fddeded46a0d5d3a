"""A double-double packing file read back (docs/guide/precision.md): contacts, floaters, zero modes, G and the
pressure from hi + lo (what ``jamflow.load_packing`` gives) against its float64 positions alone, and
against the refinement itself (``RefineResult``: its double-double network, ``moduli()``, pressure).
For each N and seed: ``jamflow.jam(n=N, seed=s)``, ``jamflow.refine(packing, P)``, save, load.

    python benchmarks/dd_read.py                        (N = 64, 256; seed 1; P = 1e-14)
    python benchmarks/dd_read.py --n 64 --seeds 2 2     (N = 64 seed 2 only)
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

import jamflow
from jamflow.analysis.modes import Spectrum
from jamflow.mechanics.contacts import Contacts
from jamflow.mechanics.elastic import HessianModuli


def reading(packing) -> dict:
    """Contacts, floaters, zero modes, G and P of one packing (warnings about float64 silenced)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        c = Contacts().compute(packing)
        h = HessianModuli().compute(packing)
        s = Spectrum().compute(packing)
    return {"N_c": c.n_contacts, "floaters": c.n_floaters, "zero_modes": s.n_zero, "G": h.G,
            "P": float(np.trace(h.pressure_tensor)) / packing.dim}


def one(n: int, seed: int, target: float, folder: Path) -> str:
    r = jamflow.refine(jamflow.jam(n=n, seed=seed, engine="numba").packing, target)
    path = folder / f"n{n}-s{seed}.h5"
    r.save(path)
    packing = jamflow.load_packing(path)
    m = r.moduli()
    lines = [f"N = {n} seed {seed} refined to {target:g}: N_c = {r.n_contacts} (iso {r.isostatic_contacts}), "
             f"floaters {r.n_floaters}, G = {m.G:.6e}, P = {r.pressure:.6e}"]
    for label, p in (("file, hi + lo", packing), ("float64 positions", replace(packing, extended=None))):
        try:
            v = reading(p)
        except ValueError as err:  # e.g. every particle a floater
            lines.append(f"  {label:18s} {err}")
            continue
        lines.append(f"  {label:18s} N_c = {v['N_c']}, floaters {v['floaters']}, zero modes {v['zero_modes']}, "
                     f"G = {v['G']:.6e} (rel {v['G'] / m.G - 1:+.1e}), P = {v['P']:.6e} (rel {v['P'] / r.pressure - 1:+.1e})")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, nargs="+", default=[64, 256])
    ap.add_argument("--seeds", type=int, nargs=2, default=[1, 1], metavar=("FIRST", "LAST"))
    ap.add_argument("--pressure", type=float, default=1e-14)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.n:
            for seed in range(args.seeds[0], args.seeds[1] + 1):
                print(one(n, seed, args.pressure, Path(tmp)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
