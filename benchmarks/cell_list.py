"""A compiled cell-list pair search (issue 17, start-up item: "a numba cell-list pair search so
a compiled jam does not import scipy.spatial"): measured in docs/speed-2.md 7.1 (not kept then, as
numba's own start-up cost more than scipy.spatial), now ``jamflow.engines.compiled.cells``, compiled
ahead of time with the disk kernels (section 12).

It was the orthogonal branch of ``jamflow.model.pairs.neighbor_pairs`` on this branch for a while
(commit 1506453): the same pair set as scipy's periodic cKDTree (the same distance test: per
axis the difference folded into [-L/2, L/2], squared distance <= rmax^2), so jams stayed
bit-identical. Measured: no whole-process gain for ``jamflow jam --n 64`` (numba's own start-up
imports scipy.linalg and scipy._lib, most of what scipy.spatial cost), and +0.6 CPU s for
``jamflow draw`` (a pair search then starts numba). This script times both (the
pair sets are compared with cKDTree's in tests/test_aot.py):

    python benchmarks/cell_list.py
"""

from __future__ import annotations

import time

import numpy as np

from jamflow.engines.compiled.cells import cell_pairs


def main():
    from scipy.spatial import cKDTree

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
