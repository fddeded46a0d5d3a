"""An independent check of ellipse/spheroid packings: energy, forces and torques from a brute-force
contact distance, sharing no code with the engines' solvers.

The contact distance is maximised directly from Perram & Wertheim's matrix definition
(chapter section 2.3.2), h(lambda) = lambda (1 - lambda) r_hat^T [(1 - lambda) A_i + lambda A_j]^-1
r_hat with A = (a/2)^2 u u^T + (b/2)^2 (I - u u^T) and sigma = (max h)^-1/2: on a dense grid of
lambda, then by golden-section search in the best cell (h is concave, so unimodal). Neither the
chapter's quartic/quintic nor the closed form of h is used. Derivatives of sigma come from
central differences of this sigma under small rotations of r_hat, u_i and u_j (sigma is smooth
in them), so forces and torques follow from the energy's definition:

    F_i = -V'(s) (r_hat / sigma - (r / sigma^2) grad_r sigma),  tau_i = V'(s) (r / sigma^2) dsigma/domega_i

with s = r / sigma and V the potential's law (``jamflow.model.potentials``). Accuracy: sigma to ~1e-15
relative (the golden section's last steps), its angular derivatives to ~1e-10; near jamming
(overlaps 1 - s ~ 1e-8) that makes V'(s), forces and torques good to ~1e-15 absolute (measured:
1.7e-15 against the engines for N = 24 at onset). Units: eps, diameter.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jamflow.model.packing import Packing
from jamflow.model.pairs import candidate_pairs, separations
from jamflow.model.shapes.rotations import generalized_torques

GRID = 401  # lambda grid points in (0, 1)
GOLDEN_STEPS = 80  # golden-section steps in the best two grid cells: 1/200 * 0.618^80 ~ 1e-19
ANGLE_STEP = 1e-5  # radians, central differences of sigma


def _shape_matrices(a, b, u):
    """(P, d, d) A = (a/2)^2 u u^T + (b/2)^2 (I - u u^T)."""
    d = u.shape[1]
    uu = np.einsum("pi,pj->pij", u, u)
    return (a**2 / 4)[:, None, None] * uu + (b**2 / 4)[:, None, None] * (np.eye(d)[None] - uu)


def _h(lam, A_i, A_j, r_hat):
    """h(lambda) from the matrix form for lam (P, G)."""
    lam4 = lam[..., None, None]
    m = (1 - lam4) * A_i[:, None] + lam4 * A_j[:, None]
    rr = np.broadcast_to(r_hat[:, None, :, None], m.shape[:-1] + (1,))
    x = np.linalg.solve(m, rr)[..., 0]
    return lam * (1 - lam) * np.einsum("pgk,pk->pg", x, r_hat)


def brute_contact_distance(a_i, b_i, a_j, b_j, r_hat, u_i, u_j) -> np.ndarray:
    """sigma_ij (P,) by direct maximisation of the matrix-form h(lambda) (full axis lengths a, b;
    unit vectors (P, d))."""
    A_i, A_j = _shape_matrices(a_i, b_i, u_i), _shape_matrices(a_j, b_j, u_j)
    grid = (np.arange(GRID) + 0.5) / GRID
    best = np.argmax(_h(np.broadcast_to(grid, (len(r_hat), GRID)), A_i, A_j, r_hat), axis=1)
    lo, hi = np.maximum(grid[best] - 1.0 / GRID, 1e-12), np.minimum(grid[best] + 1.0 / GRID, 1 - 1e-12)
    ratio = (np.sqrt(5) - 1) / 2
    c, d = hi - ratio * (hi - lo), lo + ratio * (hi - lo)
    hc, hd = _h(c[:, None], A_i, A_j, r_hat)[:, 0], _h(d[:, None], A_i, A_j, r_hat)[:, 0]
    for _ in range(GOLDEN_STEPS):
        left = hc > hd  # the maximum lies in [lo, d]: d becomes hi, c becomes d
        hi, lo = np.where(left, d, hi), np.where(left, lo, c)
        x_new = np.where(left, hi - ratio * (hi - lo), lo + ratio * (hi - lo))
        h_new = _h(x_new[:, None], A_i, A_j, r_hat)[:, 0]
        c, d, hc, hd = (np.where(left, x_new, d), np.where(left, c, x_new),
                        np.where(left, h_new, hd), np.where(left, hc, h_new))
    h_max = np.maximum(hc, hd)
    return 1.0 / np.sqrt(h_max)


def _sigma_half(a_i, b_i, a_j, b_j, r_hat, u_i, u_j):
    """sigma(1/2) from the matrix form: an upper bound on the contact distance."""
    h = _h(np.full((len(r_hat), 1), 0.5), _shape_matrices(a_i, b_i, u_i), _shape_matrices(a_j, b_j, u_j), r_hat)
    return 1.0 / np.sqrt(h[:, 0])


def _rotate(v, axis, angle):
    """v (P, d) turned by ``angle`` about world axis ``axis`` (0, 1, 2; 2 = z in 2D)."""
    d = v.shape[1]
    c, s = np.cos(angle), np.sin(angle)
    if d == 2:
        return np.column_stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]])
    e = np.zeros(3)
    e[axis] = 1.0
    return v * c + np.cross(e, v) * s + np.outer(v @ e, e) * (1 - c)


def _angular_derivatives(sigma_of, vecs, k, axes):
    """(P, len(axes)) dsigma / domega_a for turning vector ``k`` of (r_hat, u_i, u_j)."""
    out = []
    for axis in axes:
        plus, minus = list(vecs), list(vecs)
        plus[k], minus[k] = _rotate(vecs[k], axis, ANGLE_STEP), _rotate(vecs[k], axis, -ANGLE_STEP)
        out.append((sigma_of(plus) - sigma_of(minus)) / (2 * ANGLE_STEP))
    return np.column_stack(out)


@dataclass(frozen=True)
class IndependentCheck:
    """Energy, forces, torques and generalized torques of a packing by the brute-force sigma."""

    energy: float  #: total, eps
    forces: np.ndarray  #: (N, d), eps / diameter
    torques: np.ndarray  #: (N,) 2D, (N, 3) 3D, world frame
    generalized_torques: np.ndarray  #: (N, r) body frame tau_a / d_k on the rotational degrees of freedom
    contacts: tuple  #: (i, j) of the pairs with r < sigma

    @property
    def energy_per_particle(self) -> float:
        """V = energy / N, eps."""
        return self.energy / len(self.forces)

    def max_force(self, keep=None) -> float:
        """Largest force component (eps / diameter), of the particles ``keep`` (indices or mask) if given."""
        f = self.forces if keep is None else self.forces[keep]
        return float(np.abs(f).max()) if f.size else 0.0

    def max_generalized_torque(self, keep=None) -> float:
        """Largest generalized torque tau_a / d_k (eps / diameter), of the particles ``keep`` if given."""
        g = self.generalized_torques if keep is None else self.generalized_torques[keep]
        return float(np.abs(g).max()) if g.size else 0.0


def independent_check(packing: Packing) -> IndependentCheck:
    """Brute-force energy, forces and torques of a packing of ellipses or spheroids (any sizes;
    every contact-distance method is checked against the exact sigma it approximates only if it
    is 'exact': this is the exact model)."""
    if not packing.shape.elliptic:
        raise ValueError(f"independent_check is for ellipses/spheroids, not {packing.shape.name(packing.dim)} "
                         "particles")
    n, d = packing.n, packing.dim
    reach = packing.shape.reach(packing.diameters)
    i, j = candidate_pairs(packing, 2.0 * float(reach.max()))
    dr = separations(packing, i, j)
    r = np.linalg.norm(dr, axis=1)
    r_hat = dr / r[:, None]
    axes, u = packing.shape.axes(packing.diameters), packing.directors
    # sigma(1/2) >= sigma (any lambda bounds it): pairs at r >= sigma(1/2) cannot touch
    near = r < _sigma_half(axes[i, 0], axes[i, 1], axes[j, 0], axes[j, 1], r_hat, u[i], u[j])
    i, j, dr, r, r_hat = i[near], j[near], dr[near], r[near], r_hat[near]
    a_i, b_i, a_j, b_j = axes[i, 0], axes[i, 1], axes[j, 0], axes[j, 1]

    def sigma_of(vecs):
        return brute_contact_distance(a_i, b_i, a_j, b_j, *vecs)

    vecs = [r_hat, u[i], u[j]]
    sigma = sigma_of(vecs)
    inside = r < sigma
    i, j, r, sigma, r_hat = i[inside], j[inside], r[inside], sigma[inside], r_hat[inside]
    a_i, b_i, a_j, b_j = a_i[inside], b_i[inside], a_j[inside], b_j[inside]
    vecs = [r_hat, u[i], u[j]]
    pot = packing.potential
    v, dv = pot.energy_force(r / sigma, pot.params)
    axes_turned = [2] if d == 2 else [0, 1, 2]
    w_r, w_i, w_j = (_angular_derivatives(sigma_of, vecs, k, axes_turned) for k in range(3))
    if d == 2:
        grad_r = w_r[:, 0][:, None] * np.column_stack([-r_hat[:, 1], r_hat[:, 0]])
    else:
        grad_r = np.cross(w_r, r_hat)
    fpair = -dv[:, None] * (r_hat / sigma[:, None] - grad_r / sigma[:, None] ** 2)
    forces = np.zeros((n, d))
    np.add.at(forces, i, fpair)
    np.add.at(forces, j, -fpair)
    lever = (dv * r / sigma**2)[:, None]
    torques = np.zeros((n, len(axes_turned)))
    np.add.at(torques, i, lever * w_i)
    np.add.at(torques, j, lever * w_j)
    world = torques[:, 0] if d == 2 else torques
    general = generalized_torques(packing.orientations, world, d, packing.rotational_lengths,
                                  packing.shape.rotation_mask(d))
    return IndependentCheck(float(v.sum()), forces, world, general, (i, j))
