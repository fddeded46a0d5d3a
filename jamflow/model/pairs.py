"""Pairs of particles within reach, with float64 minimum-image separations.

``neighbor_pairs`` is the one pair search: float64 throughout, any tilt (the accumulated
strain of a Lees-Edwards cell; the search runs in the reduced cell), any box size. It
returns integer image vectors so engines can build exact separations
``x_i - x_j + h @ image`` without a second minimum-image pass. Orthogonal (reduced) cells use
the cell list compiled ahead of time with the disk kernels (``engines.compiled.cells``, registered by ``use_compiled_cell_list``; the same
pair set as scipy's periodic cKDTree, which serves when that module is not built); tilted ones a
cKDTree over the wrapped positions plus the ghost images that lie within ``rmax`` of the cell.
scipy.spatial is imported only where a cKDTree is used (0.3 CPU s of a disk jam's start-up).
See docs/notes/shear-cell.md. Walled axes (``Box.periodic``) have no images: the search is not periodic
along them and no ghost crosses them.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from jamflow.model import ddouble
from jamflow.model.box import Box
from jamflow.model.packing import Packing, warn_float64_only

_compiled_cell_list = None  # set by ``use_compiled_cell_list``


def use_compiled_cell_list(provider) -> None:
    """Let ``neighbor_pairs`` search orthogonal cells with a compiled cell list: ``provider()``
    returns an object with ``cell_pairs(wrapped, lengths, periodic, rmax) -> (i, j)`` (i < j,
    unsorted), or None, and then scipy's cKDTree serves (the same pair set). The engines register
    it (``engines.compiled.aot`` on import): the model layer does not import the engines."""
    global _compiled_cell_list
    _compiled_cell_list = provider


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
        periodic = np.array(cell.periodic)
        wrapped = np.where(periodic & (wrapped >= cell.lengths), 0.0, wrapped)  # cKDTree wants [0, L)
        i, j = _orthogonal_search(wrapped, cell.lengths, periodic, rmax)
        shift = -np.round((wrapped[i] - wrapped[j]) / cell.lengths).astype(np.int64) * periodic
    # wrapped = x - cell.h @ n: fold the wrap offsets into the image, then express it in h's cells
    offset = np.round(cell.to_fractional(x - wrapped)).astype(np.int64)
    image = (offset[j] - offset[i] + shift) @ fold.T
    order = np.lexsort((j, i))
    return i[order].astype(int), j[order].astype(int), image[order].reshape(-1, box.dim)


def _orthogonal_search(wrapped: np.ndarray, lengths: np.ndarray, periodic: np.ndarray, rmax: float):
    """Pairs (i < j, unsorted) within ``rmax`` of positions in [0, L) along the periodic axes (images
    only along those): the ahead-of-time cell list if it is built, else scipy's cKDTree."""
    compiled = _compiled_cell_list() if _compiled_cell_list is not None else None
    if compiled is not None:
        return compiled.cell_pairs(np.ascontiguousarray(wrapped, dtype=float), np.asarray(lengths, float),
                                   periodic.astype(np.int64), float(rmax))
    from scipy.spatial import cKDTree

    tree = cKDTree(wrapped, boxsize=np.where(periodic, lengths, 0.0))  # 0: no images (walls)
    pairs = tree.query_pairs(rmax, output_type="ndarray")
    return pairs[:, 0], pairs[:, 1]


def _ghost_search(wrapped: np.ndarray, cell: Box, rmax: float):
    """Pairs (i < j) and the shift m (cells of ``cell``) with |x_i - x_j - cell.h @ m| <= rmax,
    for positions ``wrapped`` inside a tilted cell whose widths exceed 2 rmax.

    Ghost images x_j + h m (m in {-1, 0, 1}^d, m != 0) are kept only if their fractional
    coordinates lie within rmax / width_k of the unit cell, the reach of any point inside it.
    """
    from scipy.spatial import cKDTree

    dim = cell.dim
    tree = cKDTree(wrapped)
    inside = tree.query_pairs(rmax, output_type="ndarray")
    s = cell.to_fractional(wrapped)
    reach = rmax / cell.widths * (1 + 1e-9) + 1e-12
    ghosts, owners, shifts = [], [], []
    for m in cell.image_offsets():
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


def contact_distances(packing: Packing, i: np.ndarray, j: np.ndarray, dr: np.ndarray | None = None) -> np.ndarray:
    """sigma_ij: (a_i + a_j) / 2 for disks and spheres; the contact distance of the shape's
    method (``jamflow.model.shapes.contact_distance``, exact by default) for ellipses/spheroids along
    the separations ``dr`` (computed if not given). Rigid bodies touch site by site: see
    ``overlapping_sites``."""
    shape = packing.shape
    if dr is None and shape.oriented:
        dr = separations(packing, i, j)
    return shape.contact_distances(packing, i, j, dr)


class PairGeometry(NamedTuple):
    """Pairs within reach and their geometry (``pair_geometry``), diameters."""

    i: np.ndarray  #: (P,)
    j: np.ndarray  #: (P,)
    dr: np.ndarray  #: (P, d) minimum-image r_i - r_j
    r: np.ndarray  #: (P,) |dr|
    sigma: np.ndarray  #: (P,) contact distances
    overlap: np.ndarray | None  #: (P,) sigma - r from double-double positions (None: float64, sigma - r)


def pair_geometry(packing: Packing, skin: float = 0.0) -> PairGeometry:
    """Every pair of disks, spheres, ellipses or spheroids with r_ij < sigma_ij + skin (skin 0: the
    overlapping pairs, no tolerance; skin in diameters, for the gaps a step may close). float64
    separations, or, for disks and spheres carrying double-double coordinates (``Packing.extended``),
    separations, distances and overlaps evaluated from hi + lo (``dd_separations``): there an overlap
    ~1e-14 is below one ulp of a coordinate and the float64 test r < sigma misses contacts
    (docs/guide/precision.md)."""
    if packing.n < 2:
        return PairGeometry(np.empty(0, int), np.empty(0, int), np.empty((0, packing.dim)), np.empty(0), np.empty(0),
                            None)
    rmax = 2.0 * float(packing.shape.reach(packing.diameters).max()) + skin
    extended = packing.extended is not None and packing.shape.double_double
    if packing.extended is not None and not extended:
        warn_float64_only(packing, f"the pair geometry of {packing.shape.name(packing.dim)} particles")
    i, j = candidate_pairs(packing, rmax * (1.0 + 1e-9) if extended else rmax)  # hi parts: pad by their round-off
    if extended:
        return dd_pair_geometry(packing, i, j, skin)
    dr = separations(packing, i, j)
    r = np.linalg.norm(dr, axis=1)
    sigma = contact_distances(packing, i, j, dr)
    keep = r < sigma + skin
    return PairGeometry(i[keep], j[keep], dr[keep], r[keep], sigma[keep], None)


def dd_separations(packing: Packing, i: np.ndarray, j: np.ndarray) -> tuple:
    """(hi, lo) (P, d) minimum images r_i - r_j of a double-double packing in its orthogonal periodic
    box of sides hi + lo: ``jamflow.model.ddouble`` elementwise, the rule of the compiled kernel
    (``engines.compiled.ddkernel.separation``, k = floor(dx / L + 1/2) boxes subtracted)."""
    ext = packing.extended
    xh, xl = packing.positions, ext.positions_lo
    lh, ll = packing.box.lengths, ext.lengths_lo
    dh, dl = ddouble.dd_sub(xh[i], xl[i], xh[j], xl[j])
    k = np.floor(dh / lh + 0.5)
    return ddouble.dd_sub(dh, dl, *ddouble.dd_mul_d(lh, ll, k))


def dd_pair_geometry(packing: Packing, i, j, skin: float) -> PairGeometry:
    """``pair_geometry`` of disks/spheres from double-double separations; the overlap
    sigma - r is formed in double-double (sigma = (a_i + a_j) / 2 exactly) and rounded last."""
    dh, dl = dd_separations(packing, i, j)
    r2h, r2l = np.zeros(len(i)), np.zeros(len(i))
    for c in range(packing.dim):
        r2h, r2l = ddouble.dd_add(r2h, r2l, *ddouble.dd_mul(dh[:, c], dl[:, c], dh[:, c], dl[:, c]))
    rh, rl = ddouble.dd_sqrt(r2h, r2l) if len(i) else (r2h, r2l)
    sh, sl = ddouble.two_sum(packing.diameters[i], packing.diameters[j])
    oh, ol = ddouble.dd_sub(0.5 * sh, 0.5 * sl, rh, rl)
    keep = (oh > -skin) | ((oh == -skin) & (ol > 0))
    overlap = (oh + ol)[keep]
    sigma = (0.5 * sh + 0.5 * sl)[keep]
    return PairGeometry(i[keep], j[keep], (dh + dl)[keep], (rh + rl)[keep], sigma, overlap)


def overlapping_pairs(packing: Packing, skin: float = 0.0):
    """(i, j, dr, r, sigma) of ``pair_geometry`` (double-double packings: contacts by their
    double-double overlaps)."""
    return pair_geometry(packing, skin)[:5]


def site_packing(packing: Packing) -> tuple[Packing, np.ndarray]:
    """The sites of a packing of rigid bodies as a packing of disks/spheres (same box), and
    the body of each site."""
    shape = packing.shape
    world = shape.world_sites(packing.positions, packing.orientations, packing.diameters).reshape(-1, packing.dim)
    site_d = (packing.diameters[:, None] * shape.site_diameters[None, :]).ravel()
    sites = Packing(packing.box.wrap(world), site_d, packing.box, packing.potential)
    return sites, np.repeat(np.arange(packing.n), shape.n_sites)


def overlapping_sites(packing: Packing, skin: float = 0.0):
    """Rigid bodies: (body_i, body_j, site_s, site_t, dr, r, sigma) for every overlapping pair of
    sites of different bodies (body_i < body_j; dr = site separation r_s - r_t); with ``skin``,
    every site pair with r < sigma + skin (``overlapping_pairs``)."""
    sites, body = site_packing(packing)
    s, t, dr, r, sigma = overlapping_pairs(sites, skin)
    other = body[s] != body[t]
    s, t, dr, r, sigma = s[other], t[other], dr[other], r[other], sigma[other]
    swap = body[s] > body[t]
    s, t, dr = np.where(swap, t, s), np.where(swap, s, t), np.where(swap[:, None], -dr, dr)
    return body[s], body[t], s, t, dr, r, sigma


def particle_contacts(packing: Packing):
    """(i, j, dr) for every pair of particles in contact, i < j, dr = r_i - r_j the centre
    separation (minimum image); rigid bodies in contact through any pair of their sites."""
    if not packing.shape.made_of_sites:
        i, j, dr, _, _ = overlapping_pairs(packing)
        return i, j, dr
    bi, bj, *_ = overlapping_sites(packing)
    pairs = np.unique(np.column_stack([bi, bj]), axis=0) if len(bi) else np.empty((0, 2), int)
    i, j = pairs[:, 0], pairs[:, 1]
    return i, j, separations(packing, i, j)
