"""Pairs of particles within reach, with float64 minimum-image separations.

Candidate pairs come from a cell search (scipy's cKDTree for orthogonal boxes, freud's
AABB query for tilted ones); separations are then recomputed in float64 with
``Box.minimum_image``, because freud works in float32 and contact overlaps near
jamming are ~1e-8 of a diameter.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from .packing import Packing


def all_pairs(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Every distinct pair i < j."""
    return np.triu_indices(n, k=1)


def candidate_pairs(packing: Packing, rmax: float) -> tuple[np.ndarray, np.ndarray]:
    """Pairs i < j whose separation may be below ``rmax`` (a superset: filter after)."""
    box = packing.box
    rmax = min(float(rmax) * (1 + 1e-6) + 1e-9, 0.5 * box.widths.min() * (1 - 1e-12))
    if not box.is_triclinic:
        wrapped = box.wrap(packing.positions)
        wrapped = np.where(wrapped >= box.lengths, 0.0, wrapped)
        tree = cKDTree(wrapped, boxsize=box.lengths)
        pairs = tree.query_pairs(rmax, output_type="ndarray")
    else:
        pairs = _freud_pairs(packing, rmax)
    if len(pairs) == 0:
        return np.empty(0, int), np.empty(0, int)
    i, j = np.minimum(pairs[:, 0], pairs[:, 1]), np.maximum(pairs[:, 0], pairs[:, 1])
    order = np.lexsort((j, i))
    return i[order], j[order]


def _freud_pairs(packing: Packing, rmax: float) -> np.ndarray:
    import freud

    fbox = packing.box.to_freud()
    pts = packing.positions if packing.dim == 3 else np.column_stack([packing.positions, np.zeros(packing.n)])
    pts = fbox.wrap(pts.astype(np.float32))
    query = freud.locality.AABBQuery(fbox, pts)
    nlist = query.query(pts, dict(r_max=rmax + 1e-5, exclude_ii=True)).toNeighborList()
    pairs = np.column_stack([nlist.query_point_indices, nlist.point_indices]).astype(int)
    return np.unique(np.sort(pairs, axis=1), axis=0)


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
