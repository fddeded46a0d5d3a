"""Pairs of particles within reach, with float64 minimum-image separations.

``neighbor_pairs`` is the one pair search: float64 throughout, any tilt (the accumulated
strain of a Lees-Edwards cell; the search runs in the reduced cell), any box size. It
returns integer image vectors so engines can build exact separations
``x_i - x_j + h @ image`` without a second minimum-image pass. Orthogonal (reduced) cells use
scipy's periodic cKDTree; tilted ones a cKDTree over the wrapped positions plus the ghost
images that lie within ``rmax`` of the cell. See docs/shear-cell.md.
"""

from __future__ import annotations

from itertools import product

import numpy as np
from scipy.spatial import cKDTree

from .box import Box
from .packing import Packing


def all_pairs(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Every distinct pair i < j."""
    return np.triu_indices(n, k=1)


def candidate_pairs(packing: Packing, rmax: float) -> tuple[np.ndarray, np.ndarray]:
    """Pairs i < j (sorted by i, then j) whose separation may be below ``rmax``: a superset,
    padded by 1e-6 relative + 1e-9 so round-off cannot drop a pair; filter after."""
    box = packing.box
    rmax = min(float(rmax) * (1 + 1e-6) + 1e-9, 0.5 * box.widths.min() * (1 - 1e-12))
    i, j, _ = neighbor_pairs(packing.positions, box, rmax)
    return i, j


def neighbor_pairs(positions: np.ndarray, box: Box, rmax: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every pair i < j closer than ``rmax`` (diameters) in its minimum image, with its image.

    Returns ``(i, j, image)``, sorted by i then j; ``image`` is an integer (P, d) array with
    ``positions[i] - positions[j] + image @ box.h.T`` the minimum-image separation (``image``
    counts cells of ``box.h`` itself, the accumulated cell, not of the reduced one). The
    distance test is made in float64 on positions wrapped into the reduced cell, so the set is
    exactly {pairs with distance <= rmax} up to the wrap's round-off (~1e-16 of the box
    length): pad ``rmax`` if a strict superset is needed (``candidate_pairs`` does). Needs
    ``0 < rmax < widths.min() / 2``, where each pair has at most one image within ``rmax``.
    """
    x = np.asarray(positions, float)
    if x.ndim != 2 or x.shape[1] != box.dim:
        raise ValueError(f"positions must have shape (N, {box.dim}) for this box, got {x.shape}")
    rmax = float(rmax)
    half = 0.5 * float(box.widths.min())
    if not (0.0 < rmax < half):
        raise ValueError(f"rmax = {rmax!r} must lie in (0, {half!r}), half the smallest box width; "
                         "use a larger box or a shorter cutoff")
    cell, fold = box.reduction()
    wrapped = cell.wrap(x)
    if cell.is_triclinic:
        i, j, shift = _ghost_search(wrapped, cell, rmax)
    else:
        wrapped = np.where(wrapped >= cell.lengths, 0.0, wrapped)  # cKDTree wants [0, L)
        tree = cKDTree(wrapped, boxsize=cell.lengths)
        pairs = tree.query_pairs(rmax, output_type="ndarray")
        i, j = pairs[:, 0], pairs[:, 1]
        shift = -np.round((wrapped[i] - wrapped[j]) / cell.lengths).astype(np.int64)
    # wrapped = x - cell.h @ n: fold the wrap offsets into the image, then express it in h's cells
    offset = np.round(cell.to_fractional(x - wrapped)).astype(np.int64)
    image = (offset[j] - offset[i] + shift) @ fold.T
    order = np.lexsort((j, i))
    return i[order].astype(int), j[order].astype(int), image[order].reshape(-1, box.dim)


def _ghost_search(wrapped: np.ndarray, cell: Box, rmax: float):
    """Pairs (i < j) and the shift m (cells of ``cell``) with |x_i - x_j - cell.h @ m| <= rmax,
    for positions ``wrapped`` inside a tilted cell whose widths exceed 2 rmax.

    Ghost images x_j + h m (m in {-1, 0, 1}^d, m != 0) are kept only if their fractional
    coordinates lie within rmax / width_k of the unit cell, the reach of any point inside it.
    """
    dim = cell.dim
    tree = cKDTree(wrapped)
    inside = tree.query_pairs(rmax, output_type="ndarray")
    s = cell.to_fractional(wrapped)
    reach = rmax / cell.widths * (1 + 1e-9) + 1e-12
    ghosts, owners, shifts = [], [], []
    for m in product((-1, 0, 1), repeat=dim):
        if not any(m):
            continue
        sm = s + np.array(m)
        near = np.all((sm >= -reach) & (sm <= 1 + reach), axis=1)
        owners.append(np.flatnonzero(near))
        shifts.append(np.broadcast_to(np.array(m, dtype=np.int64), (int(near.sum()), dim)))
        ghosts.append(wrapped[near] + cell.to_cartesian(np.array(m, float)))
    owner, shift = np.concatenate(owners), np.concatenate(shifts)
    cross = tree.sparse_distance_matrix(cKDTree(np.concatenate(ghosts).reshape(-1, dim)), rmax,
                                        output_type="ndarray") if len(owner) else np.empty(0, [("i", int), ("j", int)])
    a, g = cross["i"].astype(np.int64), cross["j"].astype(np.int64)
    b = owner[g]
    keep = a < b  # each crossing pair is found twice, (a, b, m) and (b, a, -m)
    i = np.concatenate([inside[:, 0], a[keep]]).astype(np.int64)
    j = np.concatenate([inside[:, 1], b[keep]]).astype(np.int64)
    m = np.concatenate([np.zeros((len(inside), dim), np.int64), shift[g[keep]]])
    return i, j, -m


def separations(packing: Packing, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Minimum-image vectors r_i - r_j (float64), shape (len(i), d)."""
    return packing.box.minimum_image(packing.positions[i] - packing.positions[j])


def contact_distances(packing: Packing, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """sigma_ij = (a_i + a_j) / 2 for disks and spheres."""
    return 0.5 * (packing.diameters[i] + packing.diameters[j])


def overlapping_pairs(packing: Packing):
    """(i, j, dr, r, sigma) for every pair with r_ij < sigma_ij."""
    i, j = candidate_pairs(packing, packing.diameters.max())
    dr = separations(packing, i, j)
    r = np.linalg.norm(dr, axis=1)
    sigma = contact_distances(packing, i, j)
    keep = r < sigma
    return i[keep], j[keep], dr[keep], r[keep], sigma[keep]
