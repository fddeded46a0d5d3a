"""Pairs of particles within reach, with float64 minimum-image separations.

Candidate pairs come from a cell search (scipy's cKDTree for orthogonal boxes, freud's
AABB query for tilted ones; walled axes have no periodic images); separations are then recomputed in float64 with
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
        periodic = np.array(box.periodic)
        wrapped = box.wrap(packing.positions)
        wrapped = np.where(periodic & (wrapped >= box.lengths), 0.0, wrapped)
        tree = cKDTree(wrapped, boxsize=np.where(periodic, box.lengths, 0.0))  # 0: no images (walls)
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


def contact_distances(packing: Packing, i: np.ndarray, j: np.ndarray, dr: np.ndarray | None = None) -> np.ndarray:
    """sigma_ij: (a_i + a_j) / 2 for disks and spheres; the contact distance of the shape's
    method (``jamflow.shapes.contact_distance``, exact by default) for ellipses/spheroids along
    the separations ``dr`` (computed if not given). Rigid bodies touch site by site: see
    ``overlapping_sites``."""
    kind = packing.shape.kind
    if kind == "sphere":
        return 0.5 * (packing.diameters[i] + packing.diameters[j])
    if kind == "ellipsoid":
        from .shapes.contact_distance import contact_distance

        dr = separations(packing, i, j) if dr is None else dr
        axes, u = packing.shape.axes(packing.diameters), packing.directors
        r_hat = dr / np.linalg.norm(dr, axis=1)[:, None]
        return contact_distance(axes[i, 0], axes[i, 1], axes[j, 0], axes[j, 1], r_hat, u[i], u[j],
                                method=packing.shape.contact)
    raise ValueError(f"{packing.shape.name(packing.dim)} particles touch site by site; use overlapping_sites")


def overlapping_pairs(packing: Packing):
    """(i, j, dr, r, sigma) for every pair of disks, spheres, ellipses or spheroids with
    r_ij < sigma_ij (no tolerance; float64 separations dr = r_i - r_j)."""
    if packing.n < 2:
        return (np.empty(0, int), np.empty(0, int), np.empty((0, packing.dim)), np.empty(0), np.empty(0))
    i, j = candidate_pairs(packing, 2.0 * float(packing.shape.reach(packing.diameters).max()))
    dr = separations(packing, i, j)
    r = np.linalg.norm(dr, axis=1)
    sigma = contact_distances(packing, i, j, dr)
    keep = r < sigma
    return i[keep], j[keep], dr[keep], r[keep], sigma[keep]


def site_packing(packing: Packing) -> tuple[Packing, np.ndarray]:
    """The sites of a packing of rigid bodies as a packing of disks/spheres (same box), and
    the body of each site."""
    shape = packing.shape
    world = shape.world_sites(packing.positions, packing.orientations, packing.diameters).reshape(-1, packing.dim)
    site_d = (packing.diameters[:, None] * shape.site_diameters[None, :]).ravel()
    sites = Packing(packing.box.wrap(world), site_d, packing.box, packing.potential)
    return sites, np.repeat(np.arange(packing.n), shape.n_sites)


def overlapping_sites(packing: Packing):
    """Rigid bodies: (body_i, body_j, site_s, site_t, dr, r, sigma) for every overlapping pair of
    sites of different bodies (body_i < body_j; dr = site separation r_s - r_t)."""
    sites, body = site_packing(packing)
    s, t, dr, r, sigma = overlapping_pairs(sites)
    other = body[s] != body[t]
    s, t, dr, r, sigma = s[other], t[other], dr[other], r[other], sigma[other]
    swap = body[s] > body[t]
    s, t, dr = np.where(swap, t, s), np.where(swap, s, t), np.where(swap[:, None], -dr, dr)
    return body[s], body[t], s, t, dr, r, sigma


def particle_contacts(packing: Packing):
    """(i, j, dr) for every pair of particles in contact, i < j, dr = r_i - r_j the centre
    separation (minimum image); rigid bodies in contact through any pair of their sites."""
    if packing.shape.kind != "rigid":
        i, j, dr, _, _ = overlapping_pairs(packing)
        return i, j, dr
    bi, bj, *_ = overlapping_sites(packing)
    pairs = np.unique(np.column_stack([bi, bj]), axis=0) if len(bi) else np.empty((0, 2), int)
    i, j = pairs[:, 0], pairs[:, 1]
    return i, j, separations(packing, i, j)
