"""Moving a packing along a generalized displacement: centre displacements u (N, d) and
rotations d_k theta (N, r) in the coordinates of ``hessian.Coordinates`` (each particle turns
by the world rotation vector sum_a theta_a n_a about its centre, as the dynamical matrix
counts it). Used to test stability along modes (chapter section 3, Figure 2.15c).

- ``displaced``: the new packing.
- ``pair_changes``: reduced distance s = r / sigma of every pair within reach and its change,
  computed from the displacement itself so that it stays accurate relative to the change
  (subtracting two distances loses every digit when the change is far below round-off of s).
- ``energy_change``: V(xi_0 + u) - V(xi_0) summed pair by pair from those changes.
- ``opening_amplitude``: the amplitude at which the contact network would change.
"""

from __future__ import annotations

import numpy as np

from jamflow.model.packing import Packing
from jamflow.model.pairs import candidate_pairs, contact_distances, separations, site_packing
from jamflow.model.shapes.rotations import rotation_change, turned
from jamflow.mechanics.hessian import Coordinates, shape_matrices


def _rotations(packing: Packing, rotations) -> np.ndarray:
    """World rotation vectors of ``rotations`` (None: no turn)."""
    coords = Coordinates.of(packing)
    if rotations is None:
        rotations = np.zeros((packing.n, coords.n_rot))
    rotations = np.asarray(rotations, float).reshape(packing.n, coords.n_rot)
    return coords.world_rotations(packing, rotations)


def displaced(packing: Packing, translations, rotations=None) -> Packing:
    """The packing with centres moved by ``translations`` (N, d) and particles turned by
    ``rotations`` (N, r) d_k theta."""
    u = np.asarray(translations, float).reshape(packing.n, packing.dim)
    if not packing.shape.oriented:
        return packing.with_positions(packing.positions + u)
    phi = _rotations(packing, rotations)
    return packing.with_positions(packing.positions + u, orientations=turned(packing.orientations, phi, packing.dim))


def _sphere_changes(packing: Packing, u: np.ndarray, _phi=None):
    reach = 2.0 * float(packing.shape.reach(packing.diameters).max()) + 2.0 * float(np.linalg.norm(u, axis=1).max())
    i, j = candidate_pairs(packing, reach)
    dr = separations(packing, i, j)
    du = u[i] - u[j]
    r = np.linalg.norm(dr, axis=1)
    r_new = np.linalg.norm(dr + du, axis=1)
    sigma = contact_distances(packing, i, j)
    change = (2.0 * np.einsum("pd,pd->p", dr, du) + np.einsum("pd,pd->p", du, du)) / (r + r_new)
    return i, j, r / sigma, change / sigma


def _rigid_changes(packing: Packing, u: np.ndarray, phi: np.ndarray):
    shape, d = packing.shape, packing.dim
    world = shape.world_sites(packing.positions, packing.orientations, packing.diameters).reshape(-1, d)
    body = np.repeat(np.arange(packing.n), shape.n_sites)
    lever = world - packing.positions[body]
    site_u = u[body] + rotation_change(phi[body], lever)
    sites, _ = site_packing(packing)
    s, t, red, change = _sphere_changes(sites, site_u)
    other = body[s] != body[t]
    return body[s][other], body[t][other], red[other], change[other]


def _ellipsoid_changes(packing: Packing, u: np.ndarray, phi: np.ndarray):
    """s^2 = max_lambda F (``hessian`` docstring); the change of F is written as differences
    (Delta r, Delta u, Delta lambda) throughout, so it is accurate relative to itself."""
    from jamflow.model.shapes.contact_distance import contact_lambda

    shape = packing.shape
    reach = 2.0 * float(shape.reach(packing.diameters).max()) + 2.0 * float(np.linalg.norm(u, axis=1).max())
    i, j = candidate_pairs(packing, reach)
    dr = separations(packing, i, j)
    r_new = dr + (u[i] - u[j])
    full = shape.axes(packing.diameters)
    semi = 0.5 * full
    director = packing.directors
    change = rotation_change(phi, director)
    new_director = director + change
    method = shape.contact

    def lam(vec, di, dj):
        r_hat = vec / np.linalg.norm(vec, axis=1)[:, None]
        return contact_lambda(full[i, 0], full[i, 1], full[j, 0], full[j, 1], r_hat, di, dj, method=method)

    lam0, lam1 = lam(dr, director[i], director[j]), lam(r_new, new_director[i], new_director[j])
    e = _embed
    r0, r1, dlt = e(dr), e(r_new), e(r_new - dr)
    u_i, u_j, du_i, du_j = e(director[i]), e(director[j]), e(change[i]), e(change[j])
    a_i, a_j = shape_matrices(u_i, semi[i]), shape_matrices(u_j, semi[j])
    b_i, b_j = shape_matrices(u_i + du_i, semi[i]), shape_matrices(u_j + du_j, semi[j])
    c_i, c_j = semi[i, 0] ** 2 - semi[i, 1] ** 2, semi[j, 0] ** 2 - semi[j, 1] ** 2

    def g(lm, ai, aj):
        return (1 - lm)[:, None, None] * ai + lm[:, None, None] * aj

    def outer_change(v, dv):  # (v + dv)(v + dv)^T - v v^T
        return dv[:, :, None] * (v + dv)[:, None, :] + v[:, :, None] * dv[:, None, :]

    solve = np.linalg.solve
    g_old, g_new = g(lam0, a_i, a_j), g(lam0, b_i, b_j)
    k_old = solve(g_old, r0[..., None])[..., 0]
    k_mix = solve(g_new, r0[..., None])[..., 0]
    k_new = solve(g_new, r1[..., None])[..., 0]
    w0 = lam0 * (1 - lam0)
    phi_old = w0 * np.einsum("pa,pa->p", r0, k_old)
    dg = ((1 - lam0) * c_i)[:, None, None] * outer_change(u_i, du_i) + (lam0 * c_j)[:, None, None] * outer_change(u_j, du_j)
    # F_new(lambda0) - F_old(lambda0)
    d_fixed = w0 * (np.einsum("pa,pa->p", dlt, k_new + k_mix) - np.einsum("pa,pab,pb->p", k_mix, dg, k_old))
    # F_new(lambda1) - F_new(lambda0): G changes by (lambda1 - lambda0)(B_j - B_i)
    dl = lam1 - lam0
    k_far = solve(g(lam1, b_i, b_j), r1[..., None])[..., 0]
    s_far = np.einsum("pa,pa->p", r1, k_far)
    d_lam = dl * (1 - lam1 - lam0) * s_far - w0 * dl * np.einsum("pa,pab,pb->p", k_far, b_j - b_i, k_new)
    d_phi = d_fixed + d_lam
    s_old = np.sqrt(phi_old)
    s_new = np.sqrt(phi_old + d_phi)
    return i, j, s_old, d_phi / (s_old + s_new)


def _embed(v: np.ndarray) -> np.ndarray:
    return v if v.shape[1] == 3 else np.column_stack([v, np.zeros(len(v))])


_CHANGES = {"sphere": _sphere_changes, "rigid": _rigid_changes, "ellipsoid": _ellipsoid_changes}


def pair_changes(packing: Packing, translations, rotations=None):
    """(i, j, s, ds) for every pair (of particles; rigid bodies: of sites, reported by body) that
    may come within contact: reduced distance s = r / sigma and its change ds when the packing
    moves by ``translations`` (N, d) and turns by ``rotations`` (N, r) d_k theta."""
    u = np.asarray(translations, float).reshape(packing.n, packing.dim)
    phi = _rotations(packing, rotations) if packing.shape.oriented else None
    return _CHANGES[packing.shape.kind](packing, u, phi)


_GAUSS_T, _GAUSS_W = np.polynomial.legendre.leggauss(12)


def energy_change(packing: Packing, displacement, rotations=None) -> float:
    """V(xi + u) - V(xi), total energy in eps, summed pair by pair.

    ``displacement`` (N, d) moves the centres, ``rotations`` (N, r) turns the particles by
    d_k theta about their rotational axes (``hessian.Coordinates``). Each pair's term is the
    integral of V'(s) from the old to the new reduced distance (clipped at s = 1), with the
    change of s computed from the displacement (``pair_changes``), so the result stays accurate
    when the displacement is far below the overlaps, where subtracting two total energies loses
    every digit. 12-point Gauss-Legendre: exact for alpha = 2.
    """
    _, _, s, ds = pair_changes(packing, displacement, rotations)
    inside = (s < 1.0) & (s + ds < 1.0)
    lo = np.minimum(s, 1.0)
    length = np.where(inside, ds, np.minimum(s + ds, 1.0) - lo)
    nodes = lo[:, None] + length[:, None] * 0.5 * (_GAUSS_T[None, :] + 1.0)
    slopes = packing.potential.dv_dr(nodes, 1.0)  # dV/ds
    return float(np.sum(0.5 * length * (slopes @ _GAUSS_W)))


PROBE = 1e-6  # amplitude (diameters per unit mode) of the differences that give ds/ddelta and d2s/ddelta2


def network_amplitudes(packing: Packing, translations, rotations=None) -> tuple[float, float]:
    """(opening, closing): the smallest amplitude delta at which a contact opens, and at which a
    pair not in contact touches, when the packing moves by delta * (translations, rotations).
    Per pair: its reduced distance s reaches 1 to first order (|1 - s| / |s'|), or to second
    order where s''/2 pushes it across (sqrt(|1 - s| / |s''/2|)); s' and s'' are central
    differences of ``pair_changes`` at +-PROBE (ds is accurate to its own round-off, so both are
    good to ~1e-10). inf where no pair crosses."""
    u = np.asarray(translations, float)
    rot = None if rotations is None else np.asarray(rotations, float)
    _, _, s, plus = pair_changes(packing, PROBE * u, None if rot is None else PROBE * rot)
    _, _, _, minus = pair_changes(packing, -PROBE * u, None if rot is None else -PROBE * rot)
    rate = (plus - minus) / (2 * PROBE)
    half_curvature = (plus + minus) / (2 * PROBE**2)
    gap = 1.0 - s  # > 0: overlapping (a contact), <= 0: apart
    contact = gap > 0
    across = np.where(contact, half_curvature > 0, half_curvature < 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        first = np.where(rate != 0, np.abs(gap) / np.abs(rate), np.inf)
        second = np.where(across, np.sqrt(np.abs(gap) / np.abs(half_curvature)), np.inf)
    amplitude = np.minimum(first, second)
    return (float(np.min(amplitude[contact], initial=np.inf)), float(np.min(amplitude[~contact], initial=np.inf)))


def opening_amplitude(packing: Packing, translations, rotations=None) -> float:
    """Smallest amplitude delta at which the contact network changes (a contact opens or a pair
    touches, ``network_amplitudes``)."""
    smallest = min(network_amplitudes(packing, translations, rotations))
    if not np.isfinite(smallest):
        raise ValueError("the mode moves no pair: it is a rigid translation, not a nontrivial mode")
    return smallest
