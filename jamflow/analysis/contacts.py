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
- Shapes: ellipses/spheroids touch when r_ij < sigma_ij with the shape's contact distance.
  Rigid bodies touch site by site, and every overlapping pair of sites of two bodies is one
  contact: one constraint, with its own normal through both site centres, so two bodies that
  touch at two site pairs (side by side dimers) have two contacts (``i``, ``j`` list the bodies
  of each; ``n_site_contacts`` = ``n_contacts``); ``n_body_contacts`` counts touching pairs of
  bodies. Counting body pairs instead would undercount the constraints: in jammed 2D dimer
  packings (alpha = 1.5, N = 128) <z> over body pairs is ~4.8 < d_f + 1 = 4 for so many bodies
  that the floater cascade removes every body (docs/nmers.md).
- Concave bodies need more care than the convex rule d_f + 1: a rigid body whose contacts all
  touch one of its sites turns freely about that site's centre, since every contact force passes
  through it (the "rotational rattlers" of 2D dimers, Shiraishi, Mizuno, Ikeda, PRE 100, 012606
  (2019)). Such bodies (``one_site``) can keep d_f + 1 contacts and are not floaters by the
  convex rule, but have d_f - d free rotations (zero modes); ``free_rotations`` counts them and
  ``isostatic_count - free_rotations`` is the isostatic count without them.
- N' = N - N_f, N_c = contacts among non-floaters, <z> = 2 N_c / N',
  N_c,iso = N' d_f - d + 1 (d trivial translations subtracted, one added for phi); packings
  of particles that turn are generally hypostatic (N_c < N_c,iso, seed section 4.1).
- Walls and gravity (``jamflow.walls``), following the same counting: a mobile particle
  touching a smooth wall (h < a_i / 2) has a contact with it, whose direction is the wall
  normal; contacts with fixed (rough-wall) particles are contacts. Walls and fixed particles
  are never floaters and are no degrees of freedom: N' counts mobile non-floaters. The
  trivial translations are those along periodic axes that nothing fixed pins (smooth walls
  on y leave x; rough walls pin every axis), so N_c,iso = N' d_f - d_trivial + 1. Under
  gravity the weight is a load, not a self-stress: no +1 (N_c,iso = N' d_f - d_trivial), and
  in the floater test the weight acts as one more contact pressing from above (a disk
  resting in a groove of two is stable), so it counts towards d_f + 1 and the half-space test.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linprog

from ..packing import Packing
from ..pairs import candidate_pairs, contact_distances, overlapping_sites, particle_contacts, separations, site_packing


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
    n_site_contacts: int | None = None  # rigid bodies: overlapping site pairs among non-floaters (= n_contacts)
    n_body_contacts: int | None = None  # rigid bodies: touching pairs of non-floater bodies
    one_site: np.ndarray | None = None  # rigid bodies (N,) bool: a non-floater whose contacts all touch one site
    wall_contacts: np.ndarray | None = None  # (N_w, 2): particle, face (2 a + side) of each smooth-wall contact
    fixed: np.ndarray | None = None  # (N,) bool: fixed (wall) particles, never floaters, no degrees of freedom
    trivial: int | None = None  # trivial translations (None: d, a periodic box)
    loaded: bool = False  # under gravity: no +1 in the isostatic count

    @property
    def n_floaters(self) -> int:
        return int(self.floater.sum())

    @property
    def _mobile(self) -> np.ndarray:
        return np.ones(len(self.floater), bool) if self.fixed is None else ~self.fixed

    @property
    def kept(self) -> np.ndarray:
        """Indices of the mobile non-floaters, in packing order."""
        return np.flatnonzero(~self.floater & self._mobile)

    @property
    def n_kept(self) -> int:
        """N' = N - N_f (mobile particles)."""
        return int((~self.floater & self._mobile).sum())

    @property
    def n_wall_contacts(self) -> int:
        """Contacts of non-floaters with smooth walls."""
        return 0 if self.wall_contacts is None else len(self.wall_contacts)

    @property
    def n_contacts(self) -> int:
        """N_c, contacts among non-floaters (with fixed particles and walls included)."""
        return len(self.i) + self.n_wall_contacts

    @property
    def mean_z(self) -> float:
        """<z> = (sum of z over non-floaters) / N' (= 2 N_c / N' in a periodic box; nan without non-floaters)."""
        return float(self.z[self.kept].sum()) / self.n_kept if self.n_kept else float("nan")

    @property
    def isostatic_count(self) -> int:
        """N_c,iso = N' d_f - d_trivial + 1 (no +1 under gravity; 0 without non-floaters)."""
        d_f = self.dim if self.dof is None else self.dof
        trivial = self.dim if self.trivial is None else self.trivial
        return self.n_kept * d_f - trivial + (0 if self.loaded else 1) if self.n_kept else 0

    @property
    def excess_contacts(self) -> int:
        """N_c - N_c,iso: 0 isostatic, > 0 hyperstatic, < 0 hypostatic."""
        return self.n_contacts - self.isostatic_count

    @property
    def free_rotations(self) -> int:
        """Rotations left free by contacts that all touch one site: (d_f - d) per ``one_site`` body."""
        if self.one_site is None:
            return 0
        return int(self.one_site.sum()) * ((self.dim if self.dof is None else self.dof) - self.dim)

    @property
    def is_isostatic(self) -> bool:
        return self.n_kept > 0 and self.excess_contacts == 0

    def z_distribution(self) -> tuple[np.ndarray, np.ndarray]:
        """(z values, fraction of non-floaters with that z), seed Figure 2.20."""
        counts = np.bincount(self.z[self.kept], minlength=1)
        values = np.arange(len(counts))
        return values, counts / max(self.n_kept, 1)


class Contacts:
    """Contact network with iterative floater removal.

    ``min_contacts``: a particle with fewer is a floater (default d_f + 1).
    ``half_space``: also remove disks/spheres whose contacts all lie in one half-space.
    ``near_tol``: relative width of the near-contact diagnostic.
    """

    def __init__(self, min_contacts: int | None = None, half_space: bool = True, near_tol: float = 1e-12):
        if min_contacts is not None and (not isinstance(min_contacts, (int, np.integer)) or min_contacts < 0):
            raise ValueError(f"min_contacts must be a non-negative integer or None (d + 1), got {min_contacts!r}")
        if not (np.isfinite(near_tol) and near_tol >= 0):
            raise ValueError(f"near_tol must be a finite number >= 0, got {near_tol!r}")
        self.min_contacts = min_contacts
        self.half_space = bool(half_space)
        self.near_tol = float(near_tol)

    def compute(self, packing: Packing) -> ContactsResult:
        rigid = packing.shape.kind == "rigid"
        if rigid:  # one contact per overlapping site pair (module docstring); bodies have no walls
            i, j, s, t, dr, *_ = overlapping_sites(packing)
        else:
            i, j, dr = particle_contacts(packing)
        n = packing.n
        if packing.fixed is not None:  # fixed particles do not interact with each other
            live = ~(packing.fixed[i] & packing.fixed[j])
            i, j, dr = i[live], j[live], dr[live]
        d_f = packing.dof_per_particle
        need = d_f + 1 if self.min_contacts is None else int(self.min_contacts)
        unit = dr / np.linalg.norm(dr, axis=1)[:, None]  # points from j to i
        half_space = self.half_space and packing.shape.kind == "sphere"
        wall_i, wall_face, wall_unit = wall_contacts(packing)
        load_i, load_unit = weight_contacts(packing)
        virtual = n + 2 * packing.dim  # the faces, then the weight
        anchored = np.zeros(virtual + 1, bool)
        anchored[n:] = True
        if packing.fixed is not None:
            anchored[:n] = packing.fixed
        floater = find_floaters(virtual + 1, np.concatenate([i, wall_i, load_i]),
                                np.concatenate([j, n + wall_face, np.full(len(load_i), virtual)]),
                                np.concatenate([unit, wall_unit, load_unit]), need, half_space, anchored)[:n]
        keep = ~floater[i] & ~floater[j]
        wall_keep = ~floater[wall_i]
        z = (np.bincount(i[keep], minlength=n) + np.bincount(j[keep], minlength=n)
             + np.bincount(wall_i[wall_keep], minlength=n))
        bounded = bool(packing.box.walls) or packing.gravity > 0 or packing.fixed is not None
        trivial = 0 if packing.fixed is not None else sum(packing.box.periodic)
        bodies = body_counts(n, i[keep], j[keep], s[keep], t[keep], floater) if rigid else (None, None, None)
        return ContactsResult(i[keep], j[keep], floater, z, packing.dim, len(i),
                              near_contact_count(packing, self.near_tol), d_f, *bodies,
                              wall_contacts=np.column_stack([wall_i[wall_keep], wall_face[wall_keep]]) if bounded else None,
                              fixed=packing.fixed, trivial=trivial if bounded else None, loaded=packing.gravity > 0)


def body_counts(n: int, i, j, s, t, floater) -> tuple[int, int, np.ndarray]:
    """Rigid bodies, from the site contacts (bodies i, j; sites s, t) among non-floaters:
    (site contacts, touching body pairs, (N,) mask of non-floaters whose contacts all touch one
    of their sites)."""
    pairs = np.unique(np.column_stack([i, j]), axis=0) if len(i) else np.empty((0, 2), int)
    owner, site = np.concatenate([i, j]), np.concatenate([s, t])
    touched = np.unique(np.column_stack([owner, site]), axis=0) if len(owner) else np.empty((0, 2), int)
    n_touched = np.bincount(touched[:, 0], minlength=n)
    return len(i), len(pairs), ~floater & (n_touched == 1)


def wall_contacts(packing: Packing):
    """Mobile particles touching a smooth wall (h < a_i / 2, no tolerance): (particle, face
    2 a + side, unit vector from the wall to the particle)."""
    parts, faces, units = [], [], []
    half, mobile = 0.5 * packing.diameters, packing.mobile
    for a in packing.box.walls:
        x = packing.positions[:, a]
        for side, h in enumerate((x, packing.box.lengths[a] - x)):
            touching = np.flatnonzero(mobile & (h < half))
            normal = np.zeros((len(touching), packing.dim))
            normal[:, a] = 1.0 if side == 0 else -1.0
            parts.append(touching)
            faces.append(np.full(len(touching), 2 * a + side))
            units.append(normal)
    if not parts:
        return np.empty(0, int), np.empty(0, int), np.empty((0, packing.dim))
    return np.concatenate(parts), np.concatenate(faces), np.concatenate(units)


def weight_contacts(packing: Packing):
    """Under gravity, the weight of each mobile particle as a contact pressing from above:
    (particle, unit vector -e_(d-1) from the 'partner' to the particle)."""
    if not packing.gravity:
        return np.empty(0, int), np.empty((0, packing.dim))
    idx = np.flatnonzero(packing.mobile)
    unit = np.zeros((len(idx), packing.dim))
    unit[:, -1] = -1.0
    return idx, unit


def find_floaters(n: int, i, j, unit, need: int, half_space: bool = True, anchored=None) -> np.ndarray:
    """Boolean mask of floaters, removed iteratively (see module docstring).

    ``unit[p]`` is the unit vector from particle j[p] to particle i[p]; ``anchored`` nodes
    (walls, fixed particles) are never floaters.
    """
    floater = np.zeros(n, bool)
    free = np.ones(n, bool) if anchored is None else ~np.asarray(anchored, bool)
    while True:
        live = ~floater[i] & ~floater[j]
        z = np.bincount(i[live], minlength=n) + np.bincount(j[live], minlength=n)
        bad = ~floater & free & (z < need)
        if half_space:
            candidates = ~floater & ~bad & free & (z > 0)
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
