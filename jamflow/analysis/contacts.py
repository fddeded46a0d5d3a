"""Contact network, floaters and the isostatic count (seed chapter section 4.1).

- A pair is in contact iff r_ij < sigma_ij exactly, no tolerance (``overlapping_pairs``,
  float64 separations). Pairs with |r_ij / sigma_ij - 1| < ``near_tol`` are counted as a
  diagnostic only: near onset, overlaps are ~1e-8 and such pairs are round-off-sensitive.
- Floaters are removed iteratively: a particle is a floater if it has fewer than d_f + 1
  contacts among the remaining particles (d_f the degrees of freedom per particle: d for
  disks and spheres, 3 for ellipses, 5 for spheroids, ``jamflow.shapes``), or, for disks and
  spheres, if its contact directions do not positively span R^d (all contacts in one closed
  half-space, e.g. three contacts on one side of a disk's equator; seed Figure 2.19). The
  half-space rule is the disks' and spheres' only: for other shapes a contact's normal is not
  along the centre line. Removing a floater can make its neighbours floaters, so the test is
  repeated until nothing changes.
- The exception of seed Figure 2.19: a particle that turns and has at least d + 1 but fewer
  than d_f + 1 contacts is kept if its contact forces balance its force and torque (the
  generalized force of its live contacts is below ``BALANCE_TOL`` times its largest contact
  term). With three contacts on an ellipse this is the condition that their normals meet in
  one point; such a particle carries load, and dropping it would leave its neighbours out of
  balance (measured on 2D dimer packings: net forces as large as the contact forces).
- Shapes: ellipses/spheroids touch when r_ij < sigma_ij with the shape's contact distance;
  rigid bodies are in contact when any two of their sites overlap: by default one contact
  per pair of bodies, however many site pairs touch (``count="bodies"``); with
  ``count="sites"`` every overlapping site pair is one contact, the constraint count of the
  dynamical matrix (each site pair is a point-point distance; two dimers touching at two site
  pairs fix two coordinates), which ``DynamicalMatrix`` uses.
- N' = N - N_f, N_c = contacts among non-floaters, <z> = 2 N_c / N',
  N_c,iso = N' d_f - d + 1 (d trivial translations subtracted, one added for phi); packings
  of particles that turn are generally hypostatic (N_c < N_c,iso, seed section 4.1).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linprog

from ..packing import Packing
from ..pairs import (candidate_pairs, contact_distances, overlapping_sites, particle_contacts, separations,
                     site_packing)


@dataclass(frozen=True)
class ContactsResult:
    """Contacts among non-floaters. ``i < j`` index the original packing."""

    i: np.ndarray  # (N_c,) first particle of each contact
    j: np.ndarray  # (N_c,) second particle
    floater: np.ndarray  # (N,) bool
    z: np.ndarray  # (N,) contacts per particle among non-floaters; 0 for floaters
    dim: int
    n_overlapping: int  # overlapping pairs before floater removal
    n_near_contact: int  # pairs with |r/sigma - 1| < near_tol (diagnostic)
    dof: int | None = None  # d_f, degrees of freedom per particle (None: d, disks and spheres)
    balanced: np.ndarray | None = None  # (N,) bool: kept by the Figure 2.19 exception (None: not tested)

    @property
    def n_balanced(self) -> int:
        """Non-floaters with fewer than d_f + 1 contacts whose contact forces balance them."""
        return 0 if self.balanced is None else int(self.balanced.sum())

    @property
    def n_floaters(self) -> int:
        return int(self.floater.sum())

    @property
    def kept(self) -> np.ndarray:
        """Indices of the non-floaters, in packing order."""
        return np.flatnonzero(~self.floater)

    @property
    def n_kept(self) -> int:
        """N' = N - N_f."""
        return int((~self.floater).sum())

    @property
    def n_contacts(self) -> int:
        """N_c, contacts among non-floaters."""
        return len(self.i)

    @property
    def mean_z(self) -> float:
        """<z> = 2 N_c / N' (nan without non-floaters)."""
        return 2.0 * self.n_contacts / self.n_kept if self.n_kept else float("nan")

    @property
    def isostatic_count(self) -> int:
        """N_c,iso = N' d_f - d + 1 (0 without non-floaters)."""
        d_f = self.dim if self.dof is None else self.dof
        return self.n_kept * d_f - self.dim + 1 if self.n_kept else 0

    @property
    def excess_contacts(self) -> int:
        """N_c - N_c,iso: 0 isostatic, > 0 hyperstatic, < 0 hypostatic."""
        return self.n_contacts - self.isostatic_count

    @property
    def is_isostatic(self) -> bool:
        return self.n_kept > 0 and self.excess_contacts == 0

    def z_distribution(self) -> tuple[np.ndarray, np.ndarray]:
        """(z values, fraction of non-floaters with that z), seed Figure 2.20."""
        counts = np.bincount(self.z[~self.floater], minlength=1)
        values = np.arange(len(counts))
        return values, counts / max(self.n_kept, 1)


class Contacts:
    """Contact network with iterative floater removal.

    ``min_contacts``: a particle with fewer is a floater (default d_f + 1).
    ``half_space``: also remove disks/spheres whose contacts all lie in one half-space.
    ``near_tol``: relative width of the near-contact diagnostic.
    ``count``: rigid bodies only: "bodies" (one contact per touching pair of bodies) or "sites"
    (one per overlapping site pair).
    ``balanced_exception``: keep force-balanced particles that turn with d + 1 to d_f contacts
    (seed Figure 2.19; only with the default ``min_contacts``).
    """

    def __init__(self, min_contacts: int | None = None, half_space: bool = True, near_tol: float = 1e-12,
                 count: str = "bodies", balanced_exception: bool = True):
        self.balanced_exception = bool(balanced_exception)
        if count not in ("bodies", "sites"):
            raise ValueError(f"count must be 'bodies' or 'sites' (how rigid-body contacts are counted), got {count!r}")
        self.count = count
        if min_contacts is not None and (not isinstance(min_contacts, (int, np.integer)) or min_contacts < 0):
            raise ValueError(f"min_contacts must be a non-negative integer or None (d + 1), got {min_contacts!r}")
        if not (np.isfinite(near_tol) and near_tol >= 0):
            raise ValueError(f"near_tol must be a finite number >= 0, got {near_tol!r}")
        self.min_contacts = min_contacts
        self.half_space = bool(half_space)
        self.near_tol = float(near_tol)

    def compute(self, packing: Packing) -> ContactsResult:
        i, j, dr = (site_contacts(packing) if self.count == "sites" and packing.shape.kind == "rigid"
                    else particle_contacts(packing))
        d_f = packing.dof_per_particle
        need = d_f + 1 if self.min_contacts is None else int(self.min_contacts)
        unit = dr / np.linalg.norm(dr, axis=1)[:, None]  # points from j to i
        half_space = self.half_space and packing.shape.kind == "sphere"
        test = self.balanced_exception and self.min_contacts is None and d_f > packing.dim
        wrenches = contact_wrenches(packing, i, j) if test else None
        floater = find_floaters(packing.n, i, j, unit, need, half_space, wrenches, packing.dim + 1)
        keep = ~floater[i] & ~floater[j]
        z = np.bincount(i[keep], minlength=packing.n) + np.bincount(j[keep], minlength=packing.n)
        balanced = (~floater & (z < need)) if test else None
        return ContactsResult(i[keep], j[keep], floater, z, packing.dim, len(i),
                              near_contact_count(packing, self.near_tol), d_f, balanced)


def site_contacts(packing: Packing):
    """(body_i, body_j, dr) for every overlapping pair of sites of different bodies (a pair of
    bodies appears once per touching site pair; dr = centre separation)."""
    bi, bj, *_ = overlapping_sites(packing)
    return bi, bj, separations(packing, bi, bj)


BALANCE_TOL = 1e-3  # |net generalized force| / largest contact term below which a particle is balanced


def contact_wrenches(packing: Packing, i: np.ndarray, j: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(C, d_f) generalized forces (forces, torques tau_a / d_k) that each listed contact (i, j)
    exerts on i and on j; a pair of rigid bodies listed once collects all its site pairs."""
    from .hessian import pair_terms

    terms = pair_terms(packing)
    d, r = packing.dim, terms.gradient.shape[1] // 2 - packing.dim
    on_i = -terms.gradient[:, np.r_[0:d, 2 * d:2 * d + r]]
    on_j = -terms.gradient[:, np.r_[d:2 * d, 2 * d + r:2 * d + 2 * r]]
    if len(terms.i) == len(i) and np.array_equal(terms.i, i) and np.array_equal(terms.j, j):
        return on_i, on_j  # one term per contact (pairs of particles, or site pairs one by one)
    keys = i.astype(np.int64) * packing.n + j  # bodies listed once per pair: sorted, unique
    index = np.searchsorted(keys, terms.i.astype(np.int64) * packing.n + terms.j)
    wi, wj = np.zeros((len(i), on_i.shape[1])), np.zeros((len(i), on_i.shape[1]))
    np.add.at(wi, index, on_i)
    np.add.at(wj, index, on_j)
    return wi, wj


def balanced_mask(n: int, i, j, wrenches) -> np.ndarray:
    """Particles whose live contacts (i, j with generalized forces ``wrenches``) balance them."""
    wi, wj = wrenches
    net = np.zeros((n, wi.shape[1]))
    np.add.at(net, i, wi)
    np.add.at(net, j, wj)
    scale = np.zeros(n)
    np.maximum.at(scale, i, np.linalg.norm(wi, axis=1))
    np.maximum.at(scale, j, np.linalg.norm(wj, axis=1))
    return (scale > 0) & (np.linalg.norm(net, axis=1) <= BALANCE_TOL * scale)


def find_floaters(n: int, i, j, unit, need: int, half_space: bool = True, wrenches=None,
                  fewest: int = 0) -> np.ndarray:
    """Boolean mask of floaters, removed iteratively (see module docstring).

    ``unit[p]`` is the unit vector from particle j[p] to particle i[p]. ``wrenches``: per-contact
    generalized forces on i and j (``contact_wrenches``) for the Figure 2.19 exception, which
    keeps balanced particles with ``fewest`` to ``need - 1`` contacts.
    """
    floater = np.zeros(n, bool)
    while True:
        live = ~floater[i] & ~floater[j]
        z = np.bincount(i[live], minlength=n) + np.bincount(j[live], minlength=n)
        bad = ~floater & (z < need)
        if wrenches is not None and bad.any():
            live_wrenches = (wrenches[0][live], wrenches[1][live])
            bad &= ~((z >= fewest) & balanced_mask(n, i[live], j[live], live_wrenches))
        if half_space:
            candidates = ~floater & ~bad & (z > 0)
            bad |= candidates & ~spanning_mask(n, i[live], j[live], unit[live], candidates)
        if not bad.any():
            return floater
        floater |= bad


def spanning_mask(n: int, i, j, unit, which) -> np.ndarray:
    """For each particle in ``which``: do its contact directions positively span R^d?"""
    owner = np.concatenate([i, j])
    vectors = np.concatenate([-unit, unit])  # from each particle towards its partner
    out = np.zeros(n, bool)
    if unit.shape[1] == 2:
        out[:] = angular_gap_spanning(n, owner, vectors)
        return out & which
    order = np.argsort(owner, kind="stable")
    owner, vectors = owner[order], vectors[order]
    starts = np.searchsorted(owner, np.arange(n + 1))
    for p in np.flatnonzero(which):
        out[p] = positively_spanning(vectors[starts[p]:starts[p + 1]])
    return out


def angular_gap_spanning(n: int, owner, vectors) -> np.ndarray:
    """2D test: the largest angular gap between a particle's contact directions is < pi."""
    if len(owner) == 0:
        return np.zeros(n, bool)
    angle = np.arctan2(vectors[:, 1], vectors[:, 0])
    order = np.lexsort((angle, owner))
    owner, angle = owner[order], angle[order]
    gap = np.full(len(angle), 2 * np.pi)
    same = owner[1:] == owner[:-1]
    gap[:-1][same] = np.diff(angle)[same]
    last = np.flatnonzero(np.append(~same, True))  # last entry of each particle
    first = np.flatnonzero(np.insert(~same, 0, True))
    gap[last] = 2 * np.pi - (angle[last] - angle[first])
    largest = np.full(n, 2 * np.pi)
    np.minimum.at(largest, owner, 0.0)
    np.maximum.at(largest, owner, gap)
    return largest < np.pi


def positively_spanning(vectors: np.ndarray) -> bool:
    """True iff the vectors (k, d) positively span R^d: they span R^d linearly and some
    strictly positive combination vanishes (then the origin is interior to their convex
    hull). Solved as the LP feasibility problem sum_k l_k v_k = 0, l_k >= 1."""
    vectors = np.asarray(vectors, float)
    k, d = vectors.shape
    if k <= d or np.linalg.matrix_rank(vectors) < d:
        return False
    res = linprog(np.zeros(k), A_eq=vectors.T, b_eq=np.zeros(d), bounds=[(1.0, None)] * k, method="highs")
    return res.status == 0


def near_contact_count(packing: Packing, near_tol: float) -> int:
    """Pairs with |r_ij / sigma_ij - 1| < near_tol, on either side of contact (pairs of sites
    of different bodies for rigid bodies)."""
    body = None
    if packing.shape.kind == "rigid":
        packing, body = site_packing(packing)
    i, j = candidate_pairs(packing, 2.0 * float(packing.shape.reach(packing.diameters).max()) * (1.0 + near_tol))
    if body is not None:
        i, j = i[body[i] != body[j]], j[body[i] != body[j]]
    dr = separations(packing, i, j)
    r = np.linalg.norm(dr, axis=1)
    return int(np.sum(np.abs(r / contact_distances(packing, i, j, dr) - 1.0) < near_tol))


def remove_floaters(packing: Packing, contacts: ContactsResult) -> Packing:
    """The packing without its floaters (same box, potential and metadata)."""
    keep = contacts.kept
    if len(keep) == 0:
        raise ValueError("every particle is a floater: the packing is not jammed (no contact network); "
                         "compress it to jamming first")
    return packing.subset(keep, floaters_removed=contacts.n_floaters)
