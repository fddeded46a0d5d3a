"""A compiled cell-list pair search (issue 17, start-up item: "a numba cell-list pair search so
a compiled jam does not import scipy.spatial"), built, measured, not kept (docs/speed-2.md 7.1).

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

import numba
import numpy as np


@numba.njit(cache=True)
def cell_pairs(x, lengths, periodic, rmax):
    """(i, j) int64 arrays of the pairs i < j with |x_i - x_j| <= rmax (unsorted).

    ``x`` (N, d) lies in [0, L) along the periodic axes (any value along walled ones),
    ``periodic`` (d,) is 1 for a periodic axis, 0 for walls; needs rmax < L / 2 along periodic
    axes. Cells are at least ``rmax`` wide, so a pair lies in the same or adjacent cells; a
    periodic axis with fewer than 3 cells is one cell (its neighbours would repeat).
    """
    n, d = x.shape
    nc = np.ones(d, np.int64)
    reach = np.ones(d, np.int64)  # neighbour cells visited along each axis: -reach..reach
    for a in range(d):
        nc[a] = max(1, int(lengths[a] / rmax))
        if periodic[a] and nc[a] < 3:
            nc[a], reach[a] = 1, 0
    stride = np.ones(d, np.int64)
    for a in range(1, d):
        stride[a] = stride[a - 1] * nc[a - 1]
    home = np.zeros((n, d), np.int64)
    cell = np.zeros(n, np.int64)
    for p in range(n):
        for a in range(d):
            c = int(np.floor(x[p, a] / lengths[a] * nc[a]))
            c = min(max(c, 0), nc[a] - 1)  # walled axes: particles outside the box join the end cells
            home[p, a] = c
            cell[p] += c * stride[a]
    total = stride[d - 1] * nc[d - 1]
    start = np.zeros(total + 1, np.int64)  # cell c holds order[start[c]:start[c + 1]]
    for p in range(n):
        start[cell[p] + 1] += 1
    for c in range(total):
        start[c + 1] += start[c]
    order = np.empty(n, np.int64)  # counting sort: particles grouped by cell, by index within one
    fill = start[:-1].copy()
    for p in range(n):
        order[fill[cell[p]]] = p
        fill[cell[p]] += 1
    xs = np.empty((n, d))  # positions in that order: a cell's particles are contiguous in memory
    for k in range(n):
        xs[k] = x[order[k]]
    r2max = rmax * rmax
    capacity = 16 * n + 16
    out_i, out_j = np.empty(capacity, np.int64), np.empty(capacity, np.int64)
    count = 0
    visits = 1
    for a in range(d):
        visits *= 2 * reach[a] + 1
    for a_sorted in range(n):
        p = order[a_sorted]
        for v in range(visits):
            code, other, inside = v, 0, True
            for a in range(d):
                width = 2 * reach[a] + 1
                c = home[p, a] + code % width - reach[a]
                code //= width
                if c < 0 or c >= nc[a]:
                    if not periodic[a]:
                        inside = False
                        break
                    c %= nc[a]
                other += c * stride[a]
            if not inside:
                continue
            for k in range(start[other], start[other + 1]):
                q = order[k]
                if q <= p:
                    continue
                r2 = 0.0
                for a in range(d):
                    dx = xs[a_sorted, a] - xs[k, a]
                    if periodic[a]:
                        half = 0.5 * lengths[a]
                        if dx > half:
                            dx -= lengths[a]
                        elif dx < -half:
                            dx += lengths[a]
                    r2 += dx * dx
                if r2 <= r2max:
                    if count == capacity:
                        capacity *= 2
                        grown_i, grown_j = np.empty(capacity, np.int64), np.empty(capacity, np.int64)
                        grown_i[:count], grown_j[:count] = out_i[:count], out_j[:count]
                        out_i, out_j = grown_i, grown_j
                    out_i[count], out_j[count] = p, q
                    count += 1
    return out_i[:count].copy(), out_j[:count].copy()


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
