"""A cell-list pair search for orthogonal boxes, compiled ahead of time into the disk/sphere
kernels (``aot_build``) so that a disk jam needs no scipy.spatial (docs/notes/speed-2.md sections 7.1
and 10): the same pair set as scipy's periodic cKDTree (per axis the difference folded into
[-L/2, L/2], squared distance <= rmax^2). ``jamflow.model.pairs.neighbor_pairs`` calls the ahead-of-time
copy when it is there; this numba one is what ``aot_build`` compiles and the tests compare."""

from __future__ import annotations

import numpy as np

from jamflow.engines.compiled import jit


@jit
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
