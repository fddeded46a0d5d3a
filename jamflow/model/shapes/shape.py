"""Particle shapes: what every engine, analysis and file format needs to know of a particle.

Every particle of a packing has the packing's shape, scaled by its own size factor (the
``diameters`` column of a Packing: the diameter of a disk/sphere, the across-axis length
b of an ellipse/spheroid, the scale of a rigid body's sites), and, for shapes that are not
round, an orientation (``jamflow.model.shapes.rotations``). A shape provides:

- ``dof(dim)``: degrees of freedom per particle d_f (chapter section 3: 2 for disks, 3 for
  ellipses; 5 for spheroids and linear 3D bodies, whose rotation about the axis is void);
- ``rotation_mask(dim)``: which body-frame rotations are degrees of freedom (2D: one, about
  z; 3D: body x, y, z; the director is the body x-axis);
- ``volumes(scale, dim)``: particle areas/volumes, for phi;
- ``rotational_lengths(scale, dim)``: d_k per body axis, the radius of gyration sqrt(I/m)
  of a uniform particle (chapter section 3: d_k = sqrt(a^2 + b^2)/4 for an ellipse), which
  turns rotations into lengths (d_k theta) and torques into forces (tau / d_k);
- ``reach(scale)``: the radius of the smallest centred sphere that holds the particle (pair
  search and neighbour-list skin); ``smallest_contact(scale)``: the smallest contact distance;
- ``spec_words``, ``spec_usage`` and ``from_spec``: its ``--shape`` specs (``shapes.parse``);
- ``attrs()`` / ``from_attrs`` (``shape_from_attrs``): the ``shape`` attribute of packing files;
  ``datasets(positions, orientations, scale)``: the shape's datasets in packing files;
- ``contact_distances(packing, i, j, dr)``: sigma_ij of particle pairs (not for bodies of sites).

What a shape can do is declared once, on its class, and read by every layer (no layer tests
the ``kind`` string; per-kind code in a higher layer sits in one table per layer keyed by
``kind``, as ``engines.compiled.kernels.MODULES``):

- ``oriented``: particles carry an orientation;
- ``round``: a disk/sphere, the contact distance (a_i + a_j)/2 along the centre line (the
  Newton minimiser, the polish's disk/sphere pair list, gap closing, rough walls, half-space floaters);
- ``elliptic``: an ellipse/spheroid with ``axes`` and a contact-distance method (``contact``);
- ``made_of_sites``: a rigid body of spherical sites (``world_sites``, ``n_sites``), which
  touches site by site (``model.pairs.overlapping_sites``) and starts without overlaps;
- ``sphere_contacts``: every contact is between two spheres (particles or sites), the
  least-squares model of the Gauss-Newton polish;
- ``bounded``: walls, gravity and fixed particles are written for it;
- ``double_double``: double-double coordinates (``Packing.extended``, refinement) are written for it;
- ``aspect_ratio``: the ALPHA of shape annealing (1 for disks/spheres, None where it has none).
``SHAPES`` registers every class by its ``kind``.
The trivial zero modes of a periodic packing of any shape are the d uniform translations.

Contact laws (how two particles of a shape overlap) live in the engines and the numpy
reference (``jamflow.mechanics.reference``): sigma_ij = (a_i + a_j)/2 for spheres, the exact
contact distance (``contact_distance``) for ellipsoids, site-site spheres for rigid bodies.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

import numpy as np

from jamflow.model.frames import principal_frame
from jamflow.model.shapes.union import union_moments


# default force tolerance before box scaling (``mechanics.force_floor``): disks, spheres, rigid bodies
FORCE_TOL_BASE = 1e-14
# ellipses/spheroids: near onset FIRE creeps along the quartic (rotational) modes: N = 64, alpha = 1.6
# reached max force 5e-13 after 2e4 iterations of the final minimisation, 2e-13 after 3.4e5 (docs/notes/ellipses.md)
ELLIPSOID_FORCE_TOL_BASE = 5e-13


def _scale(scale) -> np.ndarray:
    return np.asarray(scale, float)


@dataclass(frozen=True)
class Sphere:
    """A disk (2D) or sphere (3D) of diameter = its scale."""

    kind = "sphere"  #: the shape's kind in files and tables
    oriented = False  #: particles have no orientation
    round = True  #: a disk/sphere: sigma_ij = (a_i + a_j) / 2 along the centre line
    elliptic = False  #: not an ellipse/spheroid
    made_of_sites = False  #: not a body of spherical sites
    sphere_contacts = True  #: every contact is between two spheres (the polish's least squares)
    bounded = True  #: walls, gravity and fixed particles are written for it
    double_double = True  #: double-double coordinates and refinement are written for it
    aspect_ratio = 1.0  #: ALPHA of shape annealing
    force_tol_base = FORCE_TOL_BASE  #: default force tolerance before box scaling (mechanics.force_floor)

    spec_words = ("disk", "sphere")  #: the first words of its --shape specs (``model.shapes.parse``)
    spec_usage = "disk | sphere"  #: its specs in the --shape usage line

    @classmethod
    def from_spec(cls, spec: str, word: str, rest: str, dim: int, contact: str):
        """The shape of a --shape spec ``word[:rest]`` (None: not a spec of this shape)."""
        return None if rest else SPHERE

    @classmethod
    def from_attrs(cls, attrs: dict):
        """The disk/sphere of a packing file's ``shape`` attributes."""
        return SPHERE

    def name(self, dim: int) -> str:
        """"disk" in 2D, "sphere" in 3D."""
        return "disk" if dim == 2 else "sphere"

    def spec(self, dim: int) -> str:
        """The ``--shape`` spec: the name."""
        return self.name(dim)

    def check(self, dim: int) -> None:
        """Every dimension: nothing to refuse."""
        pass

    def check_sizes(self, scale, dim: int) -> None:
        """Any sizes: nothing to refuse."""
        pass

    def dof(self, dim: int) -> int:
        """d_f = d: translations only."""
        return dim

    def rotation_mask(self, dim: int) -> tuple[bool, ...]:
        """No rotational degrees of freedom: ()."""
        return ()

    def volumes(self, scale, dim: int) -> np.ndarray:
        """pi s^2 / 4 (2D) or pi s^3 / 6 (3D) per particle of diameter s, diameters^d."""
        s = _scale(scale)
        return math.pi * s**2 / 4.0 if dim == 2 else math.pi * s**3 / 6.0

    def rotational_lengths(self, scale, dim: int) -> np.ndarray:
        """(N, 0): no rotational axes."""
        return np.zeros((len(_scale(scale)), 0))

    def reach(self, scale) -> np.ndarray:
        """Radii s / 2, diameters."""
        return 0.5 * _scale(scale)

    def smallest_contact(self, scale) -> float:
        """The smallest contact distance two particles of these sizes can have."""
        return float(np.min(_scale(scale)))

    def attrs(self) -> dict:
        """The ``shape`` attribute of a packing file: {"kind": "sphere"}."""
        return {"kind": self.kind}

    def datasets(self, positions, orientations, scale) -> dict:
        """No datasets of its own in packing files."""
        return {}

    def contact_distances(self, packing, i, j, dr=None) -> np.ndarray:
        """(a_i + a_j) / 2 (``dr`` is not needed)."""
        return 0.5 * (packing.diameters[i] + packing.diameters[j])


@dataclass(frozen=True)
class Ellipsoid:
    """An ellipse (2D) or spheroid (3D) with aspect ratio ``alpha`` = a / b: full length a along
    the director (body x), b across; alpha > 1 prolate, alpha < 1 oblate (3D). The scale of a
    particle is its b. ``contact``: the contact-distance method (``shapes.contact_distance``)."""

    alpha: float  #: aspect ratio a / b (> 0, not 1)
    contact: str = "exact"  #: the contact-distance method (``METHODS``)

    kind = "ellipsoid"  #: the shape's kind in files and tables
    oriented = True  #: particles carry orientations
    round = False  #: not a disk/sphere
    elliptic = True  #: an ellipse/spheroid: ``axes`` and a contact-distance method
    made_of_sites = False  #: not a body of spherical sites
    sphere_contacts = False  #: contacts are between ellipses/spheroids
    bounded = False  #: walls, gravity and fixed particles are not written for it
    double_double = False  #: float64 only
    force_tol_base = ELLIPSOID_FORCE_TOL_BASE  #: default force tolerance before box scaling (mechanics.force_floor)

    spec_words = ("ellipse", "spheroid")  #: the first words of its --shape specs (``model.shapes.parse``)
    spec_usage = "ellipse:ALPHA (2D) | spheroid:ALPHA (3D)"  #: its specs in the --shape usage line

    @classmethod
    def from_spec(cls, spec: str, word: str, rest: str, dim: int, contact: str):
        """``ellipse:ALPHA`` (2D) or ``spheroid:ALPHA`` (3D); ALPHA = 1 gives the disk/sphere."""
        wanted = {"ellipse": 2, "spheroid": 3}[word]
        if dim != wanted:
            raise ValueError(f"shape {spec!r}: '{word}' is {wanted}D, the packing is {dim}D; use "
                             f"{'spheroid' if dim == 3 else 'ellipse'}:ALPHA")
        try:
            alpha = float(rest)
        except ValueError:
            raise ValueError(f"shape {spec!r}: ALPHA in {word}:ALPHA must be a number, e.g. {word}:1.5") from None
        if not (math.isfinite(alpha) and alpha > 0):
            raise ValueError(f"shape {spec!r}: ALPHA must be a finite number > 0")
        if alpha == 1.0:
            return SPHERE
        shape = cls(alpha, contact)
        shape.check(dim)
        return shape

    @classmethod
    def from_attrs(cls, attrs: dict):
        """The ellipse/spheroid of a packing file's ``shape`` attributes (alpha, contact)."""
        return cls(float(attrs["alpha"]), str(attrs.get("contact", "exact")))

    @property
    def aspect_ratio(self) -> float:
        """ALPHA of shape annealing: ``alpha``."""
        return float(self.alpha)

    def __post_init__(self):
        from jamflow.model.shapes.contact_distance import METHODS

        if not (isinstance(self.alpha, (int, float)) and math.isfinite(self.alpha) and self.alpha > 0):
            raise ValueError(f"aspect ratio ALPHA must be a finite number > 0, got {self.alpha!r}")
        if self.alpha == 1.0:
            raise ValueError("aspect ratio 1 is a disk/sphere: use the sphere shape (parse_shape does)")
        if self.contact not in METHODS:
            raise ValueError(f"unknown contact-distance method {self.contact!r}; use one of {', '.join(METHODS)}")

    def name(self, dim: int) -> str:
        """"ellipse" in 2D, "spheroid" in 3D."""
        return "ellipse" if dim == 2 else "spheroid"

    def spec(self, dim: int) -> str:
        """The ``--shape`` spec, e.g. ``ellipse:1.5``."""
        return f"{self.name(dim)}:{self.alpha:g}"

    def check(self, dim: int) -> None:
        """Refuse a 2D ALPHA < 1 (the ellipse of 1 / ALPHA turned by 90 degrees)."""
        if dim == 2 and self.alpha < 1:
            raise ValueError(f"an ellipse with ALPHA = {self.alpha:g} < 1 is the ellipse with ALPHA = "
                             f"{1 / self.alpha:g} turned by 90 degrees; use ellipse:{1 / self.alpha:g}")

    def check_sizes(self, scale, dim: int) -> None:
        """Refuse a contact method outside its domain for these sizes (gaussian: identical
        particles only; linear/quadratic in 3D: identical spheroids only)."""
        from jamflow.model.shapes.contact_distance import SAME_SIZE_RTOL, check_method_sizes

        s = _scale(scale)
        identical = len(s) == 0 or bool(np.all(np.abs(s - s[0]) <= SAME_SIZE_RTOL * np.abs(s[0])))
        try:
            check_method_sizes(self.contact, dim, identical)
        except ValueError as err:
            raise ValueError(f"--contact {self.contact} on particles of different sizes: {err}; or use --sizes mono") from None

    def dof(self, dim: int) -> int:
        """d_f: 3 in 2D, 5 in 3D (the rotation about the director is void)."""
        return 3 if dim == 2 else 5

    def rotation_mask(self, dim: int) -> tuple[bool, ...]:
        """2D: (True,); 3D: (False, True, True), no rotation about the director."""
        return (True,) if dim == 2 else (False, True, True)

    def axes(self, scale) -> np.ndarray:
        """(N, 2): full lengths along and across the director."""
        s = _scale(scale)
        return np.column_stack([self.alpha * s, s])

    def volumes(self, scale, dim: int) -> np.ndarray:
        """pi a b / 4 (2D) or pi a b^2 / 6 (3D) per particle, diameters^d."""
        a, b = self.axes(scale).T
        return math.pi * a * b / 4.0 if dim == 2 else math.pi * a * b * b / 6.0

    def rotational_lengths(self, scale, dim: int) -> np.ndarray:
        """2D: sqrt(a^2 + b^2) / 4 (chapter section 3); 3D: sqrt((a^2 + b^2) / 20) about the two
        axes across the director (I/m = (A^2 + B^2)/5 for semi-axes A, B), 1 about the director
        (not a degree of freedom)."""
        a, b = self.axes(scale).T
        if dim == 2:
            return (np.sqrt(a * a + b * b) / 4.0)[:, None]
        d = np.sqrt((a * a + b * b) / 20.0)
        return np.column_stack([np.ones_like(d), d, d])

    def reach(self, scale) -> np.ndarray:
        """Half the longer axis, diameters."""
        return 0.5 * np.max(self.axes(scale), axis=1)

    def smallest_contact(self, scale) -> float:
        """The shortest axis of any particle: the smallest contact distance, diameters."""
        return float(np.min(self.axes(scale)))

    def attrs(self) -> dict:
        """The ``shape`` attribute of a packing file: kind, alpha and contact method."""
        return {"kind": self.kind, "alpha": float(self.alpha), "contact": self.contact}

    def datasets(self, positions, orientations, scale) -> dict:
        """``axes`` (N, 2): full lengths along and across the director."""
        return {"axes": self.axes(scale)}

    def contact_distances(self, packing, i, j, dr) -> np.ndarray:
        """The contact distance of the shape's method (``shapes.contact_distance``) along the
        separations ``dr`` (P, d) = r_i - r_j."""
        from jamflow.model.shapes.contact_distance import contact_distance

        axes, u = self.axes(packing.diameters), packing.directors
        r_hat = dr / np.linalg.norm(dr, axis=1)[:, None]
        return contact_distance(axes[i, 0], axes[i, 1], axes[j, 0], axes[j, 1], r_hat, u[i], u[j],
                                method=self.contact)


@dataclass(frozen=True, eq=False)
class RigidBody:
    """A rigid body of fused spherical sites (chapter section 2.3.1, Figure 2.9).

    ``sites`` (S, d) and ``site_diameters`` (S,) describe the body at scale 1, in any frame:
    the constructor moves the origin to the centre of mass of the union of the sites and turns
    the sites to the principal axes, smallest moment first (the body x-axis, the director of a
    linear body), in the frame ``jamflow.model.frames.principal_frame`` fixes by the sites
    (proper; signs and tied axes independent of the eigen-solver). With ``body_frame=True`` the
    sites are taken as given, already in that frame (as a packing file stores them), so
    orientations keep their meaning. Site overlap inside a body carries no energy; the volume is
    the union's (``shapes.union``). ``label`` names the body (e.g. "dimer:1.5") for files and
    messages.
    """

    sites: np.ndarray  #: (S, d) site centres in the body frame at scale 1
    site_diameters: np.ndarray  #: (S,) site diameters at scale 1
    label: str = "rigid"  #: the body's name, e.g. "dimer:1.5"
    fused: bool = True  #: the sites must overlap or touch into one connected piece
    body_frame: bool = False  #: the sites are given in the body frame already
    _mass: dict = field(default_factory=dict, repr=False, compare=False)

    kind = "rigid"  #: the shape's kind in files and tables
    oriented = True  #: particles carry orientations
    round = False  #: not a disk/sphere
    elliptic = False  #: not an ellipse/spheroid
    made_of_sites = True  #: a body of spherical sites, which touches site by site
    sphere_contacts = True  #: every contact is between two spherical sites (the polish's least squares)
    bounded = False  #: walls, gravity and fixed particles are not written for it
    double_double = False  #: float64 only
    aspect_ratio = None  #: no ALPHA of shape annealing
    force_tol_base = FORCE_TOL_BASE  #: default force tolerance before box scaling (mechanics.force_floor)
    #: no spec words of its own: its specs name the body (nmer, dimer, trimer; ``shapes.nmers``, ``parse.SPECS``)
    spec_words = ()
    spec_usage = "nmer:N:ALPHA | dimer:ALPHA:S | trimer:ALPHA:C"  #: its specs in the --shape usage line

    @classmethod
    def from_attrs(cls, attrs: dict):
        """The body a packing file's ``shape`` attributes describe (sites in the body frame)."""
        return cls(np.array(json.loads(attrs["sites"])), np.array(json.loads(attrs["site_diameters"])),
                   str(attrs.get("label", "rigid")), body_frame=True)

    def __post_init__(self):
        sites = np.array(self.sites, dtype=float)
        diam = np.array(self.site_diameters, dtype=float)
        if sites.ndim != 2 or sites.shape[1] not in (2, 3) or len(sites) < 2:
            raise ValueError(f"a rigid body needs at least 2 sites of shape (S, 2|3), got {sites.shape}")
        if diam.shape != (len(sites),) or not np.all(np.isfinite(diam)) or np.any(diam <= 0):
            raise ValueError("site_diameters must be one finite positive diameter per site")
        if not np.all(np.isfinite(sites)):
            raise ValueError("site positions must be finite")
        if self.fused:
            _check_fused(sites, diam)
        volume, first, second = union_moments(sites, diam)
        centre = first / volume
        central = second - volume * np.outer(centre, centre)  # second moments about the centre
        inertia = np.trace(central) * np.eye(len(centre)) - central if len(centre) == 3 else None
        if self.body_frame:
            size = float(np.abs(sites).max() + diam.max())
            if np.abs(centre).max() > 1e-9 * size:
                raise ValueError(f"body-frame sites must have their centre of mass at the origin, it is at {centre}")
            centre, frame = np.zeros_like(centre), np.eye(len(centre))
        else:
            frame = principal_frame(inertia if inertia is not None else -central, sites - centre)
        body = (sites - centre) @ frame
        body[np.abs(body) < 1e-14 * max(1.0, np.abs(body).max())] = 0.0
        body.setflags(write=False)
        diam.setflags(write=False)
        object.__setattr__(self, "sites", body)
        object.__setattr__(self, "site_diameters", diam)
        polar = float(np.trace(central))
        principal = (np.diag(frame.T @ inertia @ frame) if inertia is not None else np.array([polar]))
        self._mass.update(volume=volume, principal=principal)

    def __eq__(self, other):
        return (isinstance(other, RigidBody) and self.label == other.label
                and np.array_equal(self.sites, other.sites) and np.array_equal(self.site_diameters, other.site_diameters))

    __hash__ = object.__hash__

    @property
    def dim(self) -> int:
        """d of the sites."""
        return self.sites.shape[1]

    @property
    def n_sites(self) -> int:
        """S, sites per body."""
        return len(self.sites)

    @property
    def linear(self) -> bool:
        """All sites on the body x-axis (then the rotation about it is no degree of freedom)."""
        return bool(np.all(self.sites[:, 1:] == 0.0))

    def name(self, dim: int) -> str:
        """The body's label."""
        return self.label

    def spec(self, dim: int) -> str:
        """The body's label (its ``--shape`` spec)."""
        return self.label

    def check(self, dim: int) -> None:
        """Refuse a packing of the other dimension than the sites."""
        if dim != self.dim:
            raise ValueError(f"the body {self.label} has {self.dim}D sites; the packing is {dim}D")

    def check_sizes(self, scale, dim: int) -> None:
        """Any sizes: nothing to refuse."""
        pass

    def dof(self, dim: int) -> int:
        """d_f: 3 in 2D; 3D: 5 for a linear body, else 6."""
        return 3 if dim == 2 else (5 if self.linear else 6)

    def rotation_mask(self, dim: int) -> tuple[bool, ...]:
        """2D: (True,); 3D: every body axis, but not the axis of a linear body."""
        return (True,) if dim == 2 else (not self.linear, True, True)

    def volumes(self, scale, dim: int) -> np.ndarray:
        """The union's volume at scale 1 times scale^d, diameters^d."""
        return self._mass["volume"] * _scale(scale) ** dim

    def rotational_lengths(self, scale, dim: int) -> np.ndarray:
        """sqrt(I_a / m) about each principal body axis (uniform density); 1 about the axis of a
        linear body (not a degree of freedom)."""
        g = np.sqrt(self._mass["principal"] / self._mass["volume"])
        if dim == 3 and self.linear:
            g = np.array([1.0, g[1], g[2]])
        return _scale(scale)[:, None] * g[None, :]

    @property
    def site_masses(self) -> np.ndarray:
        """(S,) fractions of the body's mass on each site such that the mass-weighted site centre
        is the union's centre of mass (the body-frame origin): LAMMPS's rigid-body centre is the
        mass-weighted centre of its atoms. The minimum-norm solution of sum m = 1, sum m b = 0
        (equal masses for symmetric bodies); ValueError if a site would need a mass <= 0."""
        if "sites" not in self._mass:
            a = np.vstack([np.ones(self.n_sites), self.sites.T])
            e = np.zeros(len(a))
            e[0] = 1.0
            m = np.linalg.lstsq(a, e, rcond=None)[0]
            size = float(np.abs(self.sites).max() + self.site_diameters.max())
            if np.abs(a @ m - e).max() > 1e-12 * max(1.0, size) or np.any(m <= 0):
                raise ValueError(f"no positive site masses put the site centre of mass of {self.label} at the "
                                 "union's centre of mass; LAMMPS cannot run this body (use engine numba)")
            m.setflags(write=False)
            self._mass["sites"] = m
        return self._mass["sites"]

    def reach(self, scale) -> np.ndarray:
        """Largest distance from the centre to a site's surface, times the scale (diameters)."""
        r = float(np.max(np.linalg.norm(self.sites, axis=1) + 0.5 * self.site_diameters))
        return r * _scale(scale)

    def smallest_contact(self, scale) -> float:
        """The smallest site diameter of the smallest particle (diameters)."""
        return float(np.min(_scale(scale)) * self.site_diameters.min())

    def world_sites(self, positions, orientations, scale) -> np.ndarray:
        """(N, S, d) site positions of every particle."""
        from jamflow.model.shapes.rotations import rotation_matrices

        rot = rotation_matrices(orientations, positions.shape[1])
        return positions[:, None, :] + _scale(scale)[:, None, None] * np.einsum("nab,sb->nsa", rot, self.sites)

    def attrs(self) -> dict:
        """The ``shape`` attribute of a packing file: kind, label, sites and site diameters."""
        return {"kind": self.kind, "label": self.label, "sites": json.dumps(self.sites.tolist()),
                "site_diameters": json.dumps(self.site_diameters.tolist())}

    def datasets(self, positions, orientations, scale) -> dict:
        """World sites (N, S, d) and site diameters (N, S)."""
        return {"sites": self.world_sites(positions, orientations, scale),
                "site_diameters": _scale(scale)[:, None] * self.site_diameters[None, :]}

    def contact_distances(self, packing, i, j, dr=None) -> np.ndarray:
        """Bodies touch site by site (``model.pairs.overlapping_sites``): ValueError."""
        raise ValueError(f"{self.name(packing.dim)} particles touch site by site; use overlapping_sites")


def _check_fused(sites: np.ndarray, diam: np.ndarray) -> None:
    """Sites of a fused body must overlap (or touch) into one connected piece and must not
    coincide. Touching sites (separation = the mean diameter, to 1e-12) count as joined: the
    dimer at alpha = 2 of Schreck, Xu, O'Hern, Soft Matter 6, 2960 (2010)."""
    s = len(sites)
    sep = np.linalg.norm(sites[:, None] - sites[None], axis=-1)
    reach = 0.5 * (diam[:, None] + diam[None])
    if np.any(sep[np.triu_indices(s, 1)] < 1e-12 * reach[np.triu_indices(s, 1)]):
        raise ValueError("two sites of the body coincide; give distinct site positions")
    linked, frontier = {0}, [0]
    while frontier:
        k = frontier.pop()
        for m in np.flatnonzero(sep[k] <= reach[k] * (1.0 + 1e-12)):
            if m not in linked:
                linked.add(int(m))
                frontier.append(int(m))
    if len(linked) < s:
        raise ValueError(f"the body's sites do not overlap or touch into one piece (sites {sorted(set(range(s)) - linked)} are "
                         "apart from site 0); move them closer or pass fused=False for bodies of separate sites")


SPHERE = Sphere()


SHAPES = {cls.kind: cls for cls in (Sphere, Ellipsoid, RigidBody)}  #: every shape class by its kind
#: what every shape class declares, True or False (module docstring)
CAPABILITIES = ("oriented", "round", "elliptic", "made_of_sites", "sphere_contacts", "bounded", "double_double")


def shape_from_attrs(attrs: dict):
    """The shape a packing file's ``shape`` attributes describe."""
    kind = attrs.get("kind", "sphere")
    cls = SHAPES.get(kind)
    if cls is None:
        raise ValueError(f"unknown particle shape kind {kind!r} in packing file")
    return cls.from_attrs(attrs)
