"""Contact network, floaters and the isostatic count (chapter section 4.1).

- A pair is in contact iff r_ij < sigma_ij exactly, no tolerance (``overlapping_pairs``,
  float64 separations). Pairs with |r_ij / sigma_ij - 1| < ``near_tol`` are counted as a
  diagnostic only: near onset, overlaps are ~1e-8 and such pairs are round-off-sensitive.
- Floaters are removed iteratively: a particle is a floater if it has fewer than d_f + 1
  contacts among the remaining particles (d_f the degrees of freedom per particle: d for
  disks and spheres, 3 for ellipses, 5 for spheroids, ``jamflow.model.shapes``), or, for disks and
  spheres, if its contact directions do not positively span R^d (all contacts in one closed
  half-space, e.g. three contacts on one side of a disk's equator; chapter Figure 2.19). The
  half-space rule is the disks' and spheres' only: for other shapes a contact's normal is not
  along the centre line. Removing a floater can make its neighbours floaters, so the test is
  repeated until nothing changes.
- The exception of chapter Figure 2.19: a particle that turns and has at least d + 1 but fewer
  than d_f + 1 contacts is kept if its contact forces balance its force and torque (the
  generalized force of its live contacts is below ``BALANCE_TOL`` times its largest contact
  term). With three contacts on an ellipse this is the condition that their normals meet in
  one point; such a particle carries load, and dropping it would leave its neighbours out of
  balance (measured on 2D dimer packings: net forces as large as the contact forces). Periodic
  packings without walls, gravity or fixed particles only.
- Shapes: ellipses/spheroids touch when r_ij < sigma_ij with the shape's contact distance;
  rigid bodies are in contact when any two of their sites overlap: by default one contact
  per pair of bodies, however many site pairs touch (``count="bodies"``); with
  ``count="sites"`` every overlapping site pair is one contact, the constraint count of the
  dynamical matrix (each site pair is a point-point distance; two dimers touching at two site
  pairs fix two coordinates), which ``DynamicalMatrix`` uses. For rigid bodies the result also
  counts both: ``n_site_contacts`` and ``n_body_contacts`` among the non-floaters.
- Concave bodies need more care than the convex rule d_f + 1: a rigid body whose contacts all
  touch one of its sites turns freely about that site's centre, since every contact force passes
  through it (the "rotational rattlers" of 2D dimers, Shiraishi, Mizuno, Ikeda, PRE 100, 012606
  (2019)). Such bodies (``one_site``) can keep d_f + 1 contacts and are not floaters by the
  convex rule, but have d_f - d free rotations (zero modes); ``free_rotations`` counts them and
  ``isostatic_count - free_rotations`` is the isostatic count without them (docs/notes/nmers.md).
- N' = N - N_f, N_c = contacts among non-floaters, <z> = 2 N_c / N',
  N_c,iso = N' d_f - d + 1 (d trivial translations subtracted, one added for phi); packings
  of particles that turn are generally hypostatic (N_c < N_c,iso, chapter section 4.1).
- Walls and gravity (``jamflow.model.walls``), following the same counting: a mobile particle
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

import functools
from dataclasses import dataclass

import numpy as np

from jamflow.model.packing import Packing
from jamflow.model.pairs import (candidate_pairs, contact_distances, overlapping_sites, particle_contacts, separations,
                                 site_packing)


@dataclass(frozen=True)
class ContactsResult:
    """Contacts among non-floaters. ``i < j`` index the original packing."""

    i: np.ndarray  #: (N_c,) first particle of each contact
    j: np.ndarray  #: (N_c,) second particle
    floater: np.ndarray  #: (N,) bool: True for a floater (rattler), removed with its contacts
    z: np.ndarray  #: (N,) contacts per particle among non-floaters; 0 for floaters
    dim: int  #: d, 2 or 3
    n_overlapping: int  #: overlapping pairs before floater removal
    #: pairs with |r/sigma - 1| < near_tol (default 1e-12) on either side of contact, from the float64
    #: positions: a diagnostic, not part of N_c. In a double-double packing refined to a small pressure
    #: every contact overlaps by less than near_tol, so the count includes the contacts themselves
    #: (about N_c; the contacts are found from hi + lo).
    n_near_contact: int
    dof: int | None = None  #: d_f, degrees of freedom per particle (None: d, disks and spheres)
    wall_contacts: np.ndarray | None = None  #: (N_w, 2): particle, face (2 a + side) of each smooth-wall contact
    fixed: np.ndarray | None = None  #: (N,) bool: fixed (wall) particles, never floaters, no degrees of freedom
    trivial: int | None = None  #: trivial translations (None: d, a periodic box)
    loaded: bool = False  #: under gravity: no +1 in the isostatic count
    balanced: np.ndarray | None = None  #: (N,) bool: kept by the Figure 2.19 exception (None: not tested)
    n_site_contacts: int | None = None  #: rigid bodies: overlapping site pairs among non-floaters
    n_body_contacts: int | None = None  #: rigid bodies: touching pairs of non-floater bodies
    one_site: np.ndarray | None = None  #: rigid bodies (N,) bool: a non-floater whose contacts all touch one site

    def __repr__(self) -> str:
        """One line: N, N', floaters, N_c against isostatic, <z>; the arrays are the fields."""
        walls = f", wall_contacts={self.n_wall_contacts}" if self.wall_contacts is not None else ""
        return (f"ContactsResult(N={len(self.floater)}, dim={self.dim}, kept={self.n_kept}, floaters={self.n_floaters}, "
                f"N_c={self.n_contacts}, isostatic={self.isostatic_count}, excess={self.excess_contacts:+d}, "
                f"mean_z={self.mean_z:.4f}{walls})")

    @property
    def n_balanced(self) -> int:
        """Non-floaters with fewer than d_f + 1 contacts whose contact forces balance them."""
        return 0 if self.balanced is None else int(self.balanced.sum())

    @property
    def free_rotations(self) -> int:
        """Rotations left free by contacts that all touch one site: (d_f - d) per ``one_site`` body."""
        if self.one_site is None:
            return 0
        return int(self.one_site.sum()) * ((self.dim if self.dof is None else self.dof) - self.dim)

    @property
    def n_floaters(self) -> int:
        """N_f, the floaters."""
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
    def is_isostatic(self) -> bool:
        """N_c = N_c,iso, with non-floaters left."""
        return self.n_kept > 0 and self.excess_contacts == 0

    def z_distribution(self) -> tuple[np.ndarray, np.ndarray]:
        """(z values, fraction of non-floaters with that z), chapter Figure 2.20."""
        counts = np.bincount(self.z[self.kept], minlength=1)
        values = np.arange(len(counts))
        return values, counts / max(self.n_kept, 1)


@dataclass(frozen=True)
class PooledContacts:
    """Contact numbers pooled over packings: <z> = (sum of z over all non-floaters) / (sum of N'),
    and the floater fraction sum N_f / sum N (each packing weighted by its particles, not averaged
    per packing)."""

    mean_z: float  #: pooled <z> over the non-floaters of every packing
    n_floaters: int  #: floaters over all packings
    n: int  #: particles over all packings
    n_packings: int  #: packings pooled

    @property
    def floater_fraction(self) -> float:
        """sum N_f / sum N (nan without particles)."""
        return self.n_floaters / self.n if self.n else float("nan")

    def summary(self) -> str:
        """``pooled <z> = 3.9922, floaters 3/512 (0.0059)``."""
        return (f"pooled <z> = {self.mean_z:.4f}, floaters {self.n_floaters}/{self.n} "
                f"({self.floater_fraction:.4f})")


def pooled_contacts(results) -> PooledContacts:
    """The ``PooledContacts`` of ContactsResult objects, one per packing."""
    results = list(results)
    kept = sum(c.n_kept for c in results)
    z = sum(float(c.z[c.kept].sum()) for c in results)
    return PooledContacts(z / kept if kept else float("nan"), sum(c.n_floaters for c in results),
                          sum(len(c.floater) for c in results), len(results))


class Contacts:
    """Contact network with iterative floater removal.

    ``min_contacts``: a particle with fewer is a floater (default d_f + 1).
    ``half_space``: also remove disks/spheres whose contacts all lie in one half-space.
    ``near_tol``: relative width of the near-contact diagnostic.
    ``count``: rigid bodies only: "bodies" (one contact per touching pair of bodies) or "sites"
    (one per overlapping site pair).
    ``balanced_exception``: keep force-balanced particles that turn with d + 1 to d_f contacts
    (chapter Figure 2.19; only with the default ``min_contacts``, in periodic packings).

    Parameters
    ----------
    min_contacts : int, optional
        A particle with fewer contacts is a floater (>= 0); default d_f + 1.
    half_space : bool, default True
        Also remove disks/spheres whose contact directions do not positively span R^d.
    near_tol : float, default 1e-12
        Relative width of the near-contact count, |r/sigma - 1| < near_tol (>= 0).
    count : {"bodies", "sites"}, default "bodies"
        How contacts of rigid bodies are counted.
    balanced_exception : bool, default True
        Keep force-balanced turning particles with d + 1 to d_f contacts.

    Raises
    ------
    ValueError
        An unknown ``count``, or a bad ``min_contacts`` or ``near_tol``.
    """

    def __init__(self, min_contacts: int | None = None, half_space: bool = True, near_tol: float = 1e-12,
                 count: str = "bodies", balanced_exception: bool = True):
        if count not in ("bodies", "sites"):
            raise ValueError(f"count must be 'bodies' or 'sites' (how rigid-body contacts are counted), got {count!r}")
        self.count = count
        self.balanced_exception = bool(balanced_exception)
        if min_contacts is not None and (not isinstance(min_contacts, (int, np.integer)) or min_contacts < 0):
            raise ValueError(f"min_contacts must be a non-negative integer or None (d + 1), got {min_contacts!r}")
        if not (np.isfinite(near_tol) and near_tol >= 0):
            raise ValueError(f"near_tol must be a finite number >= 0, got {near_tol!r}")
        self.min_contacts = min_contacts
        self.half_space = bool(half_space)
        self.near_tol = float(near_tol)

    def compute(self, packing: Packing) -> ContactsResult:
        """The contact network of ``packing`` after iterative floater removal.

        Parameters
        ----------
        packing : jamflow.Packing
            Any packing; a contact is an overlap r < sigma, strictly (double-double overlaps for
            disks and spheres carrying low parts), walls and weights count as contacts.

        Returns
        -------
        ContactsResult
            The contacts among non-floaters, the floaters, z per particle and the counts (N_c,
            N_c,iso, <z>) as properties.
        """
        sites = overlapping_sites(packing) if packing.shape.made_of_sites else None
        i, j, dr = (site_contacts(packing, sites) if self.count == "sites" and sites is not None
                    else particle_contacts(packing))
        n = packing.n
        if packing.fixed is not None:  # fixed particles do not interact with each other
            live = ~(packing.fixed[i] & packing.fixed[j])
            i, j, dr = i[live], j[live], dr[live]
        d_f = packing.dof_per_particle
        need = d_f + 1 if self.min_contacts is None else int(self.min_contacts)
        unit = dr / np.linalg.norm(dr, axis=1)[:, None]  # points from j to i
        half_space = self.half_space and packing.shape.round
        wall_i, wall_face, wall_unit = wall_contacts(packing)
        load_i, load_unit = weight_contacts(packing)
        virtual = n + 2 * packing.dim  # the faces, then the weight
        anchored = np.zeros(virtual + 1, bool)
        anchored[n:] = True
        if packing.fixed is not None:
            anchored[:n] = packing.fixed
        bounded = bool(packing.box.walls) or packing.gravity > 0 or packing.fixed is not None
        test = self.balanced_exception and self.min_contacts is None and d_f > packing.dim and not bounded
        wrenches = contact_wrenches(packing, i, j) if test else None  # no wall or weight contacts here
        floater = find_floaters(virtual + 1, np.concatenate([i, wall_i, load_i]),
                                np.concatenate([j, n + wall_face, np.full(len(load_i), virtual)]),
                                np.concatenate([unit, wall_unit, load_unit]), need, half_space, anchored,
                                wrenches, packing.dim + 1)[:n]
        keep = ~floater[i] & ~floater[j]
        wall_keep = ~floater[wall_i]
        z = (np.bincount(i[keep], minlength=n) + np.bincount(j[keep], minlength=n)
             + np.bincount(wall_i[wall_keep], minlength=n))
        trivial = 0 if packing.fixed is not None else sum(packing.box.periodic)
        balanced = (~floater & (z < need)) if test else None
        bodies = body_counts(packing.n, sites, floater) if sites is not None else (None, None, None)
        n_site_contacts, n_body_contacts, one_site = bodies
        return ContactsResult(
            i=i[keep], j=j[keep], floater=floater, z=z, dim=packing.dim, n_overlapping=len(i),
            n_near_contact=near_contact_count(packing, self.near_tol), dof=d_f,
            wall_contacts=np.column_stack([wall_i[wall_keep], wall_face[wall_keep]]) if bounded else None,
            fixed=packing.fixed, trivial=trivial if bounded else None, loaded=packing.gravity > 0, balanced=balanced,
            n_site_contacts=n_site_contacts, n_body_contacts=n_body_contacts, one_site=one_site)


def site_contacts(packing: Packing, sites=None):
    """(body_i, body_j, dr) for every overlapping pair of sites of different bodies (a pair of
    bodies appears once per touching site pair; dr = centre separation); ``sites``: the
    ``overlapping_sites`` of the packing, if already found."""
    bi, bj, *_ = overlapping_sites(packing) if sites is None else sites
    return bi, bj, separations(packing, bi, bj)


def body_counts(n: int, sites, floater) -> tuple[int, int, np.ndarray]:
    """Rigid bodies, from their overlapping site pairs (``overlapping_sites``) between
    non-floaters: (site contacts, touching body pairs, (N,) mask of non-floaters whose contacts
    all touch one of their sites)."""
    bi, bj, s, t = sites[:4]
    live = ~floater[bi] & ~floater[bj]
    bi, bj, s, t = bi[live], bj[live], s[live], t[live]
    pairs = np.unique(np.column_stack([bi, bj]), axis=0) if len(bi) else np.empty((0, 2), int)
    owner, site = np.concatenate([bi, bj]), np.concatenate([s, t])
    touched = np.unique(np.column_stack([owner, site]), axis=0) if len(owner) else np.empty((0, 2), int)
    n_touched = np.bincount(touched[:, 0], minlength=n)
    return len(bi), len(pairs), ~floater & (n_touched == 1)


BALANCE_TOL = 1e-3  # |net generalized force| / largest contact term below which a particle is balanced


def contact_wrenches(packing: Packing, i: np.ndarray, j: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(C, d_f) generalized forces (forces, torques tau_a / d_k) that each listed contact (i, j)
    exerts on i and on j; a pair of rigid bodies listed once collects all its site pairs."""
    from jamflow.mechanics.hessian import pair_terms

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


def find_floaters(n: int, i, j, unit, need: int, half_space: bool = True, anchored=None, wrenches=None,
                  fewest: int = 0) -> np.ndarray:
    """Boolean mask of floaters, removed iteratively (see module docstring).

    ``unit[p]`` is the unit vector from particle j[p] to particle i[p]; ``anchored`` nodes
    (walls, fixed particles) are never floaters. ``wrenches``: per-contact generalized forces
    on i and j (``contact_wrenches``) for the Figure 2.19 exception, which keeps balanced
    particles with ``fewest`` to ``need - 1`` contacts.
    """
    floater = np.zeros(n, bool)
    free = np.ones(n, bool) if anchored is None else ~np.asarray(anchored, bool)
    spans, stale = np.zeros(n, bool), np.ones(n, bool)  # the spanning verdicts, and whose contacts changed since
    while True:
        live = ~floater[i] & ~floater[j]
        z = np.bincount(i[live], minlength=n) + np.bincount(j[live], minlength=n)
        bad = ~floater & free & (z < need)
        if wrenches is not None and bad.any():
            live_wrenches = (wrenches[0][live], wrenches[1][live])
            bad &= ~((z >= fewest) & balanced_mask(n, i[live], j[live], live_wrenches))
        if half_space:
            candidates = ~floater & ~bad & free & (z > 0)
            todo = candidates & stale  # the others keep their contacts, in the same order: the same verdict
            if todo.any():
                spans[todo] = spanning_mask(n, i[live], j[live], unit[live], todo)[todo]
            stale &= ~todo
            bad |= candidates & ~spans
        if not bad.any():
            return floater
        stale[i[live & bad[j]]] = True  # partners of new floaters lose contacts
        stale[j[live & bad[i]]] = True
        floater |= bad


def spanning_mask(n: int, i, j, unit, which) -> np.ndarray:
    """For each particle in ``which``: do its contact directions positively span R^d? (2D: the
    angular gap; 3D: ``spanning_stack`` on the particles with the same number of contacts at once.)"""
    owner = np.concatenate([i, j])
    vectors = np.concatenate([-unit, unit])  # from each particle towards its partner
    out = np.zeros(n, bool)
    if unit.shape[1] == 2:
        out[:] = angular_gap_spanning(n, owner, vectors)
        return out & which
    order = np.argsort(owner, kind="stable")
    owner, vectors = owner[order], vectors[order]
    starts = np.searchsorted(owner, np.arange(n + 1))
    count = np.diff(starts)
    for k in np.unique(count[which]):
        group = np.flatnonzero(which & (count == k))
        rows = starts[group][:, None] + np.arange(k)[None, :]
        out[group] = spanning_stack(vectors[rows])
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


SPAN_TOL = 1e-9  # w . v within this of zero (unit vectors): v on the boundary plane of w


def positively_spanning(vectors: np.ndarray) -> bool:
    """True iff the vectors (k, d), d = 2 or 3, positively span R^d: some strictly positive
    combination vanishes and they span R^d (the origin is interior to their convex hull).

    Exact test by Stiemke's lemma: either l > 0 with sum_k l_k v_k = 0 exists, or some w != 0 has
    v_k . w >= 0 for every k, not both. The cone {w : V w >= 0} of a rank-d set is pointed, so if
    it is not {0} it has an extreme ray, orthogonal to d - 1 independent v's: w = +-rot90(v_a) in
    2D, +-(v_a x v_b) in 3D; the vectors span positively iff every such candidate has vectors
    strictly on both of its sides. Products within ``SPAN_TOL`` of zero count as on the plane
    (not spanning: the boundary case, which an exact sum of contact forces cannot balance). ~10x
    faster than the LP feasibility problem sum_k l_k v_k = 0, l_k >= 1 it replaces (HiGHS: 1.3 ms
    against 0.14 ms per set of 4-8 vectors; tests/test_contacts.py compares the two); many sets
    of k vectors at once: ``spanning_stack``."""
    v = np.asarray(vectors, float)
    if v.ndim != 2 or v.shape[1] not in (2, 3):
        raise ValueError(f"positively_spanning needs 2D or 3D vectors, got shape {v.shape}")
    return bool(spanning_stack(v[None])[0])


def spanning_stack(vectors: np.ndarray) -> np.ndarray:
    """``positively_spanning`` of each of m sets of k vectors (m, k, d), d = 2 or 3, at once: (m,)
    bool, the same arithmetic per set (stacked SVD for the rank, cross products and products)."""
    v = np.asarray(vectors, float)
    m, k, d = v.shape
    if k <= d or m == 0:
        return np.zeros(m, bool)
    full = np.linalg.matrix_rank(v) == d
    v = v / np.linalg.norm(v, axis=2)[..., None]
    if d == 2:
        w = np.stack([-v[..., 1], v[..., 0]], axis=2)
    else:
        a, b = _pairs(k)
        w = np.cross(v[:, a], v[:, b])
    norm = np.linalg.norm(w, axis=2)
    keep = norm > 1e-12  # (anti)parallel pairs define no plane
    unit = w / np.where(keep, norm, 1.0)[..., None]
    side = v @ unit.transpose(0, 2, 1)  # (m, k, candidates)
    one_sided = (np.all(side >= -SPAN_TOL, axis=1) | np.all(side <= SPAN_TOL, axis=1)) & keep
    return full & ~np.any(one_sided, axis=1)


@functools.lru_cache(maxsize=None)
def _pairs(k: int) -> tuple[np.ndarray, np.ndarray]:
    """The pairs a < b of k vectors (``np.triu_indices(k, 1)``), computed once per k."""
    return np.triu_indices(k, 1)


def near_contact_count(packing: Packing, near_tol: float) -> int:
    """Pairs with |r_ij / sigma_ij - 1| < near_tol, on either side of contact (pairs of sites
    of different bodies for rigid bodies)."""
    body = None
    if packing.shape.made_of_sites:
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
