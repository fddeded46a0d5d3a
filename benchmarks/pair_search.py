"""Cost of the float64 pair search (jamflow.model.pairs.neighbor_pairs) in orthogonal and sheared
cells, beside the float32 freud search it replaced for tilted cells.

Random bidisperse disks (diameters 1 and 1.4) or spheres at phi = 0.84 (2D) / 0.64 (3D),
rmax = 1.4 + 0.3 (largest diameter + the compiled engine's default skin). Sheared cells carry
an accumulated strain of 2.3 (reduced tilt 0.3). CPU seconds (``time.process_time``), median
of ``--reps``. The freud column is the removed code path (``AABBQuery`` on float32 positions
with r_max + 1e-5), timed for comparison only; "missed" counts pairs closer than rmax that it
did not return (float32 round-off beyond its 1e-5 pad).

    flock /tmp/jamflow-bench.lock python benchmarks/pair_search.py --out docs/notes/pair-search.csv
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

from jamflow.model.box import Box
from jamflow.model.pairs import neighbor_pairs
from tqdm import tqdm

from common import merge_rows  # (benchmarks/ is the script's directory)


def configuration(n: int, dim: int, strain: float, seed: int = 0):
    rng = np.random.default_rng(seed)
    d = np.where(np.arange(n) % 2 == 0, 1.0, 1.4)
    vol = (np.pi * d**2 / 4).sum() if dim == 2 else (np.pi * d**3 / 6).sum()
    side = (vol / (0.84 if dim == 2 else 0.64)) ** (1 / dim)
    h = np.eye(dim) * side
    h[0, 1] = strain * side
    box = Box(h)
    return box.to_cartesian(rng.random((n, dim))), box


def freud_pairs(x, box, rmax):
    """The removed float32 search: freud AABB query, 1e-5 pad."""
    import freud

    fbox = box.to_freud()
    pts = x if box.dim == 3 else np.column_stack([x, np.zeros(len(x))])
    pts = fbox.wrap(pts.astype(np.float32))
    nlist = freud.locality.AABBQuery(fbox, pts).query(pts, dict(r_max=rmax + 1e-5, exclude_ii=True)).toNeighborList()
    pairs = np.column_stack([nlist.query_point_indices, nlist.point_indices]).astype(int)
    return np.unique(np.sort(pairs, axis=1), axis=0)


def cpu_seconds(fn, reps):
    times = []
    for _ in range(reps):
        t = time.process_time()
        out = fn()
        times.append(time.process_time() - t)
    return statistics.median(times), out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[1024, 4096, 16384, 65536])
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    rmax = 1.4 + 0.3
    freud_pairs(*configuration(64, 2, 0.3), rmax)  # import and first-call set-up, not timed
    rows = []
    cases = [(dim, n, strain) for dim in (2, 3) for n in args.sizes for strain in (0.0, 2.3)]
    for dim, n, strain in tqdm(cases, desc="pair search", unit="case"):
        x, box = configuration(n, dim, strain)
        t64, (i, j, _) = cpu_seconds(lambda: neighbor_pairs(x, box, rmax), args.reps)
        t32, pairs = cpu_seconds(lambda: freud_pairs(x, box, rmax), args.reps)
        missed = len(set(zip(i.tolist(), j.tolist())) - set(map(tuple, pairs.tolist())))
        rows.append(dict(dim=dim, n=n, strain=strain, side=f"{box.lengths[0]:.2f}", pairs=len(i),
                         neighbor_pairs_s=f"{t64:.5f}", freud_float32_s=f"{t32:.5f}", freud_missed=missed))
        print(rows[-1], flush=True)
    if args.out:
        merge_rows(args.out, rows)  # added to the rows of earlier runs


if __name__ == "__main__":
    main()
