"""Periodic simulation cell: the h-matrix, shear tilt, and the LAMMPS convention.

The cell is an upper-triangular matrix ``h`` whose *columns* are the cell vectors
(units: small-particle diameter). In 3D::

    h = [[lx, xy, xz],
         [ 0, ly, yz],
         [ 0,  0, lz]]

which is exactly LAMMPS's restricted triclinic cell (``xy``, ``xz``, ``yz`` are tilt
*lengths*). The shear strain of Lees-Edwards boundaries is ``gamma = xy / ly``
(chapter eq. 2.4, Figure 2.4). freud and HOOMD use dimensionless tilts ``xy / ly``; see ``to_freud``.

``h`` may hold any tilt: it is the *accumulated* cell of a shear run (gamma = 3.7 is a
different strain history from gamma = 0.7, but the same lattice). ``reduced()`` is the same
lattice with the tilts folded into LAMMPS's range (xy, xz in [-lx/2, lx/2), yz in
[-ly/2, ly/2)); the lattice-dependent operations (``wrap``, ``minimum_image``, ``widths``)
and the cell handed to LAMMPS and freud use the reduced cell, so they do not depend on how
the strain was reached.
See docs/notes/shear-cell.md.

Walls (chapter section 2.3): an axis that is not ``periodic`` is bounded by flat walls at its
faces, x_a = 0 and x_a = L_a; separations along it are direct (no image) and positions are
not wrapped along it. A walled axis can take part in no tilt: a shear across a wall has no
periodic image to act on, and a tilted face is no flat axis-aligned wall.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from itertools import product

import numpy as np

AXES = "xyz"


@dataclass(frozen=True)
class Box:
    """An upper-triangular cell; ``h`` columns are the cell vectors; ``periodic`` per axis
    (None: every axis periodic; False: walls at both faces of that axis)."""

    #: (d, d) upper-triangular cell matrix, cell vectors as columns: [[lx, xy, xz], [0, ly, yz], [0, 0, lz]], diameters
    h: np.ndarray
    #: one flag per axis; None: every axis periodic; False: walls at both faces of that axis
    periodic: tuple | None = None

    def __post_init__(self):
        h = np.array(self.h, dtype=float)
        if h.ndim != 2 or h.shape[0] != h.shape[1] or h.shape[0] not in (2, 3):
            raise ValueError(f"Box h-matrix must be 2x2 or 3x3, got shape {h.shape}")
        if not np.all(np.isfinite(h)):
            raise ValueError("Box h-matrix has non-finite entries")
        if np.any(np.tril(h, -1) != 0):
            raise ValueError("Box h-matrix must be upper-triangular (LAMMPS restricted triclinic)")
        if np.any(np.diag(h) <= 0):
            raise ValueError(f"Box side lengths must be positive, got {np.diag(h)}")
        periodic = (True,) * len(h) if self.periodic is None else tuple(bool(p) for p in self.periodic)
        if len(periodic) != len(h):
            raise ValueError(f"periodic needs one flag per axis ({len(h)}), got {self.periodic!r}")
        for a, b in zip(*np.triu_indices(len(h), 1)):
            if h[a, b] != 0 and not (periodic[a] and periodic[b]):
                axis = AXES[a] if not periodic[a] else AXES[b]
                raise ValueError(f"walls on {axis} with a sheared box (tilt {AXES[a]}{AXES[b]} = {h[a, b]:g}): a "
                                 f"walled axis takes part in no shear; remove the walls on {axis} or the shear")
        h.setflags(write=False)
        object.__setattr__(self, "h", h)
        object.__setattr__(self, "periodic", periodic)

    def __repr__(self) -> str:
        """One line, evaluable: the cell matrix (rows) and the periodic axes."""
        return f"Box(h={self.h.tolist()}, periodic={self.periodic})"

    # construction -----------------------------------------------------------------
    @classmethod
    def cube(cls, length: float, dim: int, periodic=None) -> "Box":
        """Square (2D) or cubic (3D) box of side ``length``."""
        return cls(np.eye(dim) * float(length), periodic)

    @classmethod
    def from_lammps(cls, dim: int, lengths, tilts=(0.0, 0.0, 0.0), periodic=None) -> "Box":
        """From LAMMPS side lengths (lx, ly[, lz]) and tilt lengths (xy, xz, yz)."""
        xy, xz, yz = tilts
        if dim == 2:
            return cls([[lengths[0], xy], [0.0, lengths[1]]], periodic)
        return cls([[lengths[0], xy, xz], [0.0, lengths[1], yz], [0.0, 0.0, lengths[2]]], periodic)

    # properties -------------------------------------------------------------------
    @property
    def dim(self) -> int:
        """Dimension d, 2 or 3."""
        return self.h.shape[0]

    @property
    def lengths(self) -> np.ndarray:
        """Diagonal of h: lx, ly[, lz]."""
        return np.diag(self.h).copy()

    @property
    def tilts(self) -> tuple[float, float, float]:
        """LAMMPS tilt lengths (xy, xz, yz); zeros where the dimension has none."""
        if self.dim == 2:
            return float(self.h[0, 1]), 0.0, 0.0
        return float(self.h[0, 1]), float(self.h[0, 2]), float(self.h[1, 2])

    @property
    def walls(self) -> tuple[int, ...]:
        """The walled (non-periodic) axes."""
        return tuple(a for a, p in enumerate(self.periodic) if not p)

    @property
    def wall_spec(self) -> str:
        """The walled axes as ``--walls`` writes them ("" without walls, "y", "x,y")."""
        return ",".join(AXES[a] for a in self.walls)

    def image_offsets(self):
        """Cell offsets m in {-1, 0, 1}^d of the neighbouring periodic images (0 along walls)."""
        return product(*[(-1, 0, 1) if p else (0,) for p in self.periodic])

    @property
    def is_triclinic(self) -> bool:
        """True when some tilt (xy, xz, yz) is nonzero."""
        return bool(np.any(self.tilts))

    @property
    def volume(self) -> float:
        """Area in 2D, volume in 3D."""
        return float(np.prod(np.diag(self.h)))

    @property
    def shear_strain(self) -> float:
        """Lees-Edwards strain gamma = xy / ly (chapter eq. 2.4)."""
        return float(self.h[0, 1] / self.h[1, 1])

    @property
    def widths(self) -> np.ndarray:
        """Perpendicular distances between opposite faces of the reduced cell; a pair cutoff
        must stay below half the smallest one for the minimum image to be unique."""
        inv = np.linalg.inv(self.reduced().h)
        return 1.0 / np.linalg.norm(inv, axis=1)

    # the lattice ------------------------------------------------------------------------
    def reduction(self) -> tuple["Box", np.ndarray]:
        """(reduced box, integer U) with ``reduced.h == h @ U``: the same lattice with its tilts
        folded into LAMMPS's range, half-open: -lx/2 <= xy, xz < lx/2 and -ly/2 <= yz < ly/2.

        Folds in LAMMPS's order (``fix deform`` flip): yz by the second cell vector (which
        also shifts xz by the current xy), then xz and xy by the first. U is upper-unitriangular,
        so the reduced cell of a lattice is unique up to round-off in the tilts (a tilt of +l/2
        folds to -l/2). The range is tested on the folded float64 tilts themselves, so the result
        is in range and is its own reduction at every strain, k + 1/2 and its ulp neighbours too
        (see ``_fold_column``). Returns ``self`` and the identity when the tilts are already in range.
        """
        d = self.dim
        fold = np.eye(d, dtype=np.int64)
        h = self.h.copy()
        for a, b in ((1, 2), (0, 2), (0, 1)) if d == 3 else ((0, 1),):
            _fold_column(h, fold, a, b)
        if np.array_equal(fold, np.eye(d, dtype=np.int64)):
            return self, fold
        return replace(self, h=h), fold

    def reduced(self) -> "Box":
        """The same lattice with tilts folded into LAMMPS's range (see ``reduction``)."""
        return self.reduction()[0]

    def is_same_lattice(self, other: "Box", tol: float = 1e-9) -> bool:
        """True if both cells generate the same lattice: ``other.h = h @ M`` with M an
        integer matrix of determinant +-1 (entries integral to ``tol``)."""
        if other.dim != self.dim:
            return False
        m = np.linalg.solve(self.h, other.h)
        whole = np.round(m)
        return bool(np.all(np.abs(m - whole) <= tol) and abs(round(np.linalg.det(whole))) == 1)

    # transformations ----------------------------------------------------------------
    def scaled(self, factor: float) -> "Box":
        """Every cell vector multiplied by ``factor`` (isotropic compression < 1)."""
        return replace(self, h=self.h * float(factor))

    def with_h(self, h) -> "Box":
        """Another cell matrix, the same periodicity (walls)."""
        return replace(self, h=h)

    def with_shear_strain(self, gamma: float) -> "Box":
        """Same cell with the xy tilt set to ``gamma * ly``."""
        h = self.h.copy()
        h[0, 1] = gamma * h[1, 1]
        return replace(self, h=h)

    def to_fractional(self, positions: np.ndarray) -> np.ndarray:
        """(N, d) positions in cell coordinates, h^-1 r (0..1 inside the cell)."""
        return np.linalg.solve(self.h, np.asarray(positions, float).T).T

    def to_cartesian(self, fractional: np.ndarray) -> np.ndarray:
        """(N, d) cell coordinates back to positions, h s."""
        return np.asarray(fractional, float) @ self.h.T

    def wrap(self, positions: np.ndarray) -> np.ndarray:
        """Positions mapped into the primary reduced cell: fractional coordinates of
        ``reduced().h`` in [0, 1)^d along the periodic axes (LAMMPS's cell; the same as ``h``'s
        when no fold is needed); walled axes are left as they are."""
        cell = self.reduced()
        s = cell.to_fractional(positions)
        return cell.to_cartesian(s - np.floor(s) * self._periodic_mask)

    def images(self, positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(inside, image): ``positions`` (M, d) mapped into this cell, ``h``'s own (not the
        reduced one): fractional coordinates in [0, 1) along the periodic axes, walled axes left as
        they are; and the (M, d) integer image flags, so that positions = inside + image @ h.T.
        The image flags of LAMMPS data files, dumps and GSD files."""
        image = np.floor(self.to_fractional(positions)) * self._periodic_mask
        return np.asarray(positions, float) - self.to_cartesian(image), image.astype(np.int64)

    @property
    def _periodic_mask(self) -> np.ndarray:
        return np.array(self.periodic, float)

    def minimum_image(self, dr: np.ndarray) -> np.ndarray:
        """Shortest periodic image of separation vectors ``dr`` (..., d), from the reduced cell.

        Orthogonal reduced cells: rounding. Tilted ones: rounds in fractional coordinates,
        then checks the 3^d neighbouring images. Exact for every vector whose shortest image
        is below half the smallest width (rounding alone finds it: |s_k| <= |dr| / width_k),
        i.e. for every interacting pair of a valid Packing; beyond that the best of the 3^d
        candidates (exact against brute force in the tested cells, tilts up to several lx).
        Walled axes have no images: separations along them are direct.
        """
        dr = np.asarray(dr, float)
        cell = self.reduced()
        mask = self._periodic_mask
        if not cell.is_triclinic:  # rounding is exact for orthogonal cells
            lengths = cell.lengths
            return dr - lengths * np.round(dr / lengths) * mask
        s = cell.to_fractional(dr.reshape(-1, self.dim))
        base = cell.to_cartesian(s - np.round(s) * mask)
        shifts = cell.to_cartesian(np.array(list(self.image_offsets()), float))
        candidates = base[:, None, :] + shifts[None, :, :]
        best = np.argmin(np.einsum("nkd,nkd->nk", candidates, candidates), axis=1)
        return candidates[np.arange(len(base)), best].reshape(dr.shape)

    # external conventions -------------------------------------------------------------
    def to_lammps(self) -> dict:
        """Bounds for LAMMPS ``region prism`` / ``create_box`` / ``change_box`` with the origin
        at 0: the *reduced* cell (LAMMPS's tilt range; the accumulated strain is not in it)."""
        cell = self.reduced()
        lx, ly = cell.h[0, 0], cell.h[1, 1]
        lz = cell.h[2, 2] if self.dim == 3 else 1.0
        xy, xz, yz = cell.tilts
        return dict(xlo=0.0, xhi=lx, ylo=0.0, yhi=ly, zlo=-0.5 * lz if self.dim == 2 else 0.0,
                    zhi=0.5 * lz if self.dim == 2 else lz, xy=xy, xz=xz, yz=yz)

    def to_freud(self):
        """A ``freud.box.Box`` of the reduced cell (dimensionless tilts)."""
        import freud

        cell = self.reduced()
        lx, ly = cell.h[0, 0], cell.h[1, 1]
        xy, xz, yz = cell.tilts
        if self.dim == 2:
            box = freud.box.Box(Lx=lx, Ly=ly, xy=xy / ly, is2D=True)
        else:
            lz = cell.h[2, 2]
            box = freud.box.Box(Lx=lx, Ly=ly, Lz=lz, xy=xy / ly, xz=xz / lz, yz=yz / lz)
        box.periodic = list(self.periodic) + [True] * (3 - self.dim)
        return box


def _fold_column(h: np.ndarray, fold: np.ndarray, a: int, b: int) -> None:
    """Fold cell vector b by whole cell vectors a (in place, in ``h`` and in ``fold``) until the
    tilt h[a, b] lies in [-h[a, a]/2, h[a, a]/2), tested on the float64 tilt the cell holds. The
    count from tilt / length alone fails near a half period (strain k + 1/2 and its ulp
    neighbours): the quotient rounds to the other side of 1/2 and the folded tilt lands one ulp
    outside the range, so the 'reduced' cell would fold once more under its own reduction. One
    more fold corrects it, exactly (Sterbenz: the tilt is within a length of the range). A tilt
    already in range is left alone, so a reduced cell is its own reduction."""
    length, half = h[a, a], 0.5 * h[a, a]  # half: exact
    if -half <= h[a, b] < half:
        return
    x = h[a, b] / length
    n = int(np.floor(x)) + int(x - np.floor(x) >= 0.5)
    h[:, b] = h[:, b] - n * h[:, a]
    if h[a, b] >= half:
        n, h[:, b] = n + 1, h[:, b] - h[:, a]
    elif h[a, b] < -half:
        n, h[:, b] = n - 1, h[:, b] + h[:, a]
    fold[:, b] -= n * fold[:, a]


STRESS_MODES = ("iso", "aniso", "tri")  # box relaxation at a target pressure
