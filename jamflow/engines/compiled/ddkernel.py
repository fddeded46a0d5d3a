"""Disks and spheres with the linear spring in double-double (docs/guide/precision.md): overlaps, energy, forces
and the virial of positions hi + lo in a periodic orthogonal box whose sides are hi + lo.

The arithmetic is ``jamflow.model.ddouble``, compiled from its own source: each function is
re-bound to this module's namespace (``_bound``), so that the compiled functions call one another
through numba dispatchers. The law is chapter eq. 2.1 at alpha = 2, V = eps/2 (1 - s)^2 with
s = r / sigma (``jamflow.model.potentials.spring_energy_force``), in double-double: with the
relative overlap x = (sigma - r) / sigma, V = eps x^2 / 2 and the force on i is eps x / (sigma r)
(r_i - r_j). tests/test_ddouble.py checks the kernel against that law evaluated in exact rational
arithmetic. sigma = (a_i + a_j) / 2 is formed exactly (two_sum). Units: eps, diameter.
"""

from __future__ import annotations

import math
import types
from typing import NamedTuple

import numpy as np

from jamflow.engines.compiled import jit
from jamflow.model import ddouble
from jamflow.model.ddouble import _SPLITTER  # noqa: F401  (a global of the re-bound functions)


def _bound(fn):
    """``fn`` with this module's globals, compiled when numba starts."""
    return jit(types.FunctionType(fn.__code__, globals(), fn.__name__, fn.__defaults__))


two_sum = _bound(ddouble.two_sum)
fast_two_sum = _bound(ddouble.fast_two_sum)
split = _bound(ddouble.split)
two_prod = _bound(ddouble.two_prod)
dd_add = _bound(ddouble.dd_add)
dd_sub = _bound(ddouble.dd_sub)
dd_mul = _bound(ddouble.dd_mul)
dd_mul_d = _bound(ddouble.dd_mul_d)
dd_div = _bound(ddouble.dd_div)
dd_sqrt = _bound(ddouble.dd_sqrt)


@jit
def separation(xh, xl, lh, ll, i, j, a):
    """Component a of the minimum image r_i - r_j in double-double."""
    dh, dl = dd_sub(xh[i, a], xl[i, a], xh[j, a], xl[j, a])
    k = float(math.floor(dh / lh[a] + 0.5))
    if k != 0.0:
        sh, sl = dd_mul_d(lh[a], ll[a], k)
        dh, dl = dd_sub(dh, dl, sh, sl)
    return dh, dl


@jit
def spring_pairs(xh, xl, lh, ll, diameters, i, j, epsilon, bilateral, fh, fl, wh, wl, oh, ol):
    """Over the candidate pairs (i[p], j[p]): overlaps sigma - r into (oh, ol) (negative: apart),
    forces on every particle into (fh, fl) (N, d), the virial sum r_a f_b into (wh, wl) (d, d);
    returns the energy (hi, lo). All outputs are overwritten. ``bilateral``: every pair given is a
    spring of the contact network, apart or not (the same quadratic law continued to s > 1)."""
    d = xh.shape[1]
    fh[:] = 0.0
    fl[:] = 0.0
    wh[:] = 0.0
    wl[:] = 0.0
    eh, el = 0.0, 0.0
    drh = np.zeros(3)
    drl = np.zeros(3)
    for p in range(i.shape[0]):
        a, b = i[p], j[p]
        r2h, r2l = 0.0, 0.0
        for c in range(d):
            drh[c], drl[c] = separation(xh, xl, lh, ll, a, b, c)
            qh, ql = dd_mul(drh[c], drl[c], drh[c], drl[c])
            r2h, r2l = dd_add(r2h, r2l, qh, ql)
        sh, sl = two_sum(diameters[a], diameters[b])
        sh, sl = 0.5 * sh, 0.5 * sl
        rh, rl = dd_sqrt(r2h, r2l)
        oh[p], ol[p] = dd_sub(sh, sl, rh, rl)
        if oh[p] <= 0.0 and not bilateral:
            continue
        xh_, xl_ = dd_div(oh[p], ol[p], sh, sl)  # x = 1 - s
        vh, vl = dd_mul(xh_, xl_, xh_, xl_)
        vh, vl = dd_mul_d(vh, vl, 0.5 * epsilon)
        eh, el = dd_add(eh, el, vh, vl)
        kh, kl = dd_mul_d(xh_, xl_, epsilon)
        qh, ql = dd_mul(sh, sl, rh, rl)
        frh, frl = dd_div(kh, kl, qh, ql)  # -dV/dr / r
        for c in range(d):
            gh, gl = dd_mul(frh, frl, drh[c], drl[c])
            fh[a, c], fl[a, c] = dd_add(fh[a, c], fl[a, c], gh, gl)
            fh[b, c], fl[b, c] = dd_sub(fh[b, c], fl[b, c], gh, gl)
            for e in range(d):
                qh, ql = dd_mul(drh[e], drl[e], gh, gl)
                wh[e, c], wl[e, c] = dd_add(wh[e, c], wl[e, c], qh, ql)
    return eh, el


class SpringDD(NamedTuple):
    """What ``spring_dd`` returns: every quantity as a (hi, lo) pair of float64 arrays/numbers."""

    i: np.ndarray  # (P,) candidate pairs
    j: np.ndarray
    overlap: tuple  # (P,) sigma_ij - r_ij, diameters (> 0: in contact)
    energy: tuple  # total energy, eps
    forces: tuple  # (N, d), eps / diameter
    virial: tuple  # (d, d) sum over pairs r_a f_b, eps


def spring_dd(xh, xl, lh, ll, diameters, i, j, epsilon: float, bilateral: bool = False) -> SpringDD:
    """Evaluate ``spring_pairs`` on positions xh + xl (N, d) in the orthogonal periodic box of sides
    lh + ll (d,), over the candidate pairs i, j (``bilateral``: a fixed contact network)."""
    n, d = xh.shape
    i, j = np.ascontiguousarray(i, np.int64), np.ascontiguousarray(j, np.int64)
    f = np.zeros((2, n, d))
    w = np.zeros((2, d, d))
    o = np.zeros((2, len(i)))
    args = [np.ascontiguousarray(v, float) for v in (xh, xl, lh, ll, diameters)]
    eh, el = spring_pairs(*args, i, j, float(epsilon), bool(bilateral), f[0], f[1], w[0], w[1], o[0], o[1])
    return SpringDD(i, j, (o[0], o[1]), (eh, el), (f[0], f[1]), (w[0], w[1]))
