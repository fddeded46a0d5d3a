"""Analytic dynamical matrix against LAMMPS ``dynamical_matrix`` (central finite differences of
LAMMPS forces, ``regular`` style: divided by sqrt(m_i m_j) = 1) on stored packings, for several
finite-difference steps h. Reports the largest difference over the whole matrix and over the
contact blocks whose overlap sigma - r exceeds 10 h (where a central difference stays in
contact). At onset (overlaps 1e-12 to 4e-8) a step larger than an overlap opens that contact
during the difference, so only those blocks can agree.

Usage: python benchmarks/modes_hessian_check.py PACKING.h5 [...] [--steps 1e-5 1e-9 1e-10]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from jamflow.mechanics.hessian import hessian
from jamflow.engines.lammps.engine import LammpsEngine
from jamflow.io.packing_file import load_packing
from jamflow.model.pairs import overlapping_pairs


def lammps_matrix(packing, step: float) -> np.ndarray:
    with tempfile.TemporaryDirectory() as tmp, LammpsEngine(packing) as eng:
        out = Path(tmp) / "dynmat.bin"
        eng.command(f"dynamical_matrix all regular {step:g} file {out} binary yes")
        raw = np.fromfile(out).reshape(3 * packing.n, 3 * packing.n)
    idx = (np.arange(packing.n)[:, None] * 3 + np.arange(packing.dim)).ravel()
    return raw[np.ix_(idx, idx)]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("files", nargs="+")
    ap.add_argument("--steps", type=float, nargs="+", default=[1e-5, 1e-9, 1e-10])
    args = ap.parse_args(argv)
    for path in args.files:
        p = load_packing(path)
        h = hessian(p).toarray()
        i, j, _, r, sigma = overlapping_pairs(p)
        overlap, d = sigma - r, p.dim
        print(f"{path}: N = {p.n}, max |M| = {np.abs(h).max():.3f}, overlaps {overlap.min():.1e} .. {overlap.max():.1e}")
        for step in args.steps:
            diff = np.abs(lammps_matrix(p, step) - h)
            ok = overlap > 10 * step
            blocks = [diff[d * a:d * a + d, d * b:d * b + d].max() for a, b in zip(i[ok], j[ok])]
            print(f"  h = {step:.0e}: max diff all {diff.max():.2e}; contact blocks with overlap > 10 h "
                  f"({ok.sum()}/{len(i)}): {max(blocks, default=float('nan')):.2e}")


if __name__ == "__main__":
    main()
