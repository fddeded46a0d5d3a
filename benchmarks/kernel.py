"""The compiled kernel against its floor (docs/notes/speed-2.md): microseconds per FIRE iteration
and per bare force loop over the same pairs, at N = 256 to 65536 (2D, 50:50 bidisperse,
a relaxed state at phi = 0.85, as near jamming), with the particles in their random order
and reordered along a Morton (Z-order) curve, and the FIRE iteration cost for several skins.

    python benchmarks/kernel.py --sizes 256 1024 4096 --out docs/notes/kernel.csv
    python benchmarks/kernel.py --sizes 16384 65536 --skins 0.3 --repeats 3 --out docs/notes/kernel-large-n.csv

``floor``: the disk kernel (``compiled.spheres.forces``) called in a compiled loop, i.e. the
pair loop alone, no integration, no Python. ``fire``: ``CompiledEngine`` FIRE iterations
(force_tol 1e-300, so it never stops; pair-list rebuilds included) per iteration. The
pair list holds every pair within sigma_ij + skin. CPU microseconds (process time), minimum
over ``--repeats``; run under ``flock /tmp/jamflow-bench.lock``. ``--source DIR`` is not an
option: to time another version of the kernel, run this script with PYTHONPATH=DIR.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

from common import append_row, scratch  # (benchmarks/ is the script's directory)

import numba
import numpy as np

from jamflow.engines.compiled import spheres, start_numba
from jamflow.engines.compiled.engine import CompiledEngine
from jamflow.minimize.settings import MinimizerSettings
from jamflow.protocols.compression import initial_packing
from jamflow.minimize.rules import minimize
from jamflow.model import ordering

start_numba()  # spheres.forces as a numba dispatcher (it is Deferred until numba starts), for _repeat


@numba.njit
def _repeat(pairs, x, o, f, tau, virial, reps):
    e = 0.0
    for _ in range(reps):
        e += spheres.forces(pairs, x, o, f, tau, virial)
    return e


def near_jamming_state(n: int, seed: int = 0, dim: int = 2, phi: float = 0.85):
    """A relaxed (|f| < 1e-9) 50:50 bidisperse state at packing fraction ``phi``."""
    start = initial_packing(n, dim, "bi:1.4:0.5", "spring", seed, phi)
    with CompiledEngine(start) as eng:
        minimize(eng, MinimizerSettings(force_tol=1e-9, max_iterations=200_000))
        return eng.packing()


def morton_order(packing) -> np.ndarray:
    """Particle order along the Morton (Z-order) curve of the cell, as large random starts are
    numbered (``jamflow.model.ordering``)."""
    return ordering.morton_order(packing.box.to_fractional(packing.box.wrap(packing.positions)))


def floor_us(packing, skin: float, reps: int, repeats: int) -> float:
    x = np.ascontiguousarray(packing.positions)
    pairs = spheres.build(packing, x, skin)
    n, d = x.shape
    f, o, tau, virial = np.zeros((n, d)), np.zeros((n, 0)), np.zeros((n, 0)), np.zeros((d, d))
    _repeat(pairs, x, o, f, tau, virial, 10)
    best = np.inf
    for _ in range(repeats):
        t0 = time.process_time()
        _repeat(pairs, x, o, f, tau, virial, reps)
        best = min(best, (time.process_time() - t0) / reps * 1e6)
    return best


def fire_us(packing, skin: float, iterations: int, repeats: int) -> float:
    best = np.inf
    for _ in range(repeats):
        with CompiledEngine(packing, skin=skin) as eng:
            t0 = time.process_time()
            r = minimize(eng, MinimizerSettings(force_tol=1e-300, max_iterations=iterations, window=iterations))
            best = min(best, (time.process_time() - t0) / r.iterations * 1e6)
    return best


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", default=[256, 1024, 4096])
    ap.add_argument("--skins", type=float, nargs="+", default=[0.1, 0.2, 0.3, 0.5])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out", default=str(scratch("kernel.csv")))
    args = ap.parse_args(argv)
    rows = []
    for n in args.sizes:
        state = near_jamming_state(n)  # (numbered along the curve from ordering.SPATIAL_ORDER_FROM on)
        shuffled = state.subset(np.random.default_rng(0).permutation(n))  # as a random start is drawn
        ordered = state.subset(morton_order(state))
        iterations, reps = max(2000, 2_000_000 // n), max(200, 4_000_000 // n)
        for order, packing in (("random", shuffled), ("morton", ordered)):
            for skin in args.skins:
                row = {"n": n, "order": order, "skin": skin,
                       "floor_us": round(floor_us(packing, skin, reps, args.repeats), 3),
                       "fire_us": round(fire_us(packing, skin, iterations, args.repeats), 3),
                       "pairs": len(spheres.build(packing, packing.positions, skin).i),
                       "load": round(os.getloadavg()[0], 2)}
                row["fire_over_floor"] = round(row["fire_us"] / row["floor_us"], 2)
                print(" ".join(f"{k}={v}" for k, v in row.items()), flush=True)
                rows.append(row)
    for row in rows:
        append_row(Path(args.out), list(rows[0]), row)


if __name__ == "__main__":
    main()
