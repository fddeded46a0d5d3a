"""All-pairs numpy reference: energy, forces, torques and the pressure tensor of every shape.

Independent of the engines and, by default (``pairs="all"``), of the cell search in
``jamflow.model.pairs``: it loops over every pair with the minimum image, so it serves as the second
implementation in tests. ``pairs="near"`` takes the candidate pairs of the float64 cell search
instead (the same formulas, for large packings: the packing checks use it). It uses the
potential's own law (``jamflow.model.potentials``) and, for ellipsoids, the numpy contact distance
and its gradient (``jamflow.model.shapes.contact_distance``).

For a pair energy V(s), s = r_ij / sigma_ij(r_hat, u_i, u_j): the force on i is
-V'(s) (r_hat / sigma - r grad_r sigma / sigma^2) (grad_r sigma = tangential gradient in r_hat
over r), the torque on i is V'(s) r / sigma^2 (u_i x dsigma/du_i); for rigid bodies each site
force acts at its site. Pressure tensor (chapter eq. 2.34) P_ab = V^-1 sum_pairs r_ij,a f_ij,b with
r_ij joining the particle centres. Walls and gravity (disks and spheres, ``jamflow.model.walls``):
the smooth walls' energy, forces and virial and the weight are added; fixed particles do not
interact with each other and their forces are reported as zero (they are held), while the
forces on them count in the loads on the wall faces. Units: energy eps, force eps/diameter,
torque eps, pressure eps/diameter^d.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jamflow.model.packing import Packing
from jamflow.model.pairs import (
    all_pairs,
    candidate_pairs,
    contact_distances,
    dd_pair_geometry,
    pair_geometry,
    separations,
    site_packing,
)
from jamflow.model.potentials import overlap_law_params, spring_of_overlap
from jamflow.model.walls import face_loads, gravity_terms, smooth_wall_terms


@dataclass(frozen=True)
class ReferenceResult:
    energy: float  #: total potential energy, sum over distinct pairs
    forces: np.ndarray  #: (N, d)
    pressure_tensor: np.ndarray  #: (d, d), virial only (athermal)
    torques: np.ndarray | None = None  #: (N,) in 2D, (N, 3) in 3D, world frame; None for spheres
    wall_forces: np.ndarray | None = None  #: (d, 2, d): force of the particles on each face (walled axes)
    contact_forces: np.ndarray | None = None  #: |f| of every overlapping pair (of sites, for rigid bodies)

    def __repr__(self) -> str:
        """One line: N, dim, energy, P, max|F|, which optional arrays are there."""
        n, d = self.forces.shape
        extra = "".join(f", {name}=yes" for name in ("torques", "wall_forces", "contact_forces")
                        if getattr(self, name) is not None)
        return (f"ReferenceResult(N={n}, dim={d}, energy={self.energy:.6e}, P={self.pressure:.4e}, "
                f"max_force={np.abs(self.forces).max(initial=0.0):.2e}{extra})")

    @property
    def pressure(self) -> float:
        """P = trace / d of the pressure tensor, eps / diameter^d."""
        return float(np.trace(self.pressure_tensor) / len(self.pressure_tensor))


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """z-component in 2D, the vector in 3D."""
    if a.shape[1] == 2:
        return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return np.cross(a, b)


def _rows(c: np.ndarray, x: np.ndarray) -> np.ndarray:
    """c_p x_p for scalars (2D torques) or vectors (3D)."""
    return c[:, None] * x if x.ndim == 2 else c * x


def _reduced(pot, r, sigma):
    """V and V'(s) at s = r / sigma, zero beyond contact."""
    s = r / sigma
    inside = s < 1.0
    v, dv = pot.energy_force(np.where(inside, s, 0.5), pot.params)
    return np.where(inside, v, 0.0), np.where(inside, dv, 0.0)


def _pairs(packing: Packing, near: bool):
    """Every pair i < j, or (near) the pairs the cell search finds within the largest contact distance."""
    if not near:
        return all_pairs(packing.n)
    return candidate_pairs(packing, 2.0 * float(packing.shape.reach(packing.diameters).max()))


def _spheres(packing: Packing, near: bool):
    if packing.extended is not None:
        return _dd_spheres(packing, near)
    i, j = _pairs(packing, near)
    if packing.fixed is not None:  # fixed particles do not interact with each other
        i, j = i[~(packing.fixed[i] & packing.fixed[j])], j[~(packing.fixed[i] & packing.fixed[j])]
    dr = separations(packing, i, j)
    r = np.linalg.norm(dr, axis=1)
    sigma = contact_distances(packing, i, j)
    v, dv = _reduced(packing.potential, r, sigma)
    fpair = (-dv / (sigma * r))[:, None] * dr  # force on i from j
    return i, j, dr, fpair, float(v.sum()), None


def _dd_spheres(packing: Packing, near: bool):
    """Spheres with double-double coordinates (``Packing.extended``; periodic, linear or any spring):
    the overlaps from hi + lo (``pairs.dd_pair_geometry``) and the law at the reduced overlap
    (``potentials.spring_of_overlap``), so that forces ~1e-14 keep their digits; the directions, the
    sums and the virial in float64 (relative round-off ~1e-16 of a contact force)."""
    params = overlap_law_params(packing.potential)
    i, j, dr, r, sigma, overlap = pair_geometry(packing) if near else dd_pair_geometry(packing, *all_pairs(packing.n), 0.0)
    v, dv = spring_of_overlap(overlap / sigma, params)
    fpair = (-dv / (sigma * r))[:, None] * dr
    return i, j, dr, fpair, float(v.sum()), None


def _ellipsoids(packing: Packing, near: bool):
    from jamflow.model.shapes.contact_distance import contact_distance_gradient

    i, j = _pairs(packing, near)
    dr = separations(packing, i, j)
    r = np.linalg.norm(dr, axis=1)
    r_hat = dr / r[:, None]
    axes, u = packing.shape.axes(packing.diameters), packing.directors
    sigma, g_r, g_i, g_j = contact_distance_gradient(axes[i, 0], axes[i, 1], axes[j, 0], axes[j, 1], r_hat, u[i], u[j],
                                                     method=packing.shape.contact)
    v, dv = _reduced(packing.potential, r, sigma)
    fpair = -dv[:, None] * (r_hat / sigma[:, None] - g_r / sigma[:, None] ** 2)
    lever = dv * r / sigma**2
    torques = np.zeros((packing.n, 3) if packing.dim == 3 else packing.n)
    np.add.at(torques, i, _rows(lever, _cross(u[i], g_i)))
    np.add.at(torques, j, _rows(lever, _cross(u[j], g_j)))
    return i, j, dr, fpair, float(v.sum()), torques


def _bodies(packing: Packing, near: bool):
    shape, n, d = packing.shape, packing.n, packing.dim
    k = shape.n_sites
    world = shape.world_sites(packing.positions, packing.orientations, packing.diameters).reshape(-1, d)
    lever = world - np.repeat(packing.positions, k, axis=0)
    site_d = (packing.diameters[:, None] * shape.site_diameters[None, :]).ravel()
    body = np.repeat(np.arange(n), k)
    s, t = _pairs(site_packing(packing)[0], near) if near else all_pairs(n * k)
    s, t = s[body[s] != body[t]], t[body[s] != body[t]]
    dr = packing.box.minimum_image(world[s] - world[t])
    r = np.linalg.norm(dr, axis=1)
    sigma = 0.5 * (site_d[s] + site_d[t])
    v, dv = _reduced(packing.potential, r, sigma)
    fsite = (-dv / (sigma * r))[:, None] * dr  # force on site s from site t
    torques = np.zeros((n, 3) if d == 3 else n)
    np.add.at(torques, body[s], _cross(lever[s], fsite))
    np.add.at(torques, body[t], -_cross(lever[t], fsite))
    centre_dr = dr - lever[s] + lever[t]
    return body[s], body[t], centre_dr, fsite, float(v.sum()), torques


_SHAPES = {"sphere": _spheres, "ellipsoid": _ellipsoids, "rigid": _bodies}


def energy_forces_pressure(packing: Packing, pairs: str = "all") -> ReferenceResult:
    """Direct sum over all pairs (of sites, for rigid bodies; ``pairs="all"``, for N up to a few
    thousand) or over the pairs of the cell search (``pairs="near"``)."""
    if pairs not in ("all", "near"):
        raise ValueError(f"pairs must be 'all' or 'near', got {pairs!r}")
    bounded = bool(packing.box.walls) or packing.gravity > 0 or packing.fixed is not None
    if bounded and not packing.shape.bounded:
        raise ValueError(f"walls, gravity and fixed particles are written for disks and spheres, not "
                         f"{packing.shape.name(packing.dim)} particles")
    i, j, dr, fpair, energy, torques = _SHAPES[packing.shape.kind](packing, pairs == "near")
    forces = np.zeros((packing.n, packing.dim))
    np.add.at(forces, i, fpair)
    np.add.at(forces, j, -fpair)
    virial = np.einsum("pa,pb->ab", dr, fpair)
    magnitudes = np.linalg.norm(fpair, axis=1)
    magnitudes = magnitudes[magnitudes > 0]
    if not bounded:
        return ReferenceResult(energy, forces, virial / packing.box.volume, torques, contact_forces=magnitudes)
    e_wall, f_wall, w_wall, smooth = smooth_wall_terms(packing)
    e_grav, f_grav = gravity_terms(packing)
    loads = face_loads(packing, smooth, forces)
    forces = (forces + f_wall + f_grav) * packing.mobile[:, None]
    return ReferenceResult(energy + e_wall + e_grav, forces, (virial + w_wall) / packing.box.volume, torques, loads,
                           magnitudes)


def pair_damping_forces(packing: Packing, velocities: np.ndarray, damping: float) -> np.ndarray:
    """Dissipative forces of damped MD, chapter eq. 2.3: -b [(v_i - v_j) . rhat_ij] rhat_ij on i
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
