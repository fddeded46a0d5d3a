"""The ``Packing`` value object: positions, diameters, box, potential, metadata.

Immutable: every operation returns a new Packing. Units: lengths in small diameters,
energies in epsilon, masses 1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from .box import Box
from .potentials import Potential, Spring
from .sizes import SizeSpec

# Densest packings of equal disks (hexagonal) and spheres (FCC): pi/(2 sqrt 3), pi/(3 sqrt 2).
DENSEST_PHI = {2: math.pi / (2 * math.sqrt(3)), 3: math.pi / (3 * math.sqrt(2))}


def particle_volumes(diameters: np.ndarray, dim: int) -> np.ndarray:
    """Area (2D) or volume (3D) of disks/spheres with the given diameters."""
    d = np.asarray(diameters, float)
    return math.pi * d**2 / 4.0 if dim == 2 else math.pi * d**3 / 6.0


@dataclass(frozen=True)
class Packing:
    """N disks (2D) or spheres (3D) in a periodic box, with their pair potential."""

    positions: np.ndarray
    diameters: np.ndarray
    box: Box
    potential: Potential = field(default_factory=Spring)
    metadata: dict = field(default_factory=dict)

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
        if 2 * dia.max() >= self.box.widths.min():
            raise ValueError("box too small: the largest contact distance must stay below half "
                             "the box width for a unique minimum image; use more particles")
        pos.setflags(write=False)
        dia.setflags(write=False)
        object.__setattr__(self, "positions", pos)
        object.__setattr__(self, "diameters", dia)

    @property
    def n(self) -> int:
        return len(self.diameters)

    @property
    def dim(self) -> int:
        return self.box.dim

    @property
    def phi(self) -> float:
        """Packing fraction: particle volume over box volume."""
        return float(particle_volumes(self.diameters, self.dim).sum() / self.box.volume)

    def species(self) -> tuple[np.ndarray, np.ndarray]:
        """(distinct diameters, type index 0.. of each particle)."""
        values, index = np.unique(self.diameters, return_inverse=True)
        return values, index

    def with_positions(self, positions, box: Box | None = None, **metadata) -> "Packing":
        return replace(self, positions=positions, box=box or self.box,
                       metadata={**self.metadata, **metadata})

    def scaled_to_phi(self, phi: float) -> "Packing":
        """Affine rescaling of box and positions to packing fraction ``phi``."""
        factor = (self.phi / phi) ** (1.0 / self.dim)
        return self.with_positions(self.positions * factor, self.box.scaled(factor))


def random_packing(n: int, dim: int, sizes: SizeSpec, phi: float, seed: int,
                   potential: Potential | None = None) -> Packing:
    """Uniformly random positions in a square/cubic box at packing fraction ``phi``
    (seed step 1). Diameters are drawn first, then positions, from one generator."""
    rng = np.random.default_rng(seed)
    diameters = sizes.draw(n, rng)
    length = (particle_volumes(diameters, dim).sum() / phi) ** (1.0 / dim)
    box = Box.cube(length, dim)
    positions = rng.random((n, dim)) * length
    return Packing(positions, diameters, box, potential or Spring(),
                   metadata={"seed": seed, "sizes": sizes.spec})
