"""Periodic simulation cell: the h-matrix, shear tilt, and the LAMMPS convention.

The cell is an upper-triangular matrix ``h`` whose *columns* are the cell vectors
(units: small-particle diameter). In 3D::

    h = [[lx, xy, xz],
         [ 0, ly, yz],
         [ 0,  0, lz]]

which is exactly LAMMPS's restricted triclinic cell (``xy``, ``xz``, ``yz`` are tilt
*lengths*). The shear strain of Lees-Edwards boundaries is ``gamma = xy / ly``
(seed eq. 2.4). freud and HOOMD use dimensionless tilts ``xy / ly``; see ``to_freud``.

Walls (seed section 2.3): an axis that is not ``periodic`` is bounded by flat walls at its
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

    h: np.ndarray
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
        return np.linalg.solve(self.h, np.asarray(positions, float).T).T

    def to_cartesian(self, fractional: np.ndarray) -> np.ndarray:
        return np.asarray(fractional, float) @ self.h.T

    def wrap(self, positions: np.ndarray) -> np.ndarray:
        """Positions mapped into the primary cell [0, 1)^d in fractional coordinates along
        the periodic axes (walled axes are left as they are)."""
        s = self.to_fractional(positions)
        return self.to_cartesian(s - np.floor(s) * self._periodic_mask)

    @property
    def _periodic_mask(self) -> np.ndarray:
        return np.array(self.periodic, float)

    def minimum_image(self, dr: np.ndarray) -> np.ndarray:
        """Shortest periodic image of separation vectors ``dr`` (..., d).

        Orthogonal cells: rounding. Tilted cells: rounds in fractional coordinates, then
        checks the 3^d neighbouring images, so it is exact in strongly tilted cells too.
        Walled axes have no images: separations along them are direct.
        """
        dr = np.asarray(dr, float)
        mask = self._periodic_mask
        if not self.is_triclinic:  # rounding is exact for orthogonal cells
            lengths = self.lengths
            return dr - lengths * np.round(dr / lengths) * mask
        s = self.to_fractional(dr.reshape(-1, self.dim))
        base = self.to_cartesian(s - np.round(s) * mask)
        images = product(*[(-1, 0, 1) if p else (0,) for p in self.periodic])
        shifts = self.to_cartesian(np.array(list(images), float))
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
            box = freud.box.Box(Lx=lx, Ly=ly, xy=xy / ly, is2D=True)
        else:
            lz = self.h[2, 2]
            box = freud.box.Box(Lx=lx, Ly=ly, Lz=lz, xy=xy / ly, xz=xz / lz, yz=yz / lz)
        box.periodic = list(self.periodic) + [True] * (3 - self.dim)
        return box
