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
``Strain.modulus_from_curvature`` turns U'' into G or B. Every shape: for particles that turn, H
has the rotational coordinates d_k theta of ``hessian.Coordinates``, the affine strain moves the
centres and carries the orientations unturned (as the engines' ``set_box`` does), and the rows of
Xi on the rotations are the torque response. The pressure tensor comes from the same pair terms.
The formula holds at force and torque balance (the term L^T grad U it drops is minus L^T times
the net force on each particle). Units: eps / diameter^d.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from jamflow.model.packing import Packing
from jamflow.model.pairs import overlapping_pairs, overlapping_sites
from jamflow.mechanics.hessian import (Coordinates, _local_index, _sphere_derivatives, energy_second_derivatives,
                                       pair_terms)
from jamflow.mechanics.dynamical_matrix import DynamicalMatrix
from jamflow.mechanics.strains import BULK, SHEAR, Strain

ZERO_TOL = 1e-10  # |e| <= ZERO_TOL * max e: a zero mode (round-off of e is ~1e-16 max e)


@dataclass(frozen=True)
class StrainTerms:
    """Each contact's energy derivatives in its local coordinates [x_i (d), x_j (d), rot_i, rot_j]
    (``hessian.pair_terms``), where those coordinates sit in the dynamical matrix, and the
    separation of the two particles' centres."""

    rows: np.ndarray  #: (P, L) global rows of each pair's local coordinates
    gradient: np.ndarray  #: (P, L) eps / diameter
    blocks: np.ndarray  #: (P, L, L) eps / diameter^2
    separations: np.ndarray  #: (P, d) centre separations r_i - r_j, diameters
    size: int  #: rows of the dynamical matrix

    @classmethod
    def of(cls, packing: Packing) -> "StrainTerms":
        """The terms of every contact of ``packing`` (``pair_terms``), indexed into its coordinates."""
        terms = pair_terms(packing)
        coords = Coordinates.of(packing)
        return cls(_local_index(coords, terms.i, terms.j), terms.gradient, terms.hessian,
                   centre_separations(packing), coords.size)

    def pressure_tensor(self, volume: float) -> np.ndarray:
        """P_ab = -V^-1 sum r_a dV/dr_b (chapter eq. 2.34, the virial with centre separations)."""
        d = self.separations.shape[1]
        return -np.einsum("pa,pb->ab", self.separations, self.gradient[:, :d]) / volume


def centre_separations(packing: Packing) -> np.ndarray:
    """(P, d) r_i - r_j between the centres of every contact of ``hessian.pair_terms`` (same
    order; for rigid bodies one row per overlapping site pair, the image the sites touch in)."""
    if not packing.shape.made_of_sites:
        return overlapping_pairs(packing)[2]
    _, _, s, t, dr, _, _ = overlapping_sites(packing)
    shape, d = packing.shape, packing.dim
    world = shape.world_sites(packing.positions, packing.orientations, packing.diameters).reshape(-1, d)
    lever = world - np.repeat(packing.positions, shape.n_sites, axis=0)
    return dr - lever[s] + lever[t]


def affine_terms(terms: StrainTerms, strain: Strain) -> tuple[float, np.ndarray]:
    """(A, Xi): the affine curvature and the force response to the strain's velocity L: each
    contact's block applied to the displacement L r_ij of its first particle's centre
    (orientations are carried along unturned)."""
    d = terms.separations.shape[1]
    v = terms.separations @ strain.velocity(d).T  # (P, d)
    response = np.einsum("pab,pb->pa", terms.blocks[:, :, :d], v)  # (P, L)
    xi = np.bincount(terms.rows.ravel(), weights=response.ravel(), minlength=terms.size)
    return float(np.einsum("pa,pa->", v, response[:, :d])), xi


@dataclass(frozen=True)
class HessianModuliResult:
    """G and B from the Hessian, with their affine parts and what the spectrum looked like."""

    G: float  #: shear modulus, eps / diameter^d
    B: float  #: bulk modulus, eps / diameter^d
    G_affine: float  #: without the non-affine relaxation (upper bounds)
    B_affine: float  #: without the non-affine relaxation
    pressure_tensor: np.ndarray  #: (d, d) of the floater-free packing, from the same pair terms
    n_kept: int  #: particles after floater removal
    n_contacts: int  #: contacts among the kept particles
    n_extra_zero: int  #: zero modes beyond the d translations
    n_negative: int  #: eigenvalues below -zero_tol max e
    lowest_eigenvalue: float  #: smallest non-trivial eigenvalue, eps / diameter^2
    zero_tol: float  #: the relative zero-mode threshold used

    def __repr__(self) -> str:
        """One line: G, B (and affine parts), kept particles, contacts, extra zero and negative modes."""
        return (f"HessianModuliResult(G={self.G:.6e}, B={self.B:.6e}, G_affine={self.G_affine:.4e}, "
                f"B_affine={self.B_affine:.4e}, kept={self.n_kept}, N_c={self.n_contacts}, "
                f"n_extra_zero={self.n_extra_zero}, n_negative={self.n_negative})")

    def modulus(self, strain: Strain) -> float:
        """G for ``SHEAR``, B for ``BULK``."""
        return self.G if strain.modulus == "G" else self.B

    def affine(self, strain: Strain) -> float:
        """G_affine for ``SHEAR``, B_affine for ``BULK``."""
        return self.G_affine if strain.modulus == "G" else self.B_affine


class HessianModuli:
    """``zero_tol``: relative threshold of the pseudo-inverse (``ZERO_TOL``); ``contacts``: the
    floater search (a ``Contacts``; default that of ``DynamicalMatrix``).

    Parameters
    ----------
    zero_tol : float, default 1e-10
        Eigenvalues with |e| <= zero_tol max e are zero modes, left out of the pseudo-inverse (0 < zero_tol < 1).
    contacts : Contacts, optional
        The floater search.

    Raises
    ------
    ValueError
        ``zero_tol`` outside (0, 1).
    """

    def __init__(self, zero_tol: float = ZERO_TOL, contacts=None):
        if not (np.isfinite(zero_tol) and 0 < zero_tol < 1):
            raise ValueError(f"zero_tol must lie in (0, 1), got {zero_tol!r}")
        self.zero_tol = float(zero_tol)
        self.matrix = DynamicalMatrix(contacts=contacts)

    def compute(self, packing: Packing) -> HessianModuliResult:
        """G and B of ``packing`` (floaters removed): the affine curvature minus Xi^T H^+ Xi.

        Parameters
        ----------
        packing : jamflow.Packing
            A packing in a periodic box, without walls, gravity or fixed particles.

        Returns
        -------
        HessianModuliResult
            G and B (eps / diameter^d), their affine parts and the spectrum's counts.
        """
        dyn = self.matrix.compute(packing)  # refuses walls, gravity and fixed particles
        kept = dyn.packing
        terms = StrainTerms.of(kept)
        ptensor = terms.pressure_tensor(kept.box.volume)
        evals, evecs = scipy.linalg.eigh(dyn.matrix.toarray())
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


@dataclass(frozen=True)
class ContactModuli:
    """G and B of disks/spheres by the Hessian route over a contact network the caller found."""

    G: float  #: shear modulus, eps / diameter^d
    B: float  #: bulk modulus, eps / diameter^d
    G_affine: float  #: without the non-affine relaxation
    B_affine: float  #: without the non-affine relaxation
    pressure_tensor: np.ndarray  #: (d, d) from the same contacts
    n_kept: int  #: particles kept (non-floaters)
    n_contacts: int  #: contacts given


def contact_moduli(packing: Packing, i, j, dr, sigma, overlap, kept) -> ContactModuli:
    """The formula of ``HessianModuli`` (A - Xi^T H^+ Xi) for disks/spheres with the spring law
    (V = eps/alpha (1 - s)^alpha) on given contacts: pairs i, j among the ``kept`` particles (N,)
    bool (floaters removed), separations dr, contact distances sigma and overlaps sigma - r, which
    may be known more precisely than sigma - |dr| (the double-double refinement:
    ``protocols.refine.RefineResult.moduli``; at p ~ 1e-14 an overlap ~1e-14 is a few ulps of a
    coordinate, and s = r / sigma itself keeps only 2 of its digits, so V'(s) is evaluated from
    delta = overlap / sigma: V' = -eps delta^(alpha-1), V'' = eps (alpha-1) delta^(alpha-2)). The
    stiffness term uses the directions dr / |dr|, the stress term V'; H^+ Xi is a sparse solve with
    one kept particle pinned (the d translations, which Xi does not excite). A network that is not
    rigid (a singular H) raises RuntimeError."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    pot = packing.potential
    if not math.isfinite(getattr(pot, "alpha", math.nan)):
        raise ValueError(f"contact_moduli is written for the spring law, not {pot.spec!r}")
    i, j = np.asarray(i), np.asarray(j)
    dr, sigma = np.asarray(dr, float), np.asarray(sigma, float)
    delta = np.asarray(overlap, float) / sigma
    ds, d2s = _sphere_derivatives(dr, sigma * (1.0 - delta), sigma)
    v1, blocks = energy_second_derivatives(pot, None, ds, d2s, delta)
    coords = Coordinates.of(packing)
    if coords.n_rot:
        raise ValueError("contact_moduli is written for disks and spheres")
    terms = StrainTerms(_local_index(coords, i, j), v1[:, None] * ds, blocks, dr, coords.size)
    volume = packing.box.volume
    ptensor = terms.pressure_tensor(volume)
    shape = (coords.size, coords.size)
    rows = np.broadcast_to(terms.rows[:, :, None], blocks.shape).ravel()
    cols = np.broadcast_to(terms.rows[:, None, :], blocks.shape).ravel()
    h = sp.coo_matrix((blocks.ravel(), (rows, cols)), shape).tocsc()
    d = packing.dim
    live = np.flatnonzero(np.asarray(kept, bool))
    free = (live[1:, None] * d + np.arange(d)).ravel()
    try:
        lu = spla.splu(h[free][:, free].tocsc())
    except RuntimeError as err:
        raise RuntimeError(f"the contact network ({len(i)} contacts) is not rigid: {err}") from None
    values = {}
    for strain in (SHEAR, BULK):
        affine, xi = affine_terms(terms, strain)
        relaxation = float(xi[free] @ lu.solve(xi[free]))
        values[strain.modulus] = (strain.modulus_from_curvature(affine - relaxation, volume, ptensor),
                                  strain.modulus_from_curvature(affine, volume, ptensor))
    return ContactModuli(values["G"][0], values["B"][0], values["G"][1], values["B"][1], ptensor, len(live), len(i))
