"""Dynamical matrix of every shape (chapter section 3, eq. 2.27).

M_kl = d^2 V / d xi_k d xi_l, V the total potential energy, unit masses, fixed periodic box
(any tilt). Coordinates xi (``Coordinates``): first the centres (d per particle, particle
after particle), then, for shapes that turn, the rotations d_k theta_a about each body axis a
that is a degree of freedom (``Shape.rotation_mask``; d_k = ``Packing.rotational_lengths``,
sqrt(a^2 + b^2)/4 for ellipses, the radius of gyration of rigid bodies), so M is
d_f N' x d_f N'. Units: eps / diameter^2 (d_k theta is a length).

Rotations: particle i turns about its centre by the rotation vector phi_i = sum_a theta_ia n_ia,
n_ia = R_i e_a its body axis a at the current orientation, R_i -> exp(phi_i x) R_i (the
exponential map about axes fixed in space; equivalently R_i exp(theta_i x) in the body frame,
the step the compiled FIRE takes). -dV/dxi is then tau_a / d_k, the generalized torque FIRE
relaxes. M is symmetric by construction, and it is the symmetric part of the Jacobian of the
generalized forces; that Jacobian's antisymmetric part, (1/2) eps_abc tau_c / (d_a d_b) between
two rotations of one particle, vanishes at torque balance. Away from balance the rotational
second derivatives depend on how rotations are parametrized (turning about one axis after the
other changes the mixed entries by +-tau_c / 2), so the spectrum is the physical one only at a
force- and torque-balanced state. Translational invariance holds everywhere: M T = 0.

Pair terms: every contact's energy is V(s), s = r / sigma, so each shape provides s and its first
and second derivatives in the pair's coordinates (``reduced_distances``) and the law is applied
once (``pair_terms``: V' ds and V'' ds ds^T + V' d2s), each block entering the rows of the two
particles it couples:
- disks/spheres: ds = (n, -n) / sigma, d2s = (I - n n) / (r sigma), i.e. the pair stiffness
  K_ij = V''(r) n n^T + V'(r)/r (I - n n^T) (tension term included; ``pair_stiffness``).
- rigid bodies: every overlapping site pair s (body I) - t (body J) with separation
  dr = r_s - r_t and lever arms l = r_site - R_body; d dr = dx_I - dx_J + phi_I x l_s
  - phi_J x l_t + 1/2 [phi_I x (phi_I x l_s) - phi_J x (phi_J x l_t)] to second order, so with
  B = d dr / d xi: ds = B^T n / sigma, d2s = (B^T (I - n n) B / r + n . d^2 dr) / sigma.
- ellipses/spheroids: s^2 = max_lambda F(lambda), F = lambda (1 - lambda) r^T G^-1 r,
  G = (1 - lambda) A_i + lambda A_j, A = (a/2)^2 u u^T + (b/2)^2 (I - u u^T) (Perram & Wertheim,
  J. Comput. Phys. 58, 409 (1985); the same sigma_ij as ``jamflow.model.shapes.contact_distance``).
  Derivatives of F are matrix-calculus closed forms; the maximum over lambda gives
  d^2 s^2 = F_qq - F_q,lambda F_lambda,q / F_lambda,lambda (implicit lambda*; lambda = 1/2 is
  fixed for the cleaver/gaussian methods).
Floaters are removed before the matrix is built: they and all their contacts are dropped,
the same network that ``Contacts`` counts.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from jamflow.model.packing import Packing
from jamflow.model.pairs import overlapping_pairs, overlapping_sites, pair_geometry
from jamflow.model.potentials import overlap_law_params, spring_curvature_of_overlap, spring_of_overlap
from jamflow.model.shapes.rotations import rotation_matrices


@dataclass(frozen=True)
class Coordinates:
    """The generalized coordinates xi of a packing (chapter section 3) and their layout:
    rows [k d + a] are centre coordinate a of particle k, rows [N d + k r + b] the rotation
    d_k theta about rotational axis b of particle k (r axes per particle)."""

    n: int  #: N, particles
    dim: int  #: d
    axes: tuple  #: body axes (0 = x, the director, ...) whose rotations are degrees of freedom
    lengths: np.ndarray  #: (N, r) d_k of those axes, diameters

    @classmethod
    def of(cls, packing: Packing) -> "Coordinates":
        """The coordinates of ``packing``: its rotational axes and their lengths d_k."""
        axes = tuple(int(a) for a in np.flatnonzero(packing.shape.rotation_mask(packing.dim)))
        return cls(packing.n, packing.dim, axes, packing.rotational_lengths[:, list(axes)])

    @property
    def n_rot(self) -> int:
        """r, rotational coordinates per particle."""
        return len(self.axes)

    @property
    def n_translational(self) -> int:
        """d N, the centre coordinates (the first rows)."""
        return self.n * self.dim

    @property
    def size(self) -> int:
        """d_f N, the matrix dimension."""
        return self.n * (self.dim + self.n_rot)

    def split(self, xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(N, d) centre displacements and (N, r) rotations d_k theta of a flat vector xi."""
        xi = np.asarray(xi, float)
        return xi[:self.n_translational].reshape(self.n, self.dim), xi[self.n_translational:].reshape(self.n, self.n_rot)

    def translations(self) -> np.ndarray:
        """(d_f N, d) orthonormal uniform translations: the trivial zero modes (no rotation)."""
        t = np.zeros((self.size, self.dim))
        t[:self.n_translational] = np.kron(np.ones((self.n, 1)), np.eye(self.dim)) / np.sqrt(self.n)
        return t

    def world_rotations(self, packing: Packing, rotations: np.ndarray) -> np.ndarray:
        """World rotation vectors phi of rotations d_k theta (N, r): (N,) angles in 2D, (N, 3)."""
        theta = np.asarray(rotations, float) / self.lengths
        if self.dim == 2:
            return theta[:, 0] if self.n_rot else np.zeros(self.n)
        return np.einsum("nbk,nb->nk", world_axes(packing, self.axes), theta) if self.n_rot else np.zeros((self.n, 3))


def world_axes(packing: Packing, axes) -> np.ndarray:
    """(N, r, 3) world directions of the body axes ``axes`` (2D: z for the one rotation)."""
    if packing.dim == 2:
        return np.broadcast_to(np.array([0.0, 0.0, 1.0]), (packing.n, len(axes), 3))
    rot = rotation_matrices(packing.orientations, 3)
    return np.transpose(rot[:, :, list(axes)], (0, 2, 1))


def pair_stiffness(potential, dr: np.ndarray, r: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """(P, d, d) pair stiffness blocks K_ij for separations ``dr`` (P, d)."""
    n = dr / r[:, None]
    nn = n[:, :, None] * n[:, None, :]
    eye = np.eye(dr.shape[1])[None]
    second = potential.d2v_dr2(r, sigma)[:, None, None]
    tension = (potential.dv_dr(r, sigma) / r)[:, None, None]
    return second * nn + tension * (eye - nn)


class ReducedDistances(NamedTuple):
    """s = r / sigma of every contact (overlapping pair; site pair for rigid bodies) and its
    first and second derivatives in the pair's local coordinates [x_i (d), x_j (d), rot_i (r),
    rot_j (r)] (``_local_index``); every pair energy is V(s), so these carry all the geometry."""

    i: np.ndarray  #: (P,) first particle
    j: np.ndarray  #: (P,) second particle
    s: np.ndarray  #: (P,) < 1
    ds: np.ndarray  #: (P, L)
    d2s: np.ndarray  #: (P, L, L)
    delta: np.ndarray | None = None  #: (P,) 1 - s = overlap / sigma from double-double overlaps (None: from s)


def reduced_distances(packing: Packing, skin: float = 0.0) -> ReducedDistances:
    """Contacts in the order of ``overlapping_pairs`` (``overlapping_sites`` for rigid bodies);
    with ``skin`` (diameters) also the pairs apart by less than it (s may then exceed 1)."""
    if packing.box.walls or packing.fixed is not None or packing.gravity > 0:
        raise ValueError("the dynamical matrix has no wall, gravity or fixed-particle terms yet; it covers periodic "
                         "boxes (use jamflow.mechanics.contacts for the contact count of walled packings)")
    return ReducedDistances(*_REDUCED[packing.shape.kind](packing, Coordinates.of(packing), skin))


class PairTerms(NamedTuple):
    """Derivatives of each contact's energy V(s) in its local coordinates."""

    i: np.ndarray  #: (P,) first particle
    j: np.ndarray  #: (P,) second particle
    gradient: np.ndarray  #: (P, L) dV/dxi: minus the generalized forces of the pair on i and j
    hessian: np.ndarray  #: (P, L, L)


def law_derivatives(potential, s: np.ndarray, delta: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """dV/ds and d2V/ds2 of the pair law at reduced distances s < 1; ``delta``: 1 - s known more
    precisely than from s (double-double overlaps / sigma, spring laws only: the law of
    ``potentials.spring_energy_force`` evaluated at s = 1 - delta without forming s; at an overlap
    ~1e-14 a float64 s keeps only ~2 of its digits)."""
    if delta is None:
        return potential.energy_force(s, potential.params)[1], potential.curvature(s, potential.params)
    params = overlap_law_params(potential)
    return spring_of_overlap(delta, params)[1], spring_curvature_of_overlap(delta, params)


def pair_terms(packing: Packing) -> PairTerms:
    """Gradient and Hessian blocks of every contact: V' ds and V'' ds ds^T + V' d2s."""
    red = reduced_distances(packing)
    v1, hess = energy_second_derivatives(packing.potential, red.s, red.ds, red.d2s, red.delta)
    return PairTerms(red.i, red.j, v1[:, None] * red.ds, hess)


def energy_second_derivatives(potential, s, ds, d2s, delta=None):
    """(V', blocks): dV/ds and the pair blocks V'' ds ds^T + V' d2s of each contact (``delta``:
    see ``law_derivatives``)."""
    v1, v2 = law_derivatives(potential, s, delta)
    return v1, pair_blocks(v1, v2, ds, d2s)


def pair_blocks(v1, v2, ds, d2s):
    """The Hessian blocks V'' ds ds^T + V' d2s of each contact from dV/ds and d2V/ds2."""
    return v2[:, None, None] * ds[:, :, None] * ds[:, None, :] + v1[:, None, None] * d2s


def hessian(packing: Packing) -> sp.csr_matrix:
    """Sparse (d_f N, d_f N) Hessian of the total energy over every overlapping pair, in the
    coordinates of ``Coordinates.of(packing)`` (for disks and spheres: row k d + a is
    coordinate a of particle k, packing order)."""
    terms = pair_terms(packing)
    return _assemble(Coordinates.of(packing), terms.i, terms.j, terms.hessian)


def distance_jacobian(packing: Packing, skin: float = 0.0) -> tuple[np.ndarray, sp.csr_matrix]:
    """(s, J): reduced distances s = r / sigma of the contacts (site pairs for rigid bodies) and
    of the pairs within ``skin`` of touching (``reduced_distances``), and the sparse Jacobian
    J = ds / dxi (P x d_f N) in the coordinates of ``Coordinates.of(packing)``."""
    red = reduced_distances(packing, skin)
    coords = Coordinates.of(packing)
    idx = _local_index(coords, red.i, red.j)
    rows = np.repeat(np.arange(len(red.s)), idx.shape[1])
    return red.s, sp.csr_matrix((red.ds.ravel(), (rows, idx.ravel())), shape=(len(red.s), coords.size))


def _local_index(coords: Coordinates, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """(P, 2d + 2r) global rows of a pair's local coordinates [x_i, x_j, rot_i, rot_j]."""
    d, r, n = coords.dim, coords.n_rot, coords.n
    parts = [i[:, None] * d + np.arange(d), j[:, None] * d + np.arange(d)]
    if r:
        parts += [n * d + i[:, None] * r + np.arange(r), n * d + j[:, None] * r + np.arange(r)]
    return np.concatenate(parts, axis=1)


def _assemble(coords: Coordinates, i, j, blocks) -> sp.csr_matrix:
    shape = (coords.size, coords.size)
    if not len(i):
        return sp.csr_matrix(shape)
    idx = _local_index(coords, i, j)
    rows = np.broadcast_to(idx[:, :, None], blocks.shape).ravel()
    cols = np.broadcast_to(idx[:, None, :], blocks.shape).ravel()
    return sp.coo_matrix((blocks.ravel(), (rows, cols)), shape).tocsr()


def _sphere_reduced(packing: Packing, coords: Coordinates, skin: float = 0.0):
    """s = r / sigma: ds = (n, -n) / sigma, d2s = (I - n n) / (r sigma) in [[+, -], [-, +]]
    (with V(s) this is K = V'' n n^T + V'/r (I - n n^T) per block, ``pair_stiffness``)."""
    i, j, dr, r, sigma, overlap = pair_geometry(packing, skin)
    return i, j, r / sigma, *_sphere_derivatives(dr, r, sigma), None if overlap is None else overlap / sigma


def _sphere_derivatives(dr, r, sigma):
    """ds (P, 2d) and d2s (P, 2d, 2d) of s = r / sigma for disk/sphere pairs."""
    n = dr / r[:, None]
    q = (np.eye(dr.shape[1])[None] - n[:, :, None] * n[:, None, :]) / (r * sigma)[:, None, None]
    ds = np.concatenate([n, -n], 1) / sigma[:, None]
    return ds, np.concatenate([np.concatenate([q, -q], 2), np.concatenate([-q, q], 2)], 1)


def sphere_contact_hessian(packing: Packing, i, j, dr, r, sigma, s) -> sp.csr_matrix:
    """The Hessian over contacts the caller found (disks/spheres: pairs i, j with separations dr,
    distances r, contact distances sigma and reduced distances s < 1). The double-double
    refinement (``jamflow.protocols.refine``) passes s = 1 - overlap / sigma from its double-double
    overlaps; as a float64, s keeps only a few digits of an overlap near 1e-14, so the V' (stress)
    term of this Jacobian is approximate there -- Newton's residual, evaluated in double-double,
    still decides convergence (``contact_moduli`` evaluates V' from the overlap itself)."""
    _, blocks = energy_second_derivatives(packing.potential, s, *_sphere_derivatives(dr, r, sigma))
    return _assemble(Coordinates.of(packing), i, j, blocks)


# --- shapes that turn: vectors are handled in 3D (2D vectors get z = 0) ---------------------

def _embed(v: np.ndarray) -> np.ndarray:
    """(..., d) -> (..., 3)."""
    return v if v.shape[-1] == 3 else np.concatenate([v, np.zeros(v.shape[:-1] + (3 - v.shape[-1],))], -1)


def turn_first(axes: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(P, r, 3): d v / d theta_b = n_b x v for body-fixed vectors v (P, 3), axes n (P, r, 3)."""
    return np.cross(axes, v[:, None, :])


def turn_second(axes: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(P, r, r, 3): d^2 v / d theta_b d theta_c of exp(phi x) v at phi = 0,
    1/2 [n_b x (n_c x v) + n_c x (n_b x v)] = 1/2 [n_c (n_b.v) + n_b (n_c.v)] - v (n_b.n_c)."""
    nv = np.einsum("pbk,pk->pb", axes, v)
    nn = np.einsum("pbk,pck->pbc", axes, axes)
    return (0.5 * (axes[:, None, :, :] * nv[:, :, None, None] + axes[:, :, None, :] * nv[:, None, :, None])
            - nn[..., None] * v[:, None, None, :])


@dataclass(frozen=True)
class _PairFrame:
    """Local coordinates of P pairs: [x_i (d), x_j (d), rot_i (r), rot_j (r)] (L of them),
    the world rotation axes of both particles and the scaling 1/d_k of each rotation."""

    d: int
    r: int
    axes_i: np.ndarray  #: (P, r, 3)
    axes_j: np.ndarray
    inv_i: np.ndarray  #: (P, r) 1 / d_k
    inv_j: np.ndarray

    @classmethod
    def of(cls, packing, coords, i, j):
        axes = world_axes(packing, coords.axes)
        inv = 1.0 / coords.lengths
        return cls(coords.dim, coords.n_rot, axes[i], axes[j], inv[i], inv[j])

    @property
    def size(self) -> int:
        return 2 * self.d + 2 * self.r

    @property
    def rot_i(self) -> slice:
        return slice(2 * self.d, 2 * self.d + self.r)

    @property
    def rot_j(self) -> slice:
        return slice(2 * self.d + self.r, self.size)

    def separation_jacobian(self, extra: int = 0) -> np.ndarray:
        """(P, L + extra, 3): d (r_i - r_j) / d xi of the centre separation."""
        out = np.zeros((len(self.inv_i), self.size + extra, 3))
        eye = np.eye(self.d, 3)
        out[:, :self.d], out[:, self.d:2 * self.d] = eye, -eye
        return out

    def body_vector(self, v_i, v_j, extra: int = 0):
        """First and second derivatives of body-fixed vectors v_i of i and v_j of j (P, 3):
        ((P, L + extra, 3) for each, (P, L + extra, L + extra, 3) for each)."""
        p, size = len(v_i), self.size + extra
        first_i, first_j = np.zeros((p, size, 3)), np.zeros((p, size, 3))
        second_i, second_j = np.zeros((p, size, size, 3)), np.zeros((p, size, size, 3))
        if self.r:
            ri, rj = self.rot_i, self.rot_j
            first_i[:, ri] = turn_first(self.axes_i, v_i) * self.inv_i[:, :, None]
            first_j[:, rj] = turn_first(self.axes_j, v_j) * self.inv_j[:, :, None]
            second_i[:, ri, ri] = turn_second(self.axes_i, v_i) * (self.inv_i[:, :, None] * self.inv_i[:, None, :])[..., None]
            second_j[:, rj, rj] = turn_second(self.axes_j, v_j) * (self.inv_j[:, :, None] * self.inv_j[:, None, :])[..., None]
        return first_i, first_j, second_i, second_j


def _rigid_reduced(packing: Packing, coords: Coordinates, skin: float = 0.0):
    """Site pairs: s = |dr| / sigma with dr(xi) from the lever arms (module docstring), so
    ds = B^T n / sigma and d2s = (B^T (I - n n) B / r + n . d2 dr) / sigma."""
    shape, d = packing.shape, packing.dim
    bi, bj, s, t, dr, r, sigma = overlapping_sites(packing, skin)
    world = shape.world_sites(packing.positions, packing.orientations, packing.diameters).reshape(-1, d)
    lever = _embed(world - np.repeat(packing.positions, shape.n_sites, axis=0))
    frame = _PairFrame.of(packing, coords, bi, bj)
    first_s, first_t, second_s, second_t = frame.body_vector(lever[s], lever[t])
    jac = frame.separation_jacobian() + first_s - first_t  # d dr / d xi
    n = _embed(dr / r[:, None])
    perp = np.eye(3)[None] - n[:, :, None] * n[:, None, :]
    ds = np.einsum("pak,pk->pa", jac, n) / sigma[:, None]
    d2s = (np.einsum("pak,pkl,pbl->pab", jac, perp, jac) / r[:, None, None]
           + np.einsum("pk,pabk->pab", n, second_s - second_t)) / sigma[:, None, None]
    return bi, bj, r / sigma, ds, d2s


def _ellipsoid_reduced(packing: Packing, coords: Coordinates, skin: float = 0.0):
    from jamflow.model.shapes.contact_distance import HESSIAN_CONTACTS, contact_lambda

    shape = packing.shape
    if shape.contact not in HESSIAN_CONTACTS:
        raise ValueError(f"the dynamical matrix needs the contact-distance method's derivatives; the "
                         f"{shape.contact!r} method's lambda follows a truncated polynomial root and has none here: "
                         f"use contact 'exact' (or 'cleaver'/'gaussian')")
    i, j, dr, r, sigma = overlapping_pairs(packing, skin)
    axes, u = shape.axes(packing.diameters), packing.directors
    lam = contact_lambda(axes[i, 0], axes[i, 1], axes[j, 0], axes[j, 1], dr / r[:, None], u[i], u[j],
                         method=shape.contact)
    frame = _PairFrame.of(packing, coords, i, j)
    s, ds, d2s = reduced_distance_derivatives(frame, _embed(dr), _embed(u[i]), _embed(u[j]), 0.5 * axes[i],
                                              0.5 * axes[j], lam, envelope=shape.contact == "exact")
    return i, j, s, ds, d2s


def shape_matrices(u: np.ndarray, semi: np.ndarray) -> np.ndarray:
    """(P, 3, 3) A = alpha^2 u u^T + beta^2 (I - u u^T) for directors u (P, 3) and semi-axes
    (alpha, beta) (P, 2) along and across them."""
    along, across = semi[:, 0] ** 2, semi[:, 1] ** 2
    return across[:, None, None] * np.eye(3) + (along - across)[:, None, None] * u[:, :, None] * u[:, None, :]


def reduced_distance_derivatives(frame: _PairFrame, rvec, u_i, u_j, semi_i, semi_j, lam, envelope: bool):
    """s = r / sigma_ij and its gradient (P, L) and Hessian (P, L, L) in a pair's local
    coordinates (``_PairFrame``), from s^2 = F(lambda*) (module docstring); ``envelope``: lambda*
    maximises F (exact method), else lambda is fixed. Directions e = local coordinates, then lambda."""
    size = frame.size + 1
    lam_e = size - 1
    c_i = semi_i[:, 0] ** 2 - semi_i[:, 1] ** 2
    c_j = semi_j[:, 0] ** 2 - semi_j[:, 1] ** 2
    dr = frame.separation_jacobian(extra=1)
    du_i, du_j, d2u_i, d2u_j = frame.body_vector(u_i, u_j, extra=1)
    a_i, a_j = shape_matrices(u_i, semi_i), shape_matrices(u_j, semi_j)
    wi, wj = (1 - lam) * c_i, lam * c_j  # weights of the director terms of G
    g = (1 - lam)[:, None, None] * a_i + lam[:, None, None] * a_j
    g_inv = np.linalg.inv(g)
    k = np.einsum("pab,pb->pa", g_inv, rvec)
    big_s = np.einsum("pa,pa->p", rvec, k)
    ki, kj = np.einsum("pea,pa->pe", du_i, k), np.einsum("pea,pa->pe", du_j, k)
    uki, ukj = np.einsum("pa,pa->p", u_i, k), np.einsum("pa,pa->p", u_j, k)
    # dG_e k and k^T d2G_ef k (G is linear in lambda; its director terms are w (u u^T))
    dgk = (wi[:, None, None] * (du_i * uki[:, None, None] + u_i[:, None, :] * ki[:, :, None])
           + wj[:, None, None] * (du_j * ukj[:, None, None] + u_j[:, None, :] * kj[:, :, None]))
    dgk[:, lam_e] = np.einsum("pab,pb->pa", a_j - a_i, k)
    kd2gk = 2 * (wi[:, None, None] * (ki[:, :, None] * ki[:, None, :] + np.einsum("pefa,pa->pef", d2u_i, k) * uki[:, None, None])
                 + wj[:, None, None] * (kj[:, :, None] * kj[:, None, :] + np.einsum("pefa,pa->pef", d2u_j, k) * ukj[:, None, None]))
    mixed = 2 * (-c_i[:, None] * ki * uki[:, None] + c_j[:, None] * kj * ukj[:, None])  # k^T (d_lambda dG_e) k
    kd2gk[:, :, lam_e] += mixed
    kd2gk[:, lam_e, :] += mixed
    s_e = 2 * np.einsum("pea,pa->pe", dr, k) - np.einsum("pea,pa->pe", dgk, k)
    v = dr - dgk
    s_ef = 2 * np.einsum("pea,pab,pfb->pef", v, g_inv, v) - kd2gk
    w, w1 = lam * (1 - lam), 1 - 2 * lam
    f_e = w[:, None] * s_e
    f_e[:, lam_e] += w1 * big_s
    f_ef = w[:, None, None] * s_ef
    f_ef[:, lam_e, :] += w1[:, None] * s_e
    f_ef[:, :, lam_e] += w1[:, None] * s_e
    f_ef[:, lam_e, lam_e] -= 2 * big_s
    q = slice(0, frame.size)
    phi, grad, hess = w * big_s, f_e[:, q], f_ef[:, q, q]
    if envelope:
        hess = hess - f_ef[:, q, lam_e][:, :, None] * f_ef[:, lam_e, q][:, None, :] / f_ef[:, lam_e, lam_e][:, None, None]
    s = np.sqrt(phi)
    ds = grad / (2 * s[:, None])
    d2s = hess / (2 * s[:, None, None]) - grad[:, :, None] * grad[:, None, :] / (4 * s**3)[:, None, None]
    return s, ds, d2s


_REDUCED = {"sphere": _sphere_reduced, "rigid": _rigid_reduced, "ellipsoid": _ellipsoid_reduced}




