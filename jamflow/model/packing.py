"""The ``Packing`` value object: the whole configuration of a particle system.

Positions, sizes, orientations and the particle shape, the periodic box and the pair
potential: everything an engine, an analysis or a file needs. Immutable: every operation
returns a new Packing. Units: lengths in small diameters (the scale 1 of the smallest
particle), energies in epsilon, masses 1.

Sizes: ``diameters[i]`` is particle i's scale: the diameter of a disk/sphere, the
across-axis length b of an ellipse/spheroid, the scale factor of a rigid body's sites
(``jamflow.model.shapes``). Orientations (``jamflow.model.shapes.rotations``): None for disks and
spheres; (N,) angles in 2D, (N, 4) unit quaternions in 3D for every other shape.

Boundaries (chapter section 2.3, ``jamflow.model.walls``): the box's walled axes carry flat walls at
their faces; ``fixed`` marks particles held in place (the particles of rough walls, which
sit on the wall faces); ``gravity`` g pulls every mobile particle (mass 1) along -e_(d-1)
onto the floor x_(d-1) = 0, which must be a wall.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field, replace

import numpy as np

from jamflow.model.box import Box
from jamflow.model.ordering import SPATIAL_ORDER_FROM, morton_order
from jamflow.model.potentials import Potential, Spring
from jamflow.model.shapes.rotations import check_orientations, directors, start_orientations
from jamflow.model.shapes.shape import SPHERE
from jamflow.model.sizes import SizeSpec


@dataclass(frozen=True)
class Extended:
    """Double-double coordinates of a packing (``jamflow.model.ddouble``; docs/guide/precision.md): the true
    positions are ``Packing.positions + positions_lo`` and the true side lengths of the orthogonal
    periodic box ``Packing.box.lengths + lengths_lo``. ``positions_hi`` and ``lengths_hi`` record the
    float64 parts they were made with: a Packing whose positions or box differ (any operation that
    moves the particles in float64) drops them, so a stale low part never survives a move."""

    positions_hi: np.ndarray  #: (N, d)
    positions_lo: np.ndarray  #: (N, d)
    lengths_hi: np.ndarray  #: (d,)
    lengths_lo: np.ndarray  #: (d,)

    def matches(self, positions: np.ndarray, box: Box) -> bool:
        return (self.positions_hi.shape == positions.shape and bool(np.array_equal(self.positions_hi, positions))
                and not box.is_triclinic and bool(np.array_equal(self.lengths_hi, box.lengths)))


def check_low_part(name: str, lo, shape: tuple) -> np.ndarray:
    """``lo`` as a float64 array of ``shape`` with finite values; a one-line ValueError naming it otherwise."""
    arr = np.asarray(lo, dtype=float)
    if arr.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite")
    return arr


def warn_float64_only(packing: Packing, what: str) -> None:
    """Warn that ``what`` reads only the float64 part of a double-double packing."""
    if packing.extended is not None:
        source = packing.metadata.get("source", "the packing")
        warnings.warn(f"{source} carries extended precision (positions_lo, precision = double-double); {what} uses "
                      "the float64 positions only", stacklevel=3)


# Densest packings of equal disks (hexagonal) and spheres (FCC): pi/(2 sqrt 3), pi/(3 sqrt 2).
DENSEST_PHI = {2: math.pi / (2 * math.sqrt(3)), 3: math.pi / (3 * math.sqrt(2))}


class BoxTooSmall(ValueError):
    """The box is narrower than twice the largest contact distance (``fits_cell``)."""


def fits_cell(box: Box, reach: float) -> bool:
    """True when a contact distance of up to 2 ``reach`` (the largest particle's reach, twice)
    stays below half of every width of the reduced cell, so each pair has one minimum image."""
    return 4.0 * reach < float(box.widths.min())


def densest_phi(packing: "Packing") -> float:
    """The largest packing fraction of ``packing``'s particles in a box of its shape with a unique
    minimum image: the smallest width twice the largest contact distance (``fits_cell``)."""
    reach = float(packing.shape.reach(packing.diameters).max())
    return packing.phi * (float(packing.box.widths.min()) / (4.0 * reach)) ** packing.dim


def particle_volumes(diameters: np.ndarray, dim: int) -> np.ndarray:
    """Area (2D) or volume (3D) of disks/spheres with the given diameters."""
    return SPHERE.volumes(diameters, dim)


@dataclass(frozen=True)
class Packing:
    """N particles of one shape in a periodic box, with their pair potential."""

    positions: np.ndarray  #: (N, d) centres, in diameters (the small diameter is 1)
    #: (N,) each particle's size scale: the diameter of disks and spheres, the width b of ellipsoids
    diameters: np.ndarray
    box: Box  #: the cell (``Box``): periodic, tilted, or with walls
    potential: Potential = field(default_factory=Spring)  #: the pair law (``Spring`` or ``RepulsiveLJ``)
    #: free-form values carried with the packing (written to files as attributes)
    metadata: dict = field(default_factory=dict)
    shape: object = SPHERE  #: the particle shape (``jamflow.parse_shape``); disks/spheres by default
    #: (N,) angles (2D) or (N, 4) unit quaternions (w, x, y, z) (3D); None for disks, spheres
    orientations: np.ndarray | None = None
    fixed: np.ndarray | None = None  #: (N,) bool: held in place (rough-wall particles); None: none
    gravity: float = 0.0  #: g: force per (unit-mass) mobile particle along -e_(d-1), eps / diameter
    extended: Extended | None = None  #: double-double low parts (``Extended``); None: float64 exactly

    def __post_init__(self):
        pos = np.array(self.positions, dtype=float)
        dia = np.array(self.diameters, dtype=float)
        if pos.ndim != 2 or pos.shape[1] != self.box.dim:
            raise ValueError(f"positions must have shape (N, {self.box.dim}), got {pos.shape}")
        if dia.shape != (pos.shape[0],):
            raise ValueError(f"diameters must have shape ({pos.shape[0]},), got {dia.shape}")
        if not (np.all(np.isfinite(pos)) and np.all(np.isfinite(dia))):
            raise ValueError("positions and diameters must be finite")
        if np.any(dia <= 0):
            raise ValueError("diameters must be positive")
        self.shape.check(self.box.dim)
        self.shape.check_sizes(dia, self.box.dim)
        if self.shape.oriented:
            if self.orientations is None:
                raise ValueError(f"a packing of {self.shape.name(self.box.dim)} particles needs orientations")
            orient = check_orientations(self.orientations, len(pos), self.box.dim)
            orient.setflags(write=False)
            object.__setattr__(self, "orientations", orient)
        elif self.orientations is not None:
            raise ValueError("disks and spheres have no orientations; pass orientations=None")
        self._check_boundary(len(dia))
        if len(dia) and not fits_cell(self.box, self.shape.reach(dia).max()):
            raise BoxTooSmall("box too small: the largest contact distance must stay below half "
                              "the box width for a unique minimum image; use more particles")
        pos.setflags(write=False)
        dia.setflags(write=False)
        if self.extended is not None and not self.extended.matches(pos, self.box):
            object.__setattr__(self, "extended", None)
        object.__setattr__(self, "positions", pos)
        object.__setattr__(self, "diameters", dia)

    def __repr__(self) -> str:
        """One line: N, dim, shape, phi, potential, box lengths (and walls, strain, fixed particles,
        gravity when present); the arrays are the fields."""
        box = self.box
        extra = (f", walls={box.wall_spec!r}" if box.walls else "") + (
            f", gamma={box.shear_strain:.6g}" if box.is_triclinic else "") + (
            f", fixed={int(self.fixed.sum())}" if self.fixed is not None else "") + (
            f", gravity={self.gravity:g}" if self.gravity else "")
        return (f"Packing(N={self.n}, dim={self.dim}, shape={self.shape.spec(self.dim)!r}, phi={self.phi:.6f}, "
                f"potential={self.potential.spec!r}, box={' x '.join(f'{v:.6g}' for v in box.lengths)}{extra})")

    def _check_boundary(self, n: int) -> None:
        if self.fixed is not None:
            fixed = np.array(self.fixed, dtype=bool)
            if fixed.shape != (n,):
                raise ValueError(f"fixed must be a boolean mask of shape ({n},), got {np.shape(self.fixed)}")
            if fixed.all():
                raise ValueError("every particle is fixed: nothing can move; mark only the wall particles fixed")
            fixed.setflags(write=False)
            object.__setattr__(self, "fixed", fixed if fixed.any() else None)
        g = self.gravity
        if not (isinstance(g, (int, float, np.floating)) and math.isfinite(g) and g >= 0):
            raise ValueError(f"gravity must be a finite number >= 0 (eps/diameter per particle), got {g!r}")
        object.__setattr__(self, "gravity", float(g))
        if g > 0 and self.box.periodic[-1]:
            floor = "yz"[self.box.dim - 2]
            raise ValueError(f"gravity without a floor: gravity pulls along -{floor}, but {floor} is periodic; "
                             f"add walls on {floor} (--walls {floor})")

    @property
    def precision(self) -> str:
        """"double-double" when the packing carries low parts (``extended``), else "double"."""
        return "double" if self.extended is None else "double-double"

    @property
    def positions_lo(self) -> np.ndarray:
        """(N, d) low parts of the positions: true position = positions + positions_lo (zeros in float64)."""
        return np.zeros_like(self.positions) if self.extended is None else self.extended.positions_lo

    @property
    def lengths_lo(self) -> np.ndarray:
        """(d,) low parts of the box side lengths (zeros in float64)."""
        return np.zeros(self.dim) if self.extended is None else self.extended.lengths_lo

    def with_low_parts(self, positions_lo, lengths_lo=None) -> "Packing":
        """This packing with double-double low parts (orthogonal periodic boxes); refused with a
        one-line ValueError for a wrong shape or non-finite values."""
        if self.box.is_triclinic or self.box.walls:
            raise ValueError("double-double coordinates are written for orthogonal periodic boxes")
        lo = check_low_part("positions_lo", positions_lo, self.positions.shape)
        llo = check_low_part("box_lo", np.zeros(self.dim) if lengths_lo is None else lengths_lo, (self.dim,))
        return replace(self, extended=Extended(self.positions, lo, self.box.lengths, llo))

    @property
    def n(self) -> int:
        """Number of particles N."""
        return len(self.diameters)

    @property
    def mobile(self) -> np.ndarray:
        """(N,) bool: particles that move (all but the fixed ones)."""
        return np.ones(self.n, bool) if self.fixed is None else ~self.fixed

    @property
    def n_mobile(self) -> int:
        """Particles that move: the N of energies per particle and of the contact count."""
        return self.n if self.fixed is None else int(self.n - self.fixed.sum())

    @property
    def dim(self) -> int:
        """Dimension d, 2 or 3."""
        return self.box.dim

    @property
    def volumes(self) -> np.ndarray:
        """Area (2D) or volume (3D) of every particle."""
        return self.shape.volumes(self.diameters, self.dim)

    @property
    def phi(self) -> float:
        """Packing fraction: particle volume inside the box over the box volume, which with
        walls is the volume between them (mobile particles count whole, fixed wall particles
        by the fraction inside: ``jamflow.model.packing.inside_fraction``)."""
        if self.fixed is None:
            return float(self.volumes.sum() / self.box.volume)
        from jamflow.model.packing import inside_fraction

        return float((self.volumes * inside_fraction(self)).sum() / self.box.volume)

    @property
    def dof_per_particle(self) -> int:
        """d_f of the chapter (section 3)."""
        return self.shape.dof(self.dim)

    @property
    def directors(self) -> np.ndarray | None:
        """(N, d) unit vectors along each particle's body x-axis (None for disks/spheres)."""
        return None if self.orientations is None else directors(self.orientations, self.dim)

    @property
    def rotational_lengths(self) -> np.ndarray:
        """(N, r) d_k of each rotational body axis (r = 0 for disks and spheres)."""
        return self.shape.rotational_lengths(self.diameters, self.dim)

    def species(self) -> tuple[np.ndarray, np.ndarray]:
        """(distinct diameters, type index 0.. of each particle)."""
        values, index = np.unique(self.diameters, return_inverse=True)
        return values, index

    def with_positions(self, positions, box: Box | None = None, orientations=None, **metadata) -> "Packing":
        """Same particles at new positions (and orientations, if given) in ``box``."""
        return replace(self, positions=positions, box=box or self.box,
                       orientations=self.orientations if orientations is None else orientations,
                       metadata={**self.metadata, **metadata})

    def subset(self, keep: np.ndarray, **metadata) -> "Packing":
        """The packing of particles ``keep`` (indices or mask), same box, shape and potential."""
        orient = None if self.orientations is None else self.orientations[keep]
        fixed = None if self.fixed is None else self.fixed[keep]
        ext = self.extended
        if ext is not None:  # the low parts of the kept particles come along
            ext = replace(ext, positions_hi=ext.positions_hi[keep], positions_lo=ext.positions_lo[keep])
        return replace(self, positions=self.positions[keep], diameters=self.diameters[keep],
                       orientations=orient, fixed=fixed, extended=ext, metadata={**self.metadata, **metadata})

    def scaled_to_phi(self, phi: float) -> "Packing":
        """Affine rescaling of box and positions to packing fraction ``phi``."""
        factor = (self.phi / phi) ** (1.0 / self.dim)
        return self.with_positions(self.positions * factor, self.box.scaled(factor))


def random_packing(n: int, dim: int, sizes: SizeSpec, phi: float, seed: int,
                   potential: Potential | None = None, shape=SPHERE, separated: bool = False,
                   orientations: str = "random") -> Packing:
    """Uniformly random positions in a square/cubic box at packing fraction ``phi`` and, for
    shapes that are not round, uniformly random orientations (chapter step 1), all aligned
    along x with ``orientations="aligned"``, or in a cone about x with nematic order S with
    ``"nematic:S"`` (``rotations.start_orientations``). Diameters are
    drawn first, then positions, then orientations, from one generator. ``separated`` (rigid
    bodies): orientations first, then positions by random sequential addition, so that no two
    bodies overlap (``separated_positions``). From ``SPATIAL_ORDER_FROM`` particles on, the
    particles (with their sizes and orientations) are then numbered along a space-filling curve
    (``ordering.morton_order``): the same start, labelled so that neighbours are near in memory."""
    rng = np.random.default_rng(seed)
    diameters = sizes.draw(n, rng)
    length = (shape.volumes(diameters, dim).sum() / phi) ** (1.0 / dim)
    box = Box.cube(length, dim)
    if separated:
        turns = start_orientations(orientations, n, dim, rng)
        positions = separated_positions(shape, diameters, turns, box, rng)
    else:
        positions = rng.random((n, dim)) * length
        turns = start_orientations(orientations, n, dim, rng) if shape.oriented else None
    if n >= SPATIAL_ORDER_FROM:  # labels along a space-filling curve: the same particles, cache-friendly arrays
        order = morton_order(box.to_fractional(positions))
        diameters, positions = diameters[order], positions[order]
        turns = None if turns is None else turns[order]
    metadata = {"seed": seed, "sizes": sizes.spec, **({"orientations": orientations} if shape.oriented else {})}
    return Packing(positions, diameters, box, potential or Spring(), metadata=metadata, shape=shape,
                   orientations=turns)


SEPARATION_TRIES = 10_000  # random positions tried per body before random sequential addition gives up


class SeparationFailed(ValueError):
    """Random sequential addition found no place for a body: the start is too dense."""


def separated_positions(shape, diameters, orientations, box: Box, rng: np.random.Generator) -> np.ndarray:
    """Random sequential addition of rigid bodies, the largest first: each at a uniform random
    position, drawn again while any of its sites overlaps a site of a body already placed
    (minimum image). Soft
    concave bodies started on top of each other can stay interlocked (two crossed dimers at
    alpha = 2 are a local energy minimum, site overlaps 1 - 1/sqrt 2: docs/notes/nmers.md)."""
    n, dim = len(diameters), box.dim
    local = shape.world_sites(np.zeros((n, dim)), orientations, diameters)  # (N, S, d) about each centre
    site_d = diameters[:, None] * shape.site_diameters[None, :]
    placed, placed_d = np.empty((0, dim)), np.empty(0)
    positions = np.empty((n, dim))
    for k in np.argsort(-np.asarray(diameters), kind="stable"):
        for _ in range(SEPARATION_TRIES):
            centre = box.to_cartesian(rng.random(dim))
            sites = centre + local[k]
            gap = np.linalg.norm(box.minimum_image(sites[:, None, :] - placed[None, :, :]), axis=-1)
            if np.all(gap >= 0.5 * (site_d[k][:, None] + placed_d[None, :])):
                break
        else:
            raise SeparationFailed(f"random sequential addition found no place for body {k + 1} of {n} at packing fraction "
                             f"{shape.volumes(diameters, dim).sum() / box.volume:.3f}; use a lower phi0")
        positions[k] = centre
        placed, placed_d = np.vstack([placed, sites]), np.concatenate([placed_d, site_d[k]])
    return positions


ON_FACE = 1e-9  # a fixed particle lies on a face when |x_a - face| < ON_FACE * L_a


def face_membership(packing) -> np.ndarray:
    """(N, d, 2) bool: particle i is a fixed particle centred on the lower/upper face of axis a."""
    out = np.zeros((packing.n, packing.dim, 2), bool)
    if packing.fixed is None:
        return out
    x, lengths = packing.positions, packing.box.lengths
    for a in packing.box.walls:
        tol = ON_FACE * lengths[a]
        out[:, a, 0] = packing.fixed & (np.abs(x[:, a]) < tol)
        out[:, a, 1] = packing.fixed & (np.abs(x[:, a] - lengths[a]) < tol)
    return out


def inside_fraction(packing) -> np.ndarray:
    """(N,) fraction of each particle's volume counted inside the walls: 1 for mobile
    particles, 2^-k for a fixed particle on k faces (exact while wall particles do not overlap)."""
    faces = face_membership(packing).sum(axis=(1, 2))
    return 0.5 ** faces
