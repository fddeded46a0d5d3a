"""Jammed packings of dimers (compiled engine, ``jamflow.jam``) for the stability analysis of
docs/notes/modes-rotations.md: symmetric dimers of two unit sites with total length ALPHA (seed
Figure 2.9, alpha = L / D), bidisperse sizes bi:1.4:0.5 scaling whole bodies, linear springs,
random starts. Ellipse packings come from benchmarks/reference_jam.py until an engine jams them.

Usage: python benchmarks/modes_shapes_data.py --dim 2 --alpha 1.5 --n 64 --seeds 0 1 2 --out DIR
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from jamflow import jam
from jamflow.io.packing_file import save_packing
from jamflow.model.shapes import RigidBody


def dimer(dim: int, alpha: float) -> RigidBody:
    """Two sites of diameter 1 whose union is alpha long (centres alpha - 1 apart)."""
    return RigidBody([[0.0] * dim, [alpha - 1.0] + [0.0] * (dim - 1)], [1.0, 1.0], f"dimer:{alpha:g}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dim", type=int, default=2)
    ap.add_argument("--alpha", type=float, default=1.5)
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--seeds", type=int, nargs="+", default=[0])
    ap.add_argument("--out", required=True)
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for seed in args.seeds:
        t0 = time.process_time()
        res = jam(n=args.n, dim=args.dim, shape=dimer(args.dim, args.alpha), seed=seed)
        name = out / f"dimer{args.dim}d_a{args.alpha:g}_n{args.n}_s{seed}.h5"
        save_packing(name, res.packing, energy_per_particle=res.energy_per_particle,
                     pressure_tensor=res.pressure_tensor, history=res.history)
        print(f"{name}: phi_J {res.phi_j:.6f} V/N {res.energy_per_particle:.3e} "
              f"({time.process_time() - t0:.1f} s CPU)", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
