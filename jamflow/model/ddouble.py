"""Double-double arithmetic: a number is an unevaluated sum hi + lo of two float64 with
|lo| <= ulp(hi) / 2, about 106 significant bits (unit round-off ~ 2^-104 ~ 4.9e-32 for the
operations below; Hida, Li & Bailey, "Library for double-double and quad-double arithmetic"
(2000); Shewchuk, Discrete Comput. Geom. 18, 305 (1997) for the error-free transformations).

Error-free transformations (exact in IEEE round-to-nearest float64, without overflow):
- ``two_sum(a, b)`` -> (s, e), s = fl(a + b), s + e = a + b exactly (Knuth);
- ``fast_two_sum(a, b)`` -> the same when |a| >= |b| (Dekker);
- ``two_prod(a, b)`` -> (p, e), p = fl(a b), p + e = a b exactly, by Dekker's split of each factor
  into 26-bit halves (``split``; no FMA, so numpy, numba and plain Python give the same bits).

Every function is plain arithmetic on its arguments, so the same source runs on Python floats,
elementwise on numpy arrays, and compiled by numba (``jamflow.engines.compiled.ddkernel``).
Double-double values are passed as two arguments (hi, lo) and returned as tuples.
"""

from __future__ import annotations

EPS_DD = 2.0**-104  # relative round-off of the double-double operations here (~4.9e-32)
EPS_DOUBLE = 2.0**-52  # float64 machine epsilon (~2.2e-16)
_SPLITTER = 134217729.0  # 2^27 + 1


def two_sum(a, b):
    """(s, e): s = fl(a + b) and s + e = a + b exactly."""
    s = a + b
    bb = s - a
    e = (a - (s - bb)) + (b - bb)
    return s, e


def fast_two_sum(a, b):
    """(s, e) with s + e = a + b exactly, valid when |a| >= |b| (or a = 0)."""
    s = a + b
    e = b - (s - a)
    return s, e


def split(a):
    """(hi, lo), a = hi + lo exactly, each with at most 26 significant bits (Dekker)."""
    c = _SPLITTER * a
    hi = c - (c - a)
    return hi, a - hi


def two_prod(a, b):
    """(p, e): p = fl(a b) and p + e = a b exactly (Dekker's product)."""
    p = a * b
    ah, al = split(a)
    bh, bl = split(b)
    e = ((ah * bh - p) + ah * bl + al * bh) + al * bl
    return p, e


def dd_add(ah, al, bh, bl):
    """(a + b) in double-double (the accurate sum: two two_sums, then renormalised)."""
    s, e = two_sum(ah, bh)
    t, f = two_sum(al, bl)
    e = e + t
    s, e = fast_two_sum(s, e)
    e = e + f
    return fast_two_sum(s, e)


def dd_sub(ah, al, bh, bl):
    """(a - b) in double-double."""
    return dd_add(ah, al, -bh, -bl)


def dd_mul(ah, al, bh, bl):
    """(a b) in double-double."""
    p, e = two_prod(ah, bh)
    e = e + (ah * bl + al * bh)
    return fast_two_sum(p, e)


def dd_mul_d(ah, al, b):
    """(a b) for a double-double a and a float64 b."""
    p, e = two_prod(ah, b)
    e = e + al * b
    return fast_two_sum(p, e)


def dd_div(ah, al, bh, bl):
    """(a / b) in double-double: a float64 quotient and two correction terms."""
    q1 = ah / bh
    rh, rl = dd_sub(ah, al, *dd_mul_d(bh, bl, q1))
    q2 = rh / bh
    rh, rl = dd_sub(rh, rl, *dd_mul_d(bh, bl, q2))
    q3 = rh / bh
    q1, q2 = fast_two_sum(q1, q2)
    return dd_add(q1, q2, q3, 0.0)


def dd_sqrt(ah, al):
    """sqrt(a) in double-double for a > 0 (one Newton correction of the float64 root, Karp & Markstein)."""
    x = ah**0.5
    sh, sl = two_prod(x, x)
    rh = dd_sub(ah, al, sh, sl)[0]
    return fast_two_sum(x, rh / (2.0 * x))

