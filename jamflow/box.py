"""Periodic simulation cell: the h-matrix, shear tilt, and the LAMMPS convention.

The cell is an upper-triangular matrix ``h`` whose *columns* are the cell vectors
(units: small-particle diameter). In 3D::

    h = [[lx, xy, xz],
         [ 0, ly, yz],
         [ 0,  0, lz]]

which is exactly LAMMPS's restricted triclinic cell (``xy``, ``xz``, ``yz`` are tilt
*lengths*). The shear strain of Lees-Edwards boundaries is ``gamma = xy / ly``
(seed eq. 2.4). freud and HOOMD use dimensionless tilts ``xy / ly``; see ``to_freud``.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import product

import numpy as np


@dataclass(frozen=True)
class Box:
    """An upper-triangular periodic cell; ``h`` columns are the cell vectors."""

    h: np.ndarray

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
        h.setflags(write=False)
        object.__setattr__(self, "h", h)

    # construction -----------------------------------------------------------------
    @classmethod
    def cube(cls, length: float, dim: int) -> "Box":
        """Square (2D) or cubic (3D) box of side ``length``."""
        return cls(np.eye(dim) * float(length))

    @classmethod
    def from_lammps(cls, dim: int, lengths, tilts=(0.0, 0.0, 0.0)) -> "Box":
        """From LAMMPS side lengths (lx, ly[, lz]) and tilt lengths (xy, xz, yz)."""
        xy, xz, yz = tilts
        if dim == 2:
            return cls([[lengths[0], xy], [0.0, lengths[1]]])
        return cls([[lengths[0], xy, xz], [0.0, lengths[1], yz], [0.0, 0.0, lengths[2]]])

    # properties -------------------------------------------------------------------
    @property
    def dim(self) -> int:
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
    def is_triclinic(self) -> bool:
        return bool(np.any(self.tilts))

    @property
    def volume(self) -> float:
        """Area in 2D, volume in 3D."""
        return float(np.prod(np.diag(self.h)))

    @property
    def shear_strain(self) -> float:
        """Lees-Edwards strain gamma = xy / ly (seed eq. 2.4)."""
        return float(self.h[0, 1] / self.h[1, 1])

    @property
    def widths(self) -> np.ndarray:
        """Perpendicular distances between opposite faces; a pair cutoff must stay
        below half the smallest one for the minimum image to be unique."""
        inv = np.linalg.inv(self.h)
        return 1.0 / np.linalg.norm(inv, axis=1)

    # transformations ----------------------------------------------------------------
    def scaled(self, factor: float) -> "Box":
        """Every cell vector multiplied by ``factor`` (isotropic compression < 1)."""
        return Box(self.h * float(factor))

    def with_shear_strain(self, gamma: float) -> "Box":
        """Same cell with the xy tilt set to ``gamma * ly``."""
        h = self.h.copy()
        h[0, 1] = gamma * h[1, 1]
        return Box(h)

    def to_fractional(self, positions: np.ndarray) -> np.ndarray:
        return np.linalg.solve(self.h, np.asarray(positions, float).T).T

    def to_cartesian(self, fractional: np.ndarray) -> np.ndarray:
        return np.asarray(fractional, float) @ self.h.T

    def wrap(self, positions: np.ndarray) -> np.ndarray:
        """Positions mapped into the primary cell [0, 1)^d in fractional coordinates."""
        s = self.to_fractional(positions)
        return self.to_cartesian(s - np.floor(s))

    def minimum_image(self, dr: np.ndarray) -> np.ndarray:
        """Shortest periodic image of separation vectors ``dr`` (..., d).

        Orthogonal cells: rounding. Tilted cells: rounds in fractional coordinates, then
        checks the 3^d neighbouring images, so it is exact in strongly tilted cells too.
        """
        dr = np.asarray(dr, float)
        if not self.is_triclinic:  # rounding is exact for orthogonal cells
            lengths = self.lengths
            return dr - lengths * np.round(dr / lengths)
        s = self.to_fractional(dr.reshape(-1, self.dim))
        base = self.to_cartesian(s - np.round(s))
        shifts = self.to_cartesian(np.array(list(product((-1, 0, 1), repeat=self.dim)), float))
        candidates = base[:, None, :] + shifts[None, :, :]
        best = np.argmin(np.einsum("nkd,nkd->nk", candidates, candidates), axis=1)
        return candidates[np.arange(len(base)), best].reshape(dr.shape)

    # external conventions -------------------------------------------------------------
    def to_lammps(self) -> dict:
        """Bounds for LAMMPS ``region prism`` / ``create_box`` with the origin at 0."""
        lx, ly = self.h[0, 0], self.h[1, 1]
        lz = self.h[2, 2] if self.dim == 3 else 1.0
        xy, xz, yz = self.tilts
        return dict(xlo=0.0, xhi=lx, ylo=0.0, yhi=ly, zlo=-0.5 * lz if self.dim == 2 else 0.0,
                    zhi=0.5 * lz if self.dim == 2 else lz, xy=xy, xz=xz, yz=yz)

    def to_freud(self):
        """A ``freud.box.Box`` (dimensionless tilts)."""
        import freud

        lx, ly = self.h[0, 0], self.h[1, 1]
        xy, xz, yz = self.tilts
        if self.dim == 2:
            return freud.box.Box(Lx=lx, Ly=ly, xy=xy / ly, is2D=True)
        lz = self.h[2, 2]
        return freud.box.Box(Lx=lx, Ly=ly, Lz=lz, xy=xy / ly, xz=xz / lz, yz=yz / lz)
