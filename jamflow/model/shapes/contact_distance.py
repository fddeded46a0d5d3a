"""Contact distance sigma_ij of two ellipses (2D) or spheroids (3D), chapter section 2.3.2.

Conventions (lengths in any unit; sigma comes out in the same unit):

- ``a`` is the full axis length along the director ``u``, ``b`` the full length across it,
  so two circles of diameter 1 have sigma = 1 (as for disks elsewhere in jamflow).
  ``a > b`` is prolate, ``a < b`` oblate; aspect ratio alpha = a / b.
- Shape matrix ``A = (a/2)^2 u u^T + (b/2)^2 (I - u u^T)``.
- ``r_hat`` is the unit vector from particle i to particle j (the sign does not matter).

Perram & Wertheim, J. Comput. Phys. 58, 409 (1985) (chapter ref. [41]): the contact function

    h(lambda) = lambda (1 - lambda) r_hat^T [(1 - lambda) A_i + lambda A_j]^{-1} r_hat

is concave on [0, 1] and vanishes at both ends; sigma_ij = (max_lambda h)^{-1/2}, and any
other lambda gives an upper bound sigma(lambda) = h(lambda)^{-1/2} >= sigma_ij.
Because A_i and A_j are rank-one updates of multiples of I, h has the closed form (valid in
2D and 3D, all terms non-negative for prolate pairs)

    C  = (1-lambda) b_i^2 + lambda b_j^2,  P = (1-lambda)(a_i^2 - b_i^2),  Q = lambda (a_j^2 - b_j^2)
    Nn = C^2 + C [P (1 - x^2) + Q (1 - z^2)] + P Q g
    Qd = C^2 + C (P + Q) + P Q (1 - m^2)
    h  = 4 lambda (1 - lambda) Nn / (C Qd)

with x = r_hat.u_i, z = r_hat.u_j, m = u_i.u_j and g = (r_hat . u_i x u_j)^2 (g = 0 in 2D).
It is the chapter's sigma(lambda) with lambda-dependent sigma_0, chi, beta; at lambda = 1/2 it
is exactly Cleaver et al.'s eq. 2.6, and for equal particles Berne & Pechukas's eq. 2.5.

Methods (``method=``):

- ``"exact"``: lambda_min from the chapter's quartic (2D, any sizes; eqs 2.7-2.15, with the
  sign of the m^2 term of eq. 2.15 corrected) or quintic (3D equal spheroids; eqs 2.16-2.25),
  root bracketed in y = lambda - 1/2 in (-1/2, 1/2) and polished by safeguarded Newton;
  elsewhere (3D, unequal spheroids) a safeguarded Newton-bisection maximisation of h(lambda)
  on [0, 1]. Agrees with brute force to ~1e-15 relative.
- ``"gaussian"``: Berne & Pechukas, J. Chem. Phys. 56, 4213 (1972), eq. 2.5; equal particles only.
- ``"cleaver"``: Cleaver, Care, Allen & Neal, Phys. Rev. E 54, 559 (1996), eq. 2.6.
- ``"linear"``, ``"quadratic"``: lambda_min from the truncations of eq. 2.26 (read as
  y_min = lambda_min - 1/2, quadratic root on the branch that tends to the linear one);
  wherever the chapter's polynomials apply (2D, or 3D equal spheroids). Where the truncated
  root leaves (-1/2, 1/2) (common at alpha >~ 3), or gives a larger sigma than lambda = 1/2,
  they fall back to lambda = 1/2 (Cleaver; ``truncated_lambda``).

Every method has derivatives (``contact_distance_gradient``): at lambda_min by the envelope
theorem, at lambda = 1/2 directly, for the truncations through dlambda/d(configuration).
The algebra (``pw_terms`` ... ``truncated_root``) is plain arithmetic that numpy evaluates on
arrays here and numba compiles into the engine kernel (jamflow/engines/compiled/ellipsoids.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

METHODS = ("exact", "gaussian", "cleaver", "linear", "quadratic")
HESSIAN_CONTACTS = ("exact", "cleaver", "gaussian")  # with second derivatives: the dynamical matrix, packing checks
UNIT_TOL = 1e-8  # allowed | |v| - 1 | for the unit vectors r_hat, u_i, u_j
SAME_SIZE_RTOL = 1e-12  # a_i == a_j and b_i == b_j to this relative tolerance counts as equal
OVERLAPPING, TOUCHING, APART = -1, 0, 1
STEP_TOL = 1e-12  # safeguarded Newton stops after a step this small (t = y or lambda, O(1))
# what the engines count while they evaluate contact distances (in this order): contacts where a
# truncation's root left (-1/2, 1/2) and lambda fell back to 1/2, contacts where it gave a larger
# sigma than 1/2 and was capped there, contacts evaluated with a truncation, pair evaluations
# whose contact distance came out non-finite
ENGINE_COUNTERS = ("fallbacks", "capped", "approximate", "invalid")


@dataclass(frozen=True)
class _Pair:
    """Validated, broadcast, flattened inputs (n pairs)."""

    a_i: np.ndarray
    b_i: np.ndarray
    a_j: np.ndarray
    b_j: np.ndarray
    r: np.ndarray  #: (n, d) unit
    u_i: np.ndarray  #: (n, d) unit
    u_j: np.ndarray  #: (n, d) unit
    shape: tuple  #: leading (batch) shape of the result

    @property
    def dim(self) -> int:
        return self.r.shape[1]

    @cached_property
    def x(self):
        return np.einsum("nk,nk->n", self.r, self.u_i)

    @cached_property
    def z(self):
        return np.einsum("nk,nk->n", self.r, self.u_j)

    @cached_property
    def m(self):
        return np.einsum("nk,nk->n", self.u_i, self.u_j)

    @cached_property
    def g(self):
        """Gram determinant of (r_hat, u_i, u_j) = triple product squared; 0 in 2D."""
        if self.dim == 2:
            return np.zeros(len(self.r))
        return np.einsum("nk,nk->n", self.r, np.cross(self.u_i, self.u_j)) ** 2

    def same_size(self) -> np.ndarray:
        return np.isclose(self.a_i, self.a_j, rtol=SAME_SIZE_RTOL, atol=0) & np.isclose(
            self.b_i, self.b_j, rtol=SAME_SIZE_RTOL, atol=0
        )

    def restrict(self, mask: np.ndarray) -> "_Pair":
        pick = [v[mask] for v in (self.a_i, self.b_i, self.a_j, self.b_j, self.r, self.u_i, self.u_j)]
        return _Pair(*pick, shape=(int(mask.sum()),))


def _unit_vectors(name: str, v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    if v.ndim == 0 or v.shape[-1] not in (2, 3):
        raise ValueError(
            f"{name} must have a last dimension of 2 (ellipses) or 3 (spheroids), got shape {v.shape}"
        )
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name} contains NaN or inf; pass finite unit vectors")
    norm = np.linalg.norm(v, axis=-1)
    if np.any(norm == 0):
        raise ValueError(f"{name} contains a zero vector; a direction (unit vector) is required")
    if np.any(np.abs(norm - 1) > UNIT_TOL):
        worst = float(np.max(np.abs(norm - 1)))
        raise ValueError(
            f"{name} must be unit vectors (| |v| - 1 | <= {UNIT_TOL:g}, worst {worst:.3g}); "
            f"normalise with v / np.linalg.norm(v, axis=-1, keepdims=True)"
        )
    return v / norm[..., None]


def _axes(name: str, v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    if not np.all(np.isfinite(v)) or np.any(v <= 0):
        raise ValueError(f"axis length {name} must be finite and > 0 (full axis lengths, not semi-axes)")
    return v


def _validate(a_i, b_i, a_j, b_j, r_hat, u_i, u_j) -> _Pair:
    axes = [_axes(n, v) for n, v in (("a_i", a_i), ("b_i", b_i), ("a_j", a_j), ("b_j", b_j))]
    vecs = [_unit_vectors(n, v) for n, v in (("r_hat", r_hat), ("u_i", u_i), ("u_j", u_j))]
    dims = {v.shape[-1] for v in vecs}
    if len(dims) != 1:
        raise ValueError(
            f"r_hat, u_i, u_j must all be 2D or all 3D vectors, got last dimensions "
            f"{[v.shape[-1] for v in vecs]}"
        )
    try:
        shape = np.broadcast_shapes(*(x.shape for x in axes), *(v.shape[:-1] for v in vecs))
    except ValueError:
        raise ValueError(
            "mismatched shapes: axes "
            f"{[x.shape for x in axes]} and vectors {[v.shape for v in vecs]} do not broadcast "
            "(vectors carry their components in the last dimension)"
        ) from None
    d = dims.pop()
    flat = [np.broadcast_to(x, shape).reshape(-1) for x in axes]
    flat += [np.broadcast_to(v, shape + (d,)).reshape(-1, d) for v in vecs]
    return _Pair(*flat, shape=shape)


def _check_method(method: str, allowed=METHODS) -> None:
    if method not in allowed:
        raise ValueError(f"unknown or unsupported method {method!r} here; choose one of {allowed}")


def check_method_sizes(method: str, dim: int, identical: bool) -> None:
    """Raise if ``method`` is used outside the domain where the chapter defines it; ``identical``:
    every pair has a_i == a_j and b_i == b_j (e.g. a monodisperse packing)."""
    if method == "gaussian" and not identical:
        raise ValueError(
            "method='gaussian' (Berne-Pechukas eq. 2.5) assumes identical particles "
            "(a_i == a_j and b_i == b_j); use method='cleaver' (eq. 2.6) or 'exact'"
        )
    if method in ("linear", "quadratic") and dim == 3 and not identical:
        raise ValueError(
            f"method={method!r} truncates the chapter's quintic (eqs 2.16-2.25), derived for "
            "identical spheroids only; for 3D pairs of different sizes use 'exact' or 'cleaver'"
        )


def _check_validity(p: _Pair, method: str) -> None:
    """Raise if ``method`` is used outside the domain where the chapter defines it."""
    if method == "gaussian" or (method in ("linear", "quadratic") and p.dim == 3):
        check_method_sizes(method, p.dim, bool(np.all(p.same_size())))


# --------------------------------------------------------------------------------------
# The algebra, written once: plain arithmetic on numpy arrays (here) or floats (numba compiles
# these very functions into jamflow/engines/compiled/ellipsoids.py). Arguments: squared full
# axis lengths ai2 = a_i^2, bi2, aj2, bj2; x = r_hat.u_i, z = r_hat.u_j, m = u_i.u_j and
# g = (r_hat . u_i x u_j)^2 (0 in 2D).
# --------------------------------------------------------------------------------------


def pw_terms(lam, ai2, bi2, aj2, bj2, x, z, m, g):
    """C, P, Q, Nn, Qd of the module docstring at lambda."""
    C = (1 - lam) * bi2 + lam * bj2
    P = (1 - lam) * (ai2 - bi2)
    Q = lam * (aj2 - bj2)
    Nn = C * C + C * (P * (1 - x * x) + Q * (1 - z * z)) + P * Q * g
    Qd = C * C + C * (P + Q) + P * Q * (1 - m * m)
    return C, P, Q, Nn, Qd


def pw_h(lam, ai2, bi2, aj2, bj2, x, z, m, g):
    """h(lambda) = sigma(lambda)^-2 in the closed form."""
    C, _, _, Nn, Qd = pw_terms(lam, ai2, bi2, aj2, bj2, x, z, m, g)
    return 4 * lam * (1 - lam) * Nn / (C * Qd)


def sigma_partials(lam, ai2, bi2, aj2, bj2, x, z, m, g):
    """sigma(lambda) = h^{-1/2} and its partial derivatives in x, z, m at fixed lambda (g as the
    Gram determinant 1 - x^2 - z^2 - m^2 + 2 x z m of the unit vectors, 0 in 2D)."""
    C, P, Q, Nn, Qd = pw_terms(lam, ai2, bi2, aj2, bj2, x, z, m, g)
    sigma = np.sqrt(C * Qd / (4 * lam * (1 - lam) * Nn))
    k_n, k_q = -0.5 * sigma / Nn, 0.5 * sigma / Qd
    s_x = k_n * (-2 * P * ((C + Q) * x - Q * m * z))
    s_z = k_n * (-2 * Q * ((C + P) * z - P * m * x))
    s_m = k_n * (2 * P * Q * (x * z - m)) + k_q * (-2 * P * Q * m)
    return sigma, s_x, s_z, s_m


def h_lambda_derivatives(lam, ai2, bi2, aj2, bj2, x, z, m, g):
    """dh/dlambda and d2h/dlambda2 of the closed form (C, P, Q are linear in lambda)."""
    dC, dP, dQ = bj2 - bi2, -(ai2 - bi2), aj2 - bj2
    C, P, Q, Nn, Qd = pw_terms(lam, ai2, bi2, aj2, bj2, x, z, m, g)
    wx, wz, wm = 1 - x * x, 1 - z * z, 1 - m * m
    # first and second lambda-derivatives of the quadratics Nn, Qd and of w = 4 lam (1-lam)
    Nn1 = 2 * C * dC + dC * (P * wx + Q * wz) + C * (dP * wx + dQ * wz) + (dP * Q + P * dQ) * g
    Nn2 = 2 * dC * dC + 2 * dC * (dP * wx + dQ * wz) + 2 * dP * dQ * g
    Qd1 = 2 * C * dC + dC * (P + Q) + C * (dP + dQ) + (dP * Q + P * dQ) * wm
    Qd2 = 2 * dC * dC + 2 * dC * (dP + dQ) + 2 * dP * dQ * wm
    w, w1, w2 = 4 * lam * (1 - lam), 4 - 8 * lam, -8.0
    # h = w Nn / (C Qd): differentiate the quotient
    num, num1, num2 = w * Nn, w1 * Nn + w * Nn1, w2 * Nn + 2 * w1 * Nn1 + w * Nn2
    den, den1, den2 = C * Qd, dC * Qd + C * Qd1, 2 * dC * Qd1 + C * Qd2
    h = num / den
    h1 = (num1 - h * den1) / den
    h2 = (num2 - 2 * h1 * den1 - h * den2) / den
    return h1, h2


def jkl_2d(ai2, bi2, aj2, bj2, x, z, m):
    """J, K, L of eqs 2.13-2.15 (eq. 2.15 with the sign of its m^2 term corrected, see docs)."""
    n_i = ai2 - (ai2 - bi2) * x * x
    n_j = aj2 - (aj2 - bj2) * z * z
    J = (n_j - n_i) / n_i  # eq. 2.13
    K = (aj2 * bj2) / (ai2 * bi2) - 1  # eq. 2.14
    # a_i^2 a_j^2 + b_i^2 b_j^2 - (a_i^2-b_i^2)(a_j^2-b_j^2) m^2, written as a sum of positive terms
    L = (ai2 * bj2 + bi2 * aj2 + (ai2 - bi2) * (aj2 - bj2) * (1 - m * m)) / (ai2 * bi2) - 2
    return J, K, L


def quartic(J, K, L):
    """Coefficients q0..q4 of eqs 2.8-2.12."""
    return (J * (L + 4) / 16 - K * (J + 4) / 16,  # eq. 2.8
            -(1 + K / 2) * (J + 2),  # eq. 2.9
            -J * (L + 6) / 2 - K * (3 * J + 2) / 2,  # eq. 2.10
            -2 * J * K,  # eq. 2.11
            J * (L - K))  # eq. 2.12


def jlm_3d(alpha2, x, z, m, g):
    """J, L, M of eqs 2.23-2.25 (identical spheroids, alpha2 = (a / b)^2, prolate or oblate)."""
    e = (alpha2 - 1) / alpha2  # (alpha^2 - 1) / alpha^2
    den = 1 - e * x * x
    J = e * (x * x - z * z) / den  # eq. 2.23
    L = (alpha2 - 1) * e * (1 - m * m)  # eq. 2.24
    # eq. 2.25: (x^2 + z^2 - m (2 x z - m) - 1) = -g, the Gram determinant of (r_hat, u_i, u_j)
    M = -(alpha2 - 1) * e * g / den
    return J, L, M


def quintic(J, L, M):
    """Coefficients q0..q5 of eqs 2.17-2.22."""
    return (J * (L + 4) / 16,  # eq. 2.17
            -(J + 2) + M * (L + 8) / 8,  # eq. 2.18
            -J * (L + 6) / 2,  # eq. 2.19
            -M * (L + 4),  # eq. 2.20
            J * L,  # eq. 2.21
            2 * M * L)  # eq. 2.22


def root_partials_2d(y, quad, ai2, bi2, aj2, bj2, x, z, m):
    """dy/dx, dy/dz, dy/dm of the root y of the truncation q0 + q1 y + quad q2 y^2 of the quartic
    (quad = 1 quadratic, 0 linear), by implicit differentiation (K does not depend on x, z, m)."""
    J, K, L = jkl_2d(ai2, bi2, aj2, bj2, x, z, m)
    n_i = ai2 - (ai2 - bi2) * x * x
    n_j = aj2 - (aj2 - bj2) * z * z
    J_x, J_z = 2 * (ai2 - bi2) * x * n_j / (n_i * n_i), -2 * (aj2 - bj2) * z / n_i
    L_m = -2 * m * (ai2 - bi2) * (aj2 - bj2) / (ai2 * bi2)
    p_J = (L + 4) / 16 - K / 16 - (1 + K / 2) * y + quad * (-(L + 6) / 2 - 1.5 * K) * y * y
    p_L = J / 16 + quad * (-J / 2) * y * y
    p_y = -(1 + K / 2) * (J + 2) + quad * 2 * (-J * (L + 6) / 2 - K * (3 * J + 2) / 2) * y
    return -p_J * J_x / p_y, -p_J * J_z / p_y, -p_L * L_m / p_y


def root_partials_3d(y, quad, alpha2, x, z, m, g):
    """As ``root_partials_2d`` for the quintic of identical spheroids (J, L, M of eqs 2.23-2.25),
    with g the Gram determinant (dg/dx = 2 (z m - x), and cyclically)."""
    J, L, M = jlm_3d(alpha2, x, z, m, g)
    e = (alpha2 - 1) / alpha2
    den = 1 - e * x * x
    J_x, J_z = 2 * e * x * (1 - e * z * z) / (den * den), -2 * e * z / den
    L_m = -2 * (alpha2 - 1) * e * m
    c = -(alpha2 - 1) * e / den
    M_x = c * (2 * (z * m - x) + g * 2 * e * x / den)
    M_z, M_m = c * 2 * (x * m - z), c * 2 * (x * z - m)
    p_J = (L + 4) / 16 - y + quad * (-(L + 6) / 2) * y * y
    p_L = J / 16 + M / 8 * y + quad * (-J / 2) * y * y
    p_M = (L + 8) / 8 * y
    p_y = -(J + 2) + M * (L + 8) / 8 + quad * 2 * (-J * (L + 6) / 2) * y
    return ((-p_J * J_x - p_M * M_x) / p_y, (-p_J * J_z - p_M * M_z) / p_y, (-p_L * L_m - p_M * M_m) / p_y)


def truncated_root(q0, q1, q2, quad):
    """y_min of eq. 2.26 truncated at linear (quad = 0) or quadratic (quad = 1) order.

    Returns (y, q, inside): the quadratic root is the branch that tends to -q0/q1 (q1 < 0 always,
    so no cancellation; without real roots the linear root, q = 0); where the root misses the
    physical interval (-1/2, 1/2) the truncation has failed (inside False) and y = 0 (lambda = 1/2,
    the Cleaver value), still an upper bound on sigma. Branch-free: floats or arrays.
    """
    disc = q1 * q1 - 4 * q0 * q2
    q = quad * (disc >= 0)
    root = np.sqrt(np.maximum(disc, 0.0))
    y = -2 * q0 / (q1 + (1 - q) * q1 + q * np.copysign(root, q1))
    inside = np.abs(y) < 0.5
    return y * inside, q * inside, inside


def truncated_lambda(quad, ai2, bi2, aj2, bj2, x, z, m, g, q0, q1, q2):
    """lambda of the linear (quad = 0) or quadratic (quad = 1) truncation with its fallback:
    (lambda, q, inside, kept). The truncation is dropped for lambda = 1/2 (the Cleaver value)
    where its root leaves (-1/2, 1/2) (inside False: the chapter's truncation has failed) or
    where it gives a larger sigma than lambda = 1/2 does (kept False too; both are upper bounds
    on the exact sigma, and near the ends of (0, 1) the linear root gave sigma up to ~100x the
    exact one at alpha >= 3). The second switch is continuous in the configuration, and it
    bounds sigma by the Cleaver value, sigma^2 <= 2 (R_i^2 + R_j^2), R the half longest axes."""
    y, q, inside = truncated_root(q0, q1, q2, quad)
    kept = inside & (pw_h(0.5 + y, ai2, bi2, aj2, bj2, x, z, m, g) >= pw_h(0.5, ai2, bi2, aj2, bj2, x, z, m, g))
    return 0.5 + y * kept, q * kept, inside, kept


# --------------------------------------------------------------------------------------
# The contact function on validated pairs, the chapter's polynomials f(y), y = lambda - 1/2
# --------------------------------------------------------------------------------------


def _squares(p: _Pair):
    return p.a_i**2, p.b_i**2, p.a_j**2, p.b_j**2


def _terms(p: _Pair, lam: np.ndarray):
    return pw_terms(lam, *_squares(p), p.x, p.z, p.m, p.g)


def _h(p: _Pair, lam: np.ndarray) -> np.ndarray:
    return pw_h(lam, *_squares(p), p.x, p.z, p.m, p.g)


def _sigma_at(p: _Pair, lam: np.ndarray) -> np.ndarray:
    """sigma(lambda) = h(lambda)^{-1/2} (>= sigma_ij for any lambda in (0, 1))."""
    return 1.0 / np.sqrt(_h(p, lam))


def _tangential(v: np.ndarray, e: np.ndarray) -> np.ndarray:
    return v - np.einsum("nk,nk->n", v, e)[:, None] * e


def _sigma_gradient(p: _Pair, lam: np.ndarray, y_partials=None):
    """sigma(lambda) and its tangential gradients in r_hat, u_i, u_j.

    At lambda_min this is the full derivative of sigma_ij (envelope theorem: dh/dlambda = 0);
    at lambda = 1/2 (gaussian, cleaver) lambda is constant. ``y_partials``: dlambda/d(x, z, m)
    where lambda depends on the configuration (linear, quadratic), added through dsigma/dlambda.
    """
    sq = _squares(p)
    sigma, s_x, s_z, s_m = sigma_partials(lam, *sq, p.x, p.z, p.m, p.g)
    if y_partials is not None:
        h1, _ = h_lambda_derivatives(lam, *sq, p.x, p.z, p.m, p.g)
        s_lam = -0.5 * sigma**3 * h1  # d h^{-1/2} / d lambda
        s_x, s_z, s_m = s_x + s_lam * y_partials[0], s_z + s_lam * y_partials[1], s_m + s_lam * y_partials[2]
    col = lambda v: v[:, None]  # noqa: E731
    d_r = col(s_x) * p.u_i + col(s_z) * p.u_j
    d_ui = col(s_x) * p.r + col(s_m) * p.u_j
    d_uj = col(s_z) * p.r + col(s_m) * p.u_i
    return sigma, _tangential(d_r, p.r), _tangential(d_ui, p.u_i), _tangential(d_uj, p.u_j)


def _chapter_coefficients_2d(p: _Pair) -> np.ndarray:
    """Quartic eqs 2.7-2.15 (any two ellipses)."""
    return np.stack(quartic(*jkl_2d(*_squares(p), p.x, p.z, p.m)), axis=-1)


def _alpha2(p: _Pair) -> np.ndarray:
    return (p.a_i / p.b_i) ** 2


def _chapter_coefficients_3d(p: _Pair) -> np.ndarray:
    """Quintic eqs 2.16-2.25 (identical spheroids, alpha = a / b, prolate or oblate)."""
    return np.stack(quintic(*jlm_3d(_alpha2(p), p.x, p.z, p.m, p.g)), axis=-1)


def _chapter_coefficients(p: _Pair) -> np.ndarray:
    return _chapter_coefficients_2d(p) if p.dim == 2 else _chapter_coefficients_3d(p)


def _polyval(c: np.ndarray, t: np.ndarray):
    """Value and derivative of sum_k c[:, k] t^k (Horner, row-wise)."""
    f, df = c[:, -1].copy(), np.zeros_like(t)
    for k in range(c.shape[1] - 2, -1, -1):
        df = df * t + f
        f = f * t + c[:, k]
    return f, df


def _safeguarded_newton(fun, lo: float, hi: float, x0: np.ndarray, max_iter: int = 100) -> np.ndarray:
    """Vectorised root of a function with f > 0 at lo, f < 0 at hi and one sign change between.

    Both uses qualify: f is dh/dlambda times a positive factor and h is concave on [0, 1] with
    h(0) = h(1) = 0 (Perram & Wertheim 1985). ``fun(t, idx)`` returns (f, df/dt) for the pairs
    ``idx``. Newton steps that leave the current bracket, or go uphill, are replaced by
    bisection, so it always converges.
    """
    t = np.clip(np.asarray(x0, dtype=float).copy(), lo, hi)
    n = t.size
    left, right = np.full(n, lo), np.full(n, hi)
    idx = np.arange(n)
    for _ in range(max_iter):
        f, df = fun(t[idx], idx)
        left[idx] = np.where(f > 0, t[idx], left[idx])
        right[idx] = np.where(f < 0, t[idx], right[idx])
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(df < 0, -f / df, np.nan)
        # a Newton step below STEP_TOL leaves an error ~ step^2, i.e. at the rounding level
        small = np.abs(step) <= STEP_TOL
        new = t[idx] + step
        bad = ~((new > left[idx]) & (new < right[idx])) & ~small
        new = np.where(bad, 0.5 * (left[idx] + right[idx]), new)
        done = (f == 0) | small | (right[idx] - left[idx] <= 4e-16)
        t[idx] = np.where(f == 0, t[idx], new)
        idx = idx[~done]
        if idx.size == 0:
            break
    return t


def _approx_y(q: np.ndarray, order: int) -> np.ndarray:
    """y_min from f truncated at linear or quadratic order (``truncated_root``)."""
    return truncated_root(q[:, 0], q[:, 1], q[:, 2], float(order == 2))[0]


def _lambda_polynomial(p: _Pair) -> np.ndarray:
    """lambda_min from the chapter's quartic / quintic: the unique root in y in (-1/2, 1/2)."""
    q = _chapter_coefficients(p)
    y0 = _approx_y(q, 2)
    y = _safeguarded_newton(lambda t, idx: _polyval(q[idx], t), -0.5, 0.5, y0)
    return 0.5 + y


def _h_lambda_derivatives(p: _Pair, lam: np.ndarray):
    return h_lambda_derivatives(lam, *_squares(p), p.x, p.z, p.m, p.g)


def _lambda_maximise(p: _Pair) -> np.ndarray:
    """lambda_min by safeguarded Newton-bisection on dh/dlambda over [0, 1] (h is concave)."""

    def fun(lam, idx):
        return _h_lambda_derivatives(p.restrict(_mask(idx, len(p.r))), lam)

    # start from the exact answer for spheres, lambda = d_i / (d_i + d_j), with d the support
    # width of each particle along r_hat: d^2 = b^2 + (a^2 - b^2) (r_hat . u)^2
    d_i = np.sqrt(p.b_i**2 + (p.a_i**2 - p.b_i**2) * p.x**2)
    d_j = np.sqrt(p.b_j**2 + (p.a_j**2 - p.b_j**2) * p.z**2)
    return _safeguarded_newton(fun, 0.0, 1.0, d_i / (d_i + d_j))


def _mask(idx: np.ndarray, n: int) -> np.ndarray:
    mask = np.zeros(n, bool)
    mask[idx] = True
    return mask


def _lambda_exact(p: _Pair) -> np.ndarray:
    if p.dim == 2:
        return _lambda_polynomial(p)
    lam = np.empty(len(p.r))
    mono = p.same_size()
    if mono.any():
        lam[mono] = _lambda_polynomial(p.restrict(mono))
    if (~mono).any():
        lam[~mono] = _lambda_maximise(p.restrict(~mono))
    return lam


def _truncation(p: _Pair, method: str):
    """(lambda, q, inside, kept) of ``truncated_lambda`` for "linear" / "quadratic"."""
    c = _chapter_coefficients(p)
    return truncated_lambda(float(method == "quadratic"), *_squares(p), p.x, p.z, p.m, p.g, c[:, 0], c[:, 1], c[:, 2])


def _lambda(p: _Pair, method: str) -> np.ndarray:
    if method == "exact":
        return _lambda_exact(p)
    if method in ("gaussian", "cleaver"):
        return np.full(len(p.r), 0.5)
    return _truncation(p, method)[0]


def _root_partials(p: _Pair, method: str):
    """dlambda/d(x, z, m) of "linear" / "quadratic" (0 where the truncation fell back to 1/2)."""
    lam, q, _, kept = _truncation(p, method)
    if p.dim == 2:
        parts = root_partials_2d(lam - 0.5, q, *_squares(p), p.x, p.z, p.m)
    else:
        parts = root_partials_3d(lam - 0.5, q, _alpha2(p), p.x, p.z, p.m, p.g)
    return [np.where(kept, v, 0.0) for v in parts]


# --------------------------------------------------------------------------------------
# Public API
# --------------------------------------------------------------------------------------


def contact_lambda(a_i, b_i, a_j, b_j, r_hat, u_i, u_j, method: str = "exact") -> np.ndarray:
    """The Perram-Wertheim parameter lambda in [0, 1] that ``method`` uses (dimensionless).

    "exact": lambda_min = argmax h; "gaussian"/"cleaver": 1/2; "linear"/"quadratic": eq. 2.26.
    """
    _check_method(method)
    p = _validate(a_i, b_i, a_j, b_j, r_hat, u_i, u_j)
    _check_validity(p, method)
    return _lambda(p, method).reshape(p.shape)


def contact_distance(a_i, b_i, a_j, b_j, r_hat, u_i, u_j, method: str = "exact") -> np.ndarray:
    """Contact distance sigma_ij (length units of a, b) of two ellipses or spheroids.

    a_*, b_*: full axis lengths along / across the directors (> 0); r_hat, u_i, u_j: unit
    vectors (..., 2) or (..., 3); all inputs broadcast over leading dimensions.
    method: "exact" (Perram & Wertheim 1985, eqs 2.7-2.25), "gaussian" (Berne & Pechukas
    1972, eq. 2.5), "cleaver" (Cleaver et al. 1996, eq. 2.6), "linear" / "quadratic" (eq. 2.26).

    Parameters
    ----------
    a_i, b_i, a_j, b_j : array_like
        Full axis lengths of particles i and j along / across their directors (> 0), in any
        length unit (diameters in jamflow).
    r_hat : array_like
        (..., d) unit vector from i to j, d = 2 or 3.
    u_i, u_j : array_like
        (..., d) unit directors of i and j.
    method : {"exact", "gaussian", "cleaver", "linear", "quadratic"}, default "exact"
        The approximation (chapter eqs 2.5-2.26); "gaussian" needs identical particles, and so
        do "linear" / "quadratic" in 3D.

    Returns
    -------
    numpy.ndarray
        sigma_ij, the centre distance at contact along ``r_hat``, in the unit of the axes, of the
        broadcast shape of the inputs (without the vectors' last axis).

    Raises
    ------
    ValueError
        Unknown method, a method outside its domain, non-positive axes, vectors that are not
        unit vectors, or shapes that do not broadcast.
    """
    _check_method(method)
    p = _validate(a_i, b_i, a_j, b_j, r_hat, u_i, u_j)
    _check_validity(p, method)
    return _sigma_at(p, _lambda(p, method)).reshape(p.shape)


def contact_distance_gradient(a_i, b_i, a_j, b_j, r_hat, u_i, u_j, method: str = "exact"):
    """sigma_ij and its derivatives with respect to r_hat, u_i and u_j.

    Returns (sigma, dsigma_dr_hat, dsigma_du_i, dsigma_du_j); the gradients are tangential
    (orthogonal to their unit vector), i.e. derivatives along the unit circle / sphere, in
    length units. For a separation vector r = |r| r_hat: d sigma / d r = dsigma_dr_hat / |r|;
    for a 2D director u = (cos t, sin t): d sigma / d t = dsigma_du . (-sin t, cos t).
    Uses the envelope theorem at lambda_min (exact) or the constant lambda = 1/2 (gaussian,
    cleaver); "linear"/"quadratic" add the change of their lambda (implicit differentiation of
    the truncated eq. 2.26; 0 where the truncation fell back to lambda = 1/2, where sigma jumps).
    """
    _check_method(method)
    p = _validate(a_i, b_i, a_j, b_j, r_hat, u_i, u_j)
    _check_validity(p, method)
    partials = _root_partials(p, method) if method in ("linear", "quadratic") else None
    sigma, d_r, d_ui, d_uj = _sigma_gradient(p, _lambda(p, method), partials)
    vec = p.shape + (p.dim,)
    return sigma.reshape(p.shape), d_r.reshape(vec), d_ui.reshape(vec), d_uj.reshape(vec)


def truncation_fallbacks(a_i, b_i, a_j, b_j, r_hat, u_i, u_j, method: str) -> np.ndarray:
    """True where "linear" / "quadratic" use lambda = 1/2 instead of their root (``truncated_lambda``:
    the root left (-1/2, 1/2), or gave a larger sigma)."""
    _check_method(method, ("linear", "quadratic"))
    p = _validate(a_i, b_i, a_j, b_j, r_hat, u_i, u_j)
    _check_validity(p, method)
    return ~_truncation(p, method)[3].reshape(p.shape)


def contact_function(lam, a_i, b_i, a_j, b_j, r_hat, u_i, u_j) -> np.ndarray:
    """Perram-Wertheim h(lambda) = sigma(lambda)^{-2} (1 / length^2), lambda in (0, 1).

    max over lambda gives sigma_ij^{-2}; F_ij = (r_ij / sigma_ij)^2 (chapter Fig. 2.13).
    """
    p = _validate(a_i, b_i, a_j, b_j, r_hat, u_i, u_j)
    lam = np.asarray(lam, dtype=float)
    if np.any((lam <= 0) | (lam >= 1)):
        raise ValueError("lambda must lie strictly between 0 and 1")
    return _h(p, np.broadcast_to(lam, p.shape).reshape(-1)).reshape(p.shape)


def lambda_polynomial(a_i, b_i, a_j, b_j, r_hat, u_i, u_j) -> np.ndarray:
    """Coefficients (q0, q1, ...) of the chapter's f(y), y = lambda - 1/2 (dimensionless).

    Quartic (..., 5) for ellipses (eqs 2.7-2.15, eq. 2.15 sign-corrected), quintic (..., 6)
    for identical spheroids (eqs 2.16-2.25). Raises for 3D pairs of different sizes.
    """
    p = _validate(a_i, b_i, a_j, b_j, r_hat, u_i, u_j)
    _check_validity(p, "linear")
    q = _chapter_coefficients(p)
    return q.reshape(p.shape + (q.shape[-1],))


def overlap_state(a_i, b_i, a_j, b_j, r_ij, u_i, u_j, rtol: float = 1e-9) -> np.ndarray:
    """Classify pairs with separation vector r_ij (length units, not unit): -1 overlapping,
    0 touching (| |r_ij| / sigma_ij - 1 | <= rtol), +1 apart. Uses the exact sigma_ij."""
    r_ij = np.asarray(r_ij, dtype=float)
    dist = np.linalg.norm(r_ij, axis=-1) if r_ij.ndim else np.array(np.nan)
    if r_ij.ndim == 0 or np.any(dist == 0) or not np.all(np.isfinite(dist)):
        raise ValueError("r_ij must be finite, non-zero separation vectors of shape (..., 2|3)")
    sigma = contact_distance(a_i, b_i, a_j, b_j, r_ij / dist[..., None], u_i, u_j, "exact")
    ratio = dist / sigma - 1
    return np.where(np.abs(ratio) <= rtol, TOUCHING, np.where(ratio < 0, OVERLAPPING, APART))
