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
  root leaves (-1/2, 1/2) (common at alpha >~ 3) they fall back to lambda = 1/2 (Cleaver).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

METHODS = ("exact", "gaussian", "cleaver", "linear", "quadratic")
GRADIENT_METHODS = ("exact", "gaussian", "cleaver")
UNIT_TOL = 1e-8  # allowed | |v| - 1 | for the unit vectors r_hat, u_i, u_j
SAME_SIZE_RTOL = 1e-12  # a_i == a_j and b_i == b_j to this relative tolerance counts as equal
OVERLAPPING, TOUCHING, APART = -1, 0, 1
STEP_TOL = 1e-12  # safeguarded Newton stops after a step this small (t = y or lambda, O(1))


@dataclass(frozen=True)
class _Pair:
    """Validated, broadcast, flattened inputs (n pairs)."""

    a_i: np.ndarray
    b_i: np.ndarray
    a_j: np.ndarray
    b_j: np.ndarray
    r: np.ndarray  # (n, d) unit
    u_i: np.ndarray  # (n, d) unit
    u_j: np.ndarray  # (n, d) unit
    shape: tuple  # leading (batch) shape of the result

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


def _check_validity(p: _Pair, method: str) -> None:
    """Raise if ``method`` is used outside the domain where the chapter defines it."""
    if method == "gaussian" and not np.all(p.same_size()):
        raise ValueError(
            "method='gaussian' (Berne-Pechukas eq. 2.5) assumes identical particles "
            "(a_i == a_j and b_i == b_j); use method='cleaver' (eq. 2.6) or 'exact'"
        )
    if method in ("linear", "quadratic") and p.dim == 3 and not np.all(p.same_size()):
        raise ValueError(
            f"method={method!r} truncates the chapter's quintic (eqs 2.16-2.25), derived for "
            "identical spheroids only; for 3D pairs of different sizes use 'exact' or 'cleaver'"
        )


# --------------------------------------------------------------------------------------
# The contact function h(lambda) in closed form and its tangential gradient
# --------------------------------------------------------------------------------------


def _terms(p: _Pair, lam: np.ndarray):
    """C, P, Q, Nn, Qd of the module docstring at lambda (arrays of shape (n,))."""
    x, z, m = p.x, p.z, p.m
    C = (1 - lam) * p.b_i**2 + lam * p.b_j**2
    P = (1 - lam) * (p.a_i**2 - p.b_i**2)
    Q = lam * (p.a_j**2 - p.b_j**2)
    Nn = C * C + C * (P * (1 - x * x) + Q * (1 - z * z)) + P * Q * p.g
    Qd = C * C + C * (P + Q) + P * Q * (1 - m * m)
    return C, P, Q, Nn, Qd


def _h(p: _Pair, lam: np.ndarray) -> np.ndarray:
    C, _, _, Nn, Qd = _terms(p, lam)
    return 4 * lam * (1 - lam) * Nn / (C * Qd)


def _sigma_at(p: _Pair, lam: np.ndarray) -> np.ndarray:
    """sigma(lambda) = h(lambda)^{-1/2} (>= sigma_ij for any lambda in (0, 1))."""
    return 1.0 / np.sqrt(_h(p, lam))


def _tangential(v: np.ndarray, e: np.ndarray) -> np.ndarray:
    return v - np.einsum("nk,nk->n", v, e)[:, None] * e


def _sigma_gradient(p: _Pair, lam: np.ndarray):
    """sigma(lambda) and its tangential gradients in r_hat, u_i, u_j at fixed lambda.

    At lambda_min this is the full derivative of sigma_ij (envelope theorem: dh/dlambda = 0).
    """
    x, z, m = p.x, p.z, p.m
    C, P, Q, Nn, Qd = _terms(p, lam)
    sigma = np.sqrt(C * Qd / (4 * lam * (1 - lam) * Nn))
    n_x = -2 * P * ((C + Q) * x - Q * m * z)
    n_z = -2 * Q * ((C + P) * z - P * m * x)
    n_m = 2 * P * Q * (x * z - m)
    q_m = -2 * P * Q * m
    k_n, k_q = (-0.5 * sigma / Nn)[:, None], (0.5 * sigma / Qd)[:, None]
    col = lambda v: v[:, None]  # noqa: E731
    d_r = k_n * (col(n_x) * p.u_i + col(n_z) * p.u_j)
    d_ui = k_n * (col(n_x) * p.r + col(n_m) * p.u_j) + k_q * col(q_m) * p.u_j
    d_uj = k_n * (col(n_z) * p.r + col(n_m) * p.u_i) + k_q * col(q_m) * p.u_i
    return sigma, _tangential(d_r, p.r), _tangential(d_ui, p.u_i), _tangential(d_uj, p.u_j)


# --------------------------------------------------------------------------------------
# The chapter's polynomials f(y), y = lambda - 1/2 (coefficients ascending: q0, q1, ...)
# --------------------------------------------------------------------------------------


def _jkl_2d(p: _Pair):
    """J, K, L of eqs 2.13-2.15 (eq. 2.15 with the sign of its m^2 term corrected, see docs)."""
    x, z, m = p.x, p.z, p.m
    ai2, bi2, aj2, bj2 = p.a_i**2, p.b_i**2, p.a_j**2, p.b_j**2
    n_i = ai2 - (ai2 - bi2) * x * x
    n_j = aj2 - (aj2 - bj2) * z * z
    J = (n_j - n_i) / n_i  # eq. 2.13
    K = (aj2 * bj2) / (ai2 * bi2) - 1  # eq. 2.14
    # a_i^2 a_j^2 + b_i^2 b_j^2 - (a_i^2-b_i^2)(a_j^2-b_j^2) m^2, written as a sum of positive terms
    L = (ai2 * bj2 + bi2 * aj2 + (ai2 - bi2) * (aj2 - bj2) * (1 - m * m)) / (ai2 * bi2) - 2
    return J, K, L


def _quartic(J, K, L) -> np.ndarray:
    """Coefficients q0..q4 of eqs 2.8-2.12."""
    return np.stack(
        [
            J * (L + 4) / 16 - K * (J + 4) / 16,  # eq. 2.8
            -(1 + K / 2) * (J + 2),  # eq. 2.9
            -J * (L + 6) / 2 - K * (3 * J + 2) / 2,  # eq. 2.10
            -2 * J * K,  # eq. 2.11
            J * (L - K),  # eq. 2.12
        ],
        axis=-1,
    )


def _chapter_coefficients_2d(p: _Pair) -> np.ndarray:
    """Quartic eqs 2.7-2.15 (any two ellipses)."""
    return _quartic(*_jkl_2d(p))


def _chapter_coefficients_3d(p: _Pair) -> np.ndarray:
    """Quintic eqs 2.16-2.25 (identical spheroids, alpha = a / b, prolate or oblate)."""
    x, z, m = p.x, p.z, p.m
    alpha2 = (p.a_i / p.b_i) ** 2
    e = (alpha2 - 1) / alpha2  # (alpha^2 - 1) / alpha^2
    den = 1 - e * x * x
    J = e * (x * x - z * z) / den  # eq. 2.23
    L = (alpha2 - 1) * e * (1 - m * m)  # eq. 2.24
    # eq. 2.25: (x^2 + z^2 - m (2 x z - m) - 1) = -g, the Gram determinant of (r_hat, u_i, u_j)
    M = -(alpha2 - 1) * e * p.g / den
    return np.stack(
        [
            J * (L + 4) / 16,  # eq. 2.17
            -(J + 2) + M * (L + 8) / 8,  # eq. 2.18
            -J * (L + 6) / 2,  # eq. 2.19
            -M * (L + 4),  # eq. 2.20
            J * L,  # eq. 2.21
            2 * M * L,  # eq. 2.22
        ],
        axis=-1,
    )


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
    """y_min from f truncated at linear or quadratic order (eq. 2.26, stable root form).

    Where the truncated root misses the physical interval (-1/2, 1/2) the truncation has
    failed; we then use y = 0 (lambda = 1/2, the Cleaver value), still an upper bound on sigma.
    A quadratic without real roots falls back to the linear root.
    """
    q0, q1, q2 = q[:, 0], q[:, 1], q[:, 2]
    y = -q0 / q1
    if order == 2:
        # root that tends to -q0/q1 as q2 -> 0; q1 < 0 always (see docs), so no cancellation
        disc = q1 * q1 - 4 * q0 * q2
        with np.errstate(invalid="ignore"):
            y = np.where(disc >= 0, -2 * q0 / (q1 + np.copysign(np.sqrt(disc), q1)), y)
    return np.where(np.abs(y) < 0.5, y, 0.0)


def _lambda_polynomial(p: _Pair) -> np.ndarray:
    """lambda_min from the chapter's quartic / quintic: the unique root in y in (-1/2, 1/2)."""
    q = _chapter_coefficients(p)
    y0 = _approx_y(q, 2)
    y = _safeguarded_newton(lambda t, idx: _polyval(q[idx], t), -0.5, 0.5, y0)
    return 0.5 + y


def _h_lambda_derivatives(p: _Pair, lam: np.ndarray):
    """dh/dlambda and d2h/dlambda2 of the closed form (C, P, Q are linear in lambda)."""
    x, z, m = p.x, p.z, p.m
    dC, dP, dQ = p.b_j**2 - p.b_i**2, -(p.a_i**2 - p.b_i**2), p.a_j**2 - p.b_j**2
    C, P, Q, Nn, Qd = _terms(p, lam)
    wx, wz, wm = 1 - x * x, 1 - z * z, 1 - m * m
    # first and second lambda-derivatives of the quadratics Nn, Qd and of w = 4 lam (1-lam)
    Nn1 = 2 * C * dC + dC * (P * wx + Q * wz) + C * (dP * wx + dQ * wz) + (dP * Q + P * dQ) * p.g
    Nn2 = 2 * dC * dC + 2 * dC * (dP * wx + dQ * wz) + 2 * dP * dQ * p.g
    Qd1 = 2 * C * dC + dC * (P + Q) + C * (dP + dQ) + (dP * Q + P * dQ) * wm
    Qd2 = 2 * dC * dC + 2 * dC * (dP + dQ) + 2 * dP * dQ * wm
    w, w1, w2 = 4 * lam * (1 - lam), 4 - 8 * lam, -8.0
    # h = w Nn / (C Qd): differentiate log h
    num, num1, num2 = w * Nn, w1 * Nn + w * Nn1, w2 * Nn + 2 * w1 * Nn1 + w * Nn2
    den, den1, den2 = C * Qd, dC * Qd + C * Qd1, 2 * dC * Qd1 + C * Qd2
    h = num / den
    h1 = (num1 - h * den1) / den
    h2 = (num2 - 2 * h1 * den1 - h * den2) / den
    return h1, h2


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


def _lambda(p: _Pair, method: str) -> np.ndarray:
    if method == "exact":
        return _lambda_exact(p)
    if method in ("gaussian", "cleaver"):
        return np.full(len(p.r), 0.5)
    return 0.5 + _approx_y(_chapter_coefficients(p), 1 if method == "linear" else 2)


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
    Uses the envelope theorem at lambda_min (exact) or lambda = 1/2 (gaussian, cleaver);
    "linear"/"quadratic" are not supported (their lambda depends on the configuration).
    """
    _check_method(method, GRADIENT_METHODS)
    p = _validate(a_i, b_i, a_j, b_j, r_hat, u_i, u_j)
    _check_validity(p, method)
    sigma, d_r, d_ui, d_uj = _sigma_gradient(p, _lambda(p, method))
    vec = p.shape + (p.dim,)
    return sigma.reshape(p.shape), d_r.reshape(vec), d_ui.reshape(vec), d_uj.reshape(vec)


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
