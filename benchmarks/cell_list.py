"""A compiled cell-list pair search (issue 17, start-up item: "a numba cell-list pair search so
a compiled jam does not import scipy.spatial"): measured in docs/speed-2.md 7.1 (not kept then, as
numba's own start-up cost more than scipy.spatial), now ``jamflow.engine.compiled.cells``, compiled
ahead of time with the disk kernels (section 12).

It was the orthogonal branch of ``jamflow.pairs.neighbor_pairs`` on this branch for a while
(commit 1506453): the same pair set as scipy's periodic cKDTree (the same distance test: per
axis the difference folded into [-L/2, L/2], squared distance <= rmax^2), so jams stayed
bit-identical. Measured: no whole-process gain for ``jamflow jam --n 64`` (numba's own start-up
imports scipy.linalg and scipy._lib, most of what scipy.spatial cost), and +0.6 CPU s for
``jamflow draw`` (a pair search then starts numba). This script checks the kernel against
cKDTree and times both:

    python benchmarks/cell_list.py
"""

from __future__ import annotations

import time

import numpy as np

from jamflow.engine.compiled.cells import cell_pairs


CASES = [  # (dim, lengths, periodic, n, rmax): 1-30 cells per axis, walls, dense and sparse
    (2, (6.0, 6.0), (True, True), 80, 2.9), (2, (6.0, 40.0), (True, True), 150, 1.3),
    (2, (9.0, 9.0), (True, False), 120, 1.4), (3, (5.0, 7.0, 12.0), (True, True, True), 150, 1.6),
    (3, (8.0, 8.0, 8.0), (False, True, False), 150, 1.5), (3, (100.0, 100.0, 100.0), (True, True, True), 1500, 3.0),
]


def same_as_kdtree(dim, lengths, periodic, n, rmax) -> bool:
    """The kernel's pairs equal cKDTree's (periodic only along periodic axes), pairs at exactly rmax included."""
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(n + dim)
    L, per = np.array(lengths), np.array(periodic)
    x = rng.uniform(0, 1, (n, dim)) * L
    x[:, ~per] = rng.uniform(-0.3, 1.3, (n, int((~per).sum()))) * L[~per]  # beyond the walls too
    x[1] = x[0] + np.eye(dim)[0] * rmax
    x[3] = x[2] + np.eye(dim)[-1] * rmax
    x[:, per] = np.mod(x[:, per], L[per])
    x[:, per] = np.where(x[:, per] >= L[per], 0.0, x[:, per])
    i, j = cell_pairs(np.ascontiguousarray(x), L, per.astype(np.int64), rmax)
    ref = cKDTree(x, boxsize=np.where(per, L, 0.0)).query_pairs(rmax, output_type="ndarray")
    return bool(np.all(i < j)) and sorted(zip(i.tolist(), j.tolist())) == sorted(map(tuple, ref.tolist()))


def main():
    from scipy.spatial import cKDTree

    print("same pairs as cKDTree:", [same_as_kdtree(*case) for case in CASES])
    for n, dim in ((1024, 2), (4096, 2), (65536, 2), (32768, 3)):
        rng = np.random.default_rng(0)
        side = (n / 0.85 * 0.8) ** 0.5 if dim == 2 else float(n) ** (1 / 3)
        x = rng.uniform(0, side, (n, dim))
        lengths, per = np.full(dim, side), np.ones(dim, np.int64)
        cell_pairs(x, lengths, per, 1.7)
        t0 = time.process_time()
        for _ in range(5):
            i, _j = cell_pairs(x, lengths, per, 1.7)
        cells = (time.process_time() - t0) / 5
        t0 = time.process_time()
        for _ in range(5):
            pairs = cKDTree(x, boxsize=lengths).query_pairs(1.7, output_type="ndarray")
        tree = (time.process_time() - t0) / 5
        print(f"N = {n} {dim}D: {len(i)} pairs (cKDTree {len(pairs)}); cell list {cells * 1e3:.2f} ms, "
              f"cKDTree {tree * 1e3:.2f} ms (CPU, mean of 5)")


if __name__ == "__main__":
    main()
