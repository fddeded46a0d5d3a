"""Kernel for ellipses (2D) and spheroids (3D): V(r_ij / sigma_ij) with the contact distance
sigma_ij(r_hat, u_i, u_j) of ``jamflow.model.shapes.contact_distance`` (chapter section 2.3.2), forces,
torques and the virial. Units: eps, diameter (the across-axis length b of the small particle).

The formulas are the numpy module's own algebra (``pw_terms``, ``sigma_partials``, ``quartic``,
``quintic``, ``truncated_root``, ``root_partials_*``, ``h_lambda_derivatives``), compiled here
by numba; this module adds the per-pair control flow of its solvers:

- ``exact``: lambda_min from the quartic (2D, any sizes) or quintic (3D identical spheroids),
  the root in y = lambda - 1/2 bracketed in [-1/2, 1/2] and polished by safeguarded Newton from
  the quadratic truncation; 3D pairs of different sizes maximise h(lambda) over [0, 1] by the
  same safeguarded Newton on dh/dlambda, from the sphere value d_i / (d_i + d_j); after the first
  evaluation each listed pair starts from its last lambda (one or two Newton steps);
- ``gaussian`` / ``cleaver``: lambda = 1/2;
- ``linear`` / ``quadratic``: lambda from eq. 2.26 truncated, with its own derivative; where
  the root leaves (-1/2, 1/2), or gives a larger sigma than 1/2 does, lambda = 1/2
  (``truncated_lambda``), and the pair list's ``counters`` count both.

Before any solve, a listed pair at r >= sigma(1/2) (an upper bound of every method's sigma) is
skipped: it cannot touch.

For a pair energy V(s), s = r / sigma: the force on i is -V'(s) (r_hat / sigma - g_r / sigma^2)
(g_r the tangential gradient of sigma in r_hat), the torque on i V'(s) r / sigma^2 (u_i x
dsigma/du_i), the virial sum r_ij,a f_ij,b (not symmetric: the forces are not central).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from jamflow.model.packing import Packing
from jamflow.model.pairs import candidate_pairs
from jamflow.model.shapes.contact_distance import (ENGINE_COUNTERS, METHODS, SAME_SIZE_RTOL, STEP_TOL,
                                                   h_lambda_derivatives, jkl_2d, jlm_3d, pw_h, pw_terms, quartic,
                                                   quintic, root_partials_2d, root_partials_3d, sigma_partials,
                                                   truncated_lambda, truncated_root)
from jamflow.engines.compiled import jit, when_numba_starts
from jamflow.engines.compiled.laws import energy_force

KIND = "ellipsoid"
# the list holds every pair within an orientation-independent bound of its contact distance,
# so turning a particle cannot bring a pair into reach: only translations trigger rebuilds
TURNING_MOVES_SITES = False
EXACT, GAUSSIAN, CLEAVER, LINEAR, QUADRATIC = range(5)  # index in contact_distance.METHODS
# what ``forces`` counts in Pairs.counters (contact_distance.ENGINE_COUNTERS)
COUNTERS = ENGINE_COUNTERS
FALLBACKS, CAPPED, APPROXIMATE, INVALID = range(4)
MAX_ITER = 100


def _register():
    """numba compiles the numpy module's algebra wherever a kernel calls it (the functions stay plain
    Python for numpy; register_jitable makes them callable from compiled code, calls among them included)."""
    from numba.extending import register_jitable

    for algebra in (pw_terms, pw_h, sigma_partials, h_lambda_derivatives, jkl_2d, quartic, jlm_3d, quintic,
                    truncated_root, root_partials_2d, root_partials_3d, truncated_lambda):
        register_jitable(algebra)


when_numba_starts(_register)


class Pairs(NamedTuple):
    """Pairs i < j within the method's largest contact distance + skin (``_bound_sq``, from the
    reach = half the longest axis), with each pair's periodic image offset; per-particle squared
    full axes; ``counters`` (4,) int64 (``COUNTERS``)."""

    i: np.ndarray
    j: np.ndarray
    shift: np.ndarray  # (P, d)
    identical: np.ndarray  # (P,) 1 if a_i == a_j and b_i == b_j (contact_distance.SAME_SIZE_RTOL)
    a2: np.ndarray  # (N,) a^2, full length along the director
    b2: np.ndarray  # (N,) b^2, across
    reach: np.ndarray  # (N,)
    method: int
    law: tuple
    counters: np.ndarray
    u: np.ndarray  # (N, 3) scratch: directors
    lam: np.ndarray  # (P,) each pair's lambda at its last evaluation (NaN: not yet), starts the exact solvers


@jit
def _director(o, i, d, u):
    if d == 2:
        u[0], u[1], u[2] = math.cos(o[i, 0]), math.sin(o[i, 0]), 0.0
        return
    w, x, y, z = o[i, 0], o[i, 1], o[i, 2], o[i, 3]
    u[0] = 1 - 2 * (y * y + z * z)
    u[1] = 2 * (x * y + w * z)
    u[2] = 2 * (x * z - w * y)


@jit
def _bound_sq(method, reach_i, reach_j):
    """Largest sigma_ij^2 of the method: (R_i + R_j)^2 exact, 2 (R_i^2 + R_j^2) where lambda is
    1/2 or a truncation's (``truncated_lambda``)."""
    if method == EXACT:
        return (reach_i + reach_j) ** 2
    return 2.0 * (reach_i * reach_i + reach_j * reach_j)


@jit
def _safeguarded_step(t, f, df, left, right):
    """One step of ``contact_distance._safeguarded_newton`` for one pair: (t, left, right, done)."""
    if f > 0:
        left = t
    if f < 0:
        right = t
    step = -f / df if df < 0 else math.nan
    small = abs(step) <= STEP_TOL
    new = t + step
    if not (new > left and new < right) and not small:
        new = 0.5 * (left + right)
    done = f == 0 or small or right - left <= 4e-16
    if f != 0:
        t = new
    return t, left, right, done


@jit
def _polynomial_root(q0, q1, q2, q3, q4, q5, t0):
    """The root of f(y) = sum q_k y^k in (-1/2, 1/2), from t0 (the pair's last root) or, when t0
    is NaN, the quadratic truncation."""
    t = t0 if -0.5 < t0 < 0.5 else truncated_root(q0, q1, q2, 1.0)[0]
    left, right = -0.5, 0.5
    for _ in range(MAX_ITER):
        f, df = q5, 0.0
        for c in (q4, q3, q2, q1, q0):  # Horner, as contact_distance._polyval
            df = df * t + f
            f = f * t + c
        t, left, right, done = _safeguarded_step(t, f, df, left, right)
        if done:
            break
    return t


@jit
def _maximise(ai2, bi2, aj2, bj2, x, z, m, g, t0):
    """lambda_min maximising h over [0, 1] (3D pairs of different sizes), from t0 (the pair's last
    lambda) or, when t0 is NaN, the sphere value d_i / (d_i + d_j)."""
    d_i = math.sqrt(bi2 + (ai2 - bi2) * x * x)
    d_j = math.sqrt(bj2 + (aj2 - bj2) * z * z)
    t = t0 if 0.0 < t0 < 1.0 else min(max(d_i / (d_i + d_j), 0.0), 1.0)
    left, right = 0.0, 1.0
    for _ in range(MAX_ITER):
        f, df = h_lambda_derivatives(t, ai2, bi2, aj2, bj2, x, z, m, g)
        t, left, right, done = _safeguarded_step(t, f, df, left, right)
        if done:
            break
    return t


@jit
def _coefficients(d, ai2, bi2, aj2, bj2, x, z, m, g):
    """The chapter's polynomial (quartic padded with q5 = 0, or quintic)."""
    if d == 2:
        q0, q1, q2, q3, q4 = quartic(*jkl_2d(ai2, bi2, aj2, bj2, x, z, m))
        return q0, q1, q2, q3, q4, 0.0
    return quintic(*jlm_3d(ai2 / bi2, x, z, m, g))


@jit
def contact(method, d, identical, ai2, bi2, aj2, bj2, x, z, m, g, lam0=math.nan):
    """(sigma, dsigma/dx, dsigma/dz, dsigma/dm, fell back, capped, lambda) for one pair; ``lam0``
    starts the exact solvers (the pair's lambda at the last evaluation; NaN: their own guess)."""
    partial_x, partial_z, partial_m, fell_back, capped = 0.0, 0.0, 0.0, False, False
    if method == EXACT:
        if d == 2 or identical:
            lam = 0.5 + _polynomial_root(*_coefficients(d, ai2, bi2, aj2, bj2, x, z, m, g), lam0 - 0.5)
        else:
            lam = _maximise(ai2, bi2, aj2, bj2, x, z, m, g, lam0)
    elif method == GAUSSIAN or method == CLEAVER:
        lam = 0.5
    else:
        q0, q1, q2, _, _, _ = _coefficients(d, ai2, bi2, aj2, bj2, x, z, m, g)
        lam, quad, inside, kept = truncated_lambda(1.0 if method == QUADRATIC else 0.0, ai2, bi2, aj2, bj2, x, z,
                                                   m, g, q0, q1, q2)
        fell_back, capped = not inside, inside and not kept
        if kept:
            if d == 2:
                partial_x, partial_z, partial_m = root_partials_2d(lam - 0.5, quad, ai2, bi2, aj2, bj2, x, z, m)
            else:
                partial_x, partial_z, partial_m = root_partials_3d(lam - 0.5, quad, ai2 / bi2, x, z, m, g)
    sigma, s_x, s_z, s_m = sigma_partials(lam, ai2, bi2, aj2, bj2, x, z, m, g)
    if partial_x != 0.0 or partial_z != 0.0 or partial_m != 0.0:
        s_lam = -0.5 * sigma**3 * h_lambda_derivatives(lam, ai2, bi2, aj2, bj2, x, z, m, g)[0]
        s_x, s_z, s_m = s_x + s_lam * partial_x, s_z + s_lam * partial_z, s_m + s_lam * partial_m
    return sigma, s_x, s_z, s_m, fell_back, capped, lam


@jit
def forces(pl, x, o, f, tau, virial):
    """Fill f (N, d), world torques tau (N, 1 | 3) and the virial (d, d); return the energy."""
    n, d = x.shape
    f[:] = 0.0
    tau[:] = 0.0
    virial[:] = 0.0
    energy = 0.0
    for k in range(n):
        _director(o, k, d, pl.u[k])
    dr, rh, force = np.zeros(3), np.zeros(3), np.zeros(3)
    approximate = pl.method == LINEAR or pl.method == QUADRATIC
    for k in range(pl.i.shape[0]):
        i, j = pl.i[k], pl.j[k]
        r2 = 0.0
        for a in range(d):
            dr[a] = x[i, a] - x[j, a] + pl.shift[k, a]
            r2 += dr[a] * dr[a]
        if r2 >= _bound_sq(pl.method, pl.reach[i], pl.reach[j]):
            continue
        r = math.sqrt(r2)
        ui, uj = pl.u[i], pl.u[j]
        xx, zz, mm = 0.0, 0.0, 0.0
        for a in range(d):
            rh[a] = dr[a] / r
            xx += rh[a] * ui[a]
            zz += rh[a] * uj[a]
            mm += ui[a] * uj[a]
        g = 0.0
        if d == 3:
            g = (rh[0] * (ui[1] * uj[2] - ui[2] * uj[1]) + rh[1] * (ui[2] * uj[0] - ui[0] * uj[2])
                 + rh[2] * (ui[0] * uj[1] - ui[1] * uj[0])) ** 2
        ai2, bi2, aj2, bj2 = pl.a2[i], pl.b2[i], pl.a2[j], pl.b2[j]
        if r2 * pw_h(0.5, ai2, bi2, aj2, bj2, xx, zz, mm, g) >= 1.0:  # r >= sigma(1/2) >= every method's sigma
            continue
        sigma, s_x, s_z, s_m, fell_back, capped, pl.lam[k] = contact(pl.method, d, pl.identical[k], ai2, bi2,
                                                                     aj2, bj2, xx, zz, mm, g, pl.lam[k])
        if not (sigma > 0.0 and sigma < math.inf):
            pl.counters[INVALID] += 1
            continue
        if r >= sigma:
            continue
        if approximate:
            pl.counters[APPROXIMATE] += 1
            if fell_back:
                pl.counters[FALLBACKS] += 1
            if capped:
                pl.counters[CAPPED] += 1
        v, dv = energy_force(pl.law, r / sigma)
        energy += v
        # tangential gradient of sigma in r_hat: s_x u_i + s_z u_j minus its r_hat part
        radial = 0.0
        for a in range(d):
            radial += (s_x * ui[a] + s_z * uj[a]) * rh[a]
        for a in range(d):
            g_r = s_x * ui[a] + s_z * uj[a] - radial * rh[a]
            force[a] = -dv * (rh[a] / sigma - g_r / (sigma * sigma))
            f[i, a] += force[a]
            f[j, a] -= force[a]
        for a in range(d):
            for b in range(d):
                virial[a, b] += dr[a] * force[b]
        lever = dv * r / (sigma * sigma)
        _add_torque(tau, i, d, lever, ui, s_x, rh, s_m, uj)  # u_i x (s_x r_hat + s_m u_j)
        _add_torque(tau, j, d, lever, uj, s_z, rh, s_m, ui)  # u_j x (s_z r_hat + s_m u_i)
    return energy


@jit
def _add_torque(tau, i, d, lever, u, c_r, rh, c_o, other):
    """tau_i += lever u x (c_r r_hat + c_o other) (z-component in 2D)."""
    g0 = c_r * rh[0] + c_o * other[0]
    g1 = c_r * rh[1] + c_o * other[1]
    if d == 2:
        tau[i, 0] += lever * (u[0] * g1 - u[1] * g0)
        return
    g2 = c_r * rh[2] + c_o * other[2]
    tau[i, 0] += lever * (u[1] * g2 - u[2] * g1)
    tau[i, 1] += lever * (u[2] * g0 - u[0] * g2)
    tau[i, 2] += lever * (u[0] * g1 - u[1] * g0)


def build(packing: Packing, x: np.ndarray, skin: float) -> Pairs:
    """Pairs i < j within the method's bound + skin and their periodic image offsets."""
    shape = packing.shape
    a, b = shape.axes(packing.diameters).T
    reach = np.asarray(shape.reach(packing.diameters), float)
    method = METHODS.index(shape.contact)
    i, j = candidate_pairs(packing, 2.0 * float(reach.max()) + skin)  # >= every method's bound
    dr = packing.box.minimum_image(x[i] - x[j])
    bound = np.sqrt(_bound_sq(method, reach[i], reach[j]))
    keep = np.einsum("ij,ij->i", dr, dr) < (bound + skin) ** 2
    i, j, dr = i[keep], j[keep], dr[keep]
    shift = dr - (x[i] - x[j])
    identical = (np.isclose(a[i], a[j], rtol=SAME_SIZE_RTOL, atol=0)
                 & np.isclose(b[i], b[j], rtol=SAME_SIZE_RTOL, atol=0))
    return Pairs(i.astype(np.int64), j.astype(np.int64), np.ascontiguousarray(shift), identical.astype(np.bool_),
                 a * a, b * b, reach, method, packing.potential.params,
                 np.zeros(len(COUNTERS), np.int64), np.zeros((packing.n, 3)), np.full(len(i), np.nan))
