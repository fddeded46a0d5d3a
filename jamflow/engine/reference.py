"""All-pairs numpy reference for energy, forces and the pressure tensor.

Independent of LAMMPS and of the cell search in ``jamflow.pairs`` (it loops over every
pair with the minimum image), so it serves as the second implementation in tests.
Units: energy eps, force eps/diameter, pressure eps/diameter^d.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..packing import Packing
from ..pairs import all_pairs, contact_distances, separations


@dataclass(frozen=True)
class ReferenceResult:
    energy: float  # total potential energy, sum over distinct pairs
    forces: np.ndarray  # (N, d)
    pressure_tensor: np.ndarray  # (d, d), virial only (athermal): sum_pairs r_ij f_ij / volume

    @property
    def pressure(self) -> float:
        return float(np.trace(self.pressure_tensor) / len(self.pressure_tensor))


def energy_forces_pressure(packing: Packing) -> ReferenceResult:
    """Direct sum over all N(N-1)/2 pairs; use for N up to a few thousand."""
    i, j = all_pairs(packing.n)
    dr = separations(packing, i, j)
    r = np.linalg.norm(dr, axis=1)
    sigma = contact_distances(packing, i, j)
    pot = packing.potential
    energy = float(np.sum(pot.energy(r, sigma)))
    fpair = -pot.dv_dr(r, sigma)[:, None] * dr / r[:, None]  # force on i from j
    forces = np.zeros((packing.n, packing.dim))
    np.add.at(forces, i, fpair)
    np.add.at(forces, j, -fpair)
    virial = np.einsum("pa,pb->ab", dr, fpair)
    return ReferenceResult(energy, forces, virial / packing.box.volume)


def pair_damping_forces(packing: Packing, velocities: np.ndarray, damping: float) -> np.ndarray:
    """Dissipative forces of damped MD, seed eq. 2.3: -b [(v_i - v_j) . rhat_ij] rhat_ij on i
    (and the opposite on j) for every pair in contact, r_ij < sigma_ij; (N, d), eps/diameter
    for b in sqrt(m eps)/diameter and velocities in diameter/time. LAMMPS: fix jamflow/damping."""
    i, j = all_pairs(packing.n)
    dr = separations(packing, i, j)
    rsq = np.einsum("pa,pa->p", dr, dr)
    touching = rsq < contact_distances(packing, i, j) ** 2
    i, j, dr, rsq = i[touching], j[touching], dr[touching], rsq[touching]
    vn = np.einsum("pa,pa->p", velocities[i] - velocities[j], dr)
    fpair = -damping * (vn / rsq)[:, None] * dr
    forces = np.zeros((packing.n, packing.dim))
    np.add.at(forces, i, fpair)
    np.add.at(forces, j, -fpair)
    return forces
