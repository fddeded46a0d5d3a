"""Elastic moduli from the Hessian: the affine response minus the non-affine relaxation.

The second implementation of ``jamflow moduli`` (the strain sweeps of ``analysis.sweeps`` are the
first). For a homogeneous strain x -> F(a) x of amplitude a (``analysis.strains``: shear or bulk,
velocity L = dF/da) at a force-balanced state, the relaxed energy curvature is

    U''(a) = A - Xi^T H^+ Xi,   A = sum_contacts (L r_ij)^T K_ij (L r_ij),   Xi = d^2 U / d xi da

(Maloney & Lemaitre, PRE 74, 016118 (2006); Lutsko, J. Appl. Phys. 65, 2991 (1989)): H is the
dynamical matrix (``analysis.hessian``, floaters removed), Xi the force response to the affine
strain -- each contact's block of H applied to the displacement L r_ij of its first particle --
and H^+ the pseudo-inverse on the non-trivial subspace: the eigenvectors with |e| above
``zero_tol`` times the largest eigenvalue (the d uniform translations, exact null vectors that Xi
does not excite, are left out). The relaxation is the non-affine displacement u = -H^+ Xi.
``Strain.modulus_from_curvature`` turns U'' into G or B. Units: eps / diameter^d.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ..engine.reference import energy_forces_pressure
from ..packing import Packing
from ..pairs import overlapping_pairs
from .contacts import Contacts, remove_floaters
from .hessian import hessian, pair_stiffness
from .strains import BULK, SHEAR, Strain

ZERO_TOL = 1e-10  # |e| <= ZERO_TOL * max e: a zero mode (round-off of e is ~1e-16 max e)


@dataclass(frozen=True)
class PairTerms:
    """Each contact's Hessian block in its local coordinates [x_i (d), x_j (d)] and where those
    coordinates sit in the dynamical matrix."""

    rows: np.ndarray  # (P, L) global rows of each pair's local coordinates
    blocks: np.ndarray  # (P, L, L) eps / diameter^2
    separations: np.ndarray  # (P, d) centre separations r_i - r_j, diameters
    size: int  # rows of the dynamical matrix


def pair_terms(packing: Packing) -> PairTerms:
    """Contact blocks of disks and spheres, K_ij = V'' n n^T + V'/r (I - n n^T) (``hessian``)."""
    if packing.shape.kind != "sphere":
        raise ValueError(f"the Hessian moduli of {packing.shape.name(packing.dim)} particles need the dynamical matrix "
                         "with rotational coordinates, which jamflow.analysis.hessian does not have yet; the strain "
                         "sweeps measure them (jamflow moduli --no-hessian)")
    i, j, dr, r, sigma = overlapping_pairs(packing)
    d = packing.dim
    k = pair_stiffness(packing.potential, dr, r, sigma)
    blocks = np.concatenate([np.concatenate([k, -k], 2), np.concatenate([-k, k], 2)], 1)
    rows = np.concatenate([i[:, None] * d + np.arange(d), j[:, None] * d + np.arange(d)], axis=1)
    return PairTerms(rows, blocks, dr, packing.n * d)


def affine_terms(terms: PairTerms, strain: Strain) -> tuple[float, np.ndarray]:
    """(A, Xi): the affine curvature and the force response to the strain's velocity L."""
    d = terms.separations.shape[1]
    v = terms.separations @ strain.velocity(d).T  # (P, d): L r_ij, the displacement of particle i
    response = np.einsum("pab,pb->pa", terms.blocks[:, :, :d], v)  # (P, L)
    xi = np.bincount(terms.rows.ravel(), weights=response.ravel(), minlength=terms.size)
    return float(np.einsum("pa,pa->", v, response[:, :d])), xi


@dataclass(frozen=True)
class HessianModuliResult:
    """G and B from the Hessian, with their affine parts and what the spectrum looked like."""

    G: float  # eps / diameter^d
    B: float
    G_affine: float  # without the non-affine relaxation (upper bounds)
    B_affine: float
    pressure_tensor: np.ndarray  # (d, d) of the floater-free packing (numpy reference)
    n_kept: int  # particles after floater removal
    n_contacts: int
    n_extra_zero: int  # zero modes beyond the d translations
    n_negative: int  # eigenvalues below -zero_tol max e
    lowest_eigenvalue: float  # smallest non-trivial eigenvalue
    zero_tol: float

    def modulus(self, strain: Strain) -> float:
        return self.G if strain.modulus == "G" else self.B

    def affine(self, strain: Strain) -> float:
        return self.G_affine if strain.modulus == "G" else self.B_affine


class HessianModuli:
    """``zero_tol``: relative threshold of the pseudo-inverse (``ZERO_TOL``); ``contacts``: the
    floater search (a ``Contacts``)."""

    def __init__(self, zero_tol: float = ZERO_TOL, contacts: Contacts | None = None):
        if not (np.isfinite(zero_tol) and 0 < zero_tol < 1):
            raise ValueError(f"zero_tol must lie in (0, 1), got {zero_tol!r}")
        self.zero_tol = float(zero_tol)
        self.contacts = contacts or Contacts()

    def compute(self, packing: Packing) -> HessianModuliResult:
        if packing.box.walls or packing.fixed is not None or packing.gravity > 0:
            raise ValueError("the moduli are measured in periodic boxes; this packing has walls, fixed particles "
                             "or gravity")
        kept = remove_floaters(packing, self.contacts.compute(packing))
        terms = pair_terms(kept)
        ptensor = energy_forces_pressure(kept).pressure_tensor
        evals, evecs = scipy.linalg.eigh(hessian(kept).toarray())
        tol = self.zero_tol * max(float(np.abs(evals).max()), np.finfo(float).tiny)
        live = np.abs(evals) > tol
        n_zero = int(np.sum(~live))
        values = {}
        for strain in (SHEAR, BULK):
            affine, xi = affine_terms(terms, strain)
            coeff = evecs.T @ xi
            _check_zero_modes(coeff, live, kept.dim, strain)
            relaxation = float(np.sum(coeff[live] ** 2 / evals[live]))
            values[strain.modulus] = (strain.modulus_from_curvature(affine - relaxation, kept.box.volume, ptensor),
                                      strain.modulus_from_curvature(affine, kept.box.volume, ptensor))
        lowest = evals[live & (evals > 0)]
        return HessianModuliResult(values["G"][0], values["B"][0], values["G"][1], values["B"][1], ptensor, kept.n,
                                   len(terms.rows), max(n_zero - kept.dim, 0), int(np.sum(evals < -tol)),
                                   float(lowest.min()) if lowest.size else float("nan"), self.zero_tol)


def _check_zero_modes(coeff, live, dim, strain) -> None:
    """Warn when the strain pushes along a zero mode beyond the translations: its linear
    response is unbounded and the pseudo-inverse leaves it out."""
    zero = np.abs(coeff[~live])
    scale = float(np.linalg.norm(coeff))
    if len(zero) > dim and scale > 0 and zero.max() > 1e-8 * scale:
        warnings.warn(f"the {strain.kind} strain excites a zero mode beyond the {dim} translations "
                      f"(|Xi . e| = {np.max(zero) / scale:.1e} |Xi|): its relaxation is not linear and the "
                      "Hessian modulus leaves it out", stacklevel=3)
