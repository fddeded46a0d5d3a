"""Dynamical matrix of disks and spheres (seed chapter section 3, eq. 2.27).

M_kl = d^2 V / d xi_k d xi_l with xi the particle positions (d per particle), V the total
potential energy, unit masses, fixed periodic box (any tilt). For a pair in contact with
separation r_ij = r_i - r_j, r = |r_ij|, n = r_ij / r, the d x d pair stiffness is

    K_ij = V''(r) n n^T + V'(r) / r (I - n n^T)

(the second term is the tension/stress term, negative for repulsive contacts), entering as
M_ii += K_ij, M_jj += K_ij, M_ij = M_ji = -K_ij. Units: eps / diameter^2.
Floaters are removed before the matrix is built: they and all their contacts are dropped,
the same network that ``Contacts`` counts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..packing import Packing
from ..pairs import overlapping_pairs
from .contacts import Contacts, ContactsResult, remove_floaters


def pair_stiffness(potential, dr: np.ndarray, r: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """(P, d, d) pair stiffness blocks K_ij for separations ``dr`` (P, d)."""
    n = dr / r[:, None]
    nn = n[:, :, None] * n[:, None, :]
    eye = np.eye(dr.shape[1])[None]
    second = potential.d2v_dr2(r, sigma)[:, None, None]
    tension = (potential.dv_dr(r, sigma) / r)[:, None, None]
    return second * nn + tension * (eye - nn)


def hessian(packing: Packing) -> sp.csr_matrix:
    """Sparse (dN, dN) Hessian of the total energy over every overlapping pair.
    Row/column k * d + a is coordinate a of particle k (packing order). Disks and spheres."""
    if packing.shape.kind != "sphere":
        raise ValueError(f"the dynamical matrix of {packing.shape.name(packing.dim)} particles needs rotational "
                         "coordinates, which jamflow.analysis.hessian does not have yet; it covers disks and spheres")
    if packing.box.walls or packing.fixed is not None or packing.gravity > 0:
        raise ValueError("the dynamical matrix has no wall, gravity or fixed-particle terms yet; it covers periodic "
                         "boxes (use jamflow.analysis.contacts for the contact count of walled packings)")
    i, j, dr, r, sigma = overlapping_pairs(packing)
    d, n = packing.dim, packing.n
    k = pair_stiffness(packing.potential, dr, r, sigma)
    a, b = np.meshgrid(np.arange(d), np.arange(d), indexing="ij")
    rows, cols, vals = [], [], []
    for p, q, sign in ((i, i, 1.0), (j, j, 1.0), (i, j, -1.0), (j, i, -1.0)):
        rows.append((p[:, None, None] * d + a).ravel())
        cols.append((q[:, None, None] * d + b).ravel())
        vals.append(sign * k.ravel())
    shape = (d * n, d * n)
    if not len(i):
        return sp.csr_matrix(shape)
    return sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape).tocsr()


@dataclass(frozen=True)
class DynamicalMatrixResult:
    """Dynamical matrix over the non-floaters (unit masses: equal to the Hessian)."""

    matrix: sp.csr_matrix  # (d N', d N'), eps / diameter^2
    particles: np.ndarray  # (N',) indices of the rows' particles in the original packing
    packing: Packing  # the packing the matrix belongs to (floaters removed)
    contacts: ContactsResult | None  # None when floaters were kept
    n_total: int  # N, particles in the original packing

    @property
    def dim(self) -> int:
        return self.packing.dim

    @property
    def n_dof(self) -> int:
        return self.matrix.shape[0]

    def translations(self) -> np.ndarray:
        """(d N', d) orthonormal uniform translations: the trivial zero modes."""
        n = len(self.particles)
        return np.kron(np.ones((n, 1)), np.eye(self.dim)) / np.sqrt(n)


class DynamicalMatrix:
    """Sparse dynamical matrix; ``remove_floaters`` drops floaters first (default).
    ``contacts`` configures the floater search (a ``Contacts`` instance)."""

    def __init__(self, remove_floaters: bool = True, contacts: Contacts | None = None):
        self.remove_floaters = bool(remove_floaters)
        self.contacts = contacts or Contacts()

    def compute(self, packing: Packing) -> DynamicalMatrixResult:
        if not self.remove_floaters:
            return DynamicalMatrixResult(hessian(packing), np.arange(packing.n), packing, None, packing.n)
        found = self.contacts.compute(packing)
        kept = remove_floaters(packing, found)
        return DynamicalMatrixResult(hessian(kept), found.kept, kept, found, packing.n)
