"""Double-double arithmetic and the double-double spring kernel against exact rational arithmetic
(docs/guide/precision.md): ``fractions.Fraction`` for every sum and product, square roots to 2^-200 by integer
isqrt, and the spring law of ``jamflow.model.potentials`` evaluated on Fractions."""

import math
from fractions import Fraction

import numpy as np
import pytest

from jamflow.engines.compiled.ddkernel import spring_dd
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.model import ddouble as dd
from jamflow.model.box import Box
from jamflow.model.packing import Packing
from jamflow.model.potentials import SpringParams, spring_energy_force

ROOT_BITS = 200


def exact(h, lo=0.0) -> Fraction:
    return Fraction(float(h)) + Fraction(float(lo))


def fsqrt(q: Fraction) -> Fraction:
    """sqrt(q) to 2^-ROOT_BITS (relative, for q ~ 1)."""
    return Fraction(math.isqrt(q.numerator * 4**ROOT_BITS // q.denominator), 2**ROOT_BITS)


def relerr(value: Fraction, ref: Fraction) -> float:
    return abs(float((value - ref) / ref)) if ref else abs(float(value))


def randoms(seed, n=200):
    rng = np.random.default_rng(seed)
    return rng.standard_normal(n) * 10.0 ** rng.integers(-12, 12, n)


def test_error_free_transformations_are_exact():
    a, b = randoms(1), randoms(2)
    for x, y in zip(a, b):
        s, e = dd.two_sum(x, y)
        assert exact(s, e) == Fraction(x) + Fraction(y) and s == x + y
        p, e = dd.two_prod(x, y)
        assert exact(p, e) == Fraction(x) * Fraction(y) and p == x * y
        big, small = (x, y) if abs(x) >= abs(y) else (y, x)
        s, e = dd.fast_two_sum(big, small)
        assert exact(s, e) == Fraction(big) + Fraction(small)
        hi, lo = dd.split(x)
        assert Fraction(hi) + Fraction(lo) == Fraction(x)


def test_double_double_operations_agree_with_fractions_to_1e_30():
    rng = np.random.default_rng(3)
    worst = 0.0
    for _ in range(300):
        ah, bh = rng.uniform(0.5, 2.0, 2) * 10.0 ** rng.integers(-5, 5, 2)
        al, bl = ah * rng.uniform(-1, 1) * 2**-53, bh * rng.uniform(-1, 1) * 2**-53
        ah, al = dd.fast_two_sum(ah, al)
        bh, bl = dd.fast_two_sum(bh, bl)
        a, b = exact(ah, al), exact(bh, bl)
        for got, ref in ((dd.dd_add(ah, al, bh, bl), a + b), (dd.dd_sub(ah, al, bh, bl), a - b),
                         (dd.dd_mul(ah, al, bh, bl), a * b), (dd.dd_div(ah, al, bh, bl), a / b),
                         (dd.dd_mul_d(ah, al, bh), a * Fraction(bh)), (dd.dd_sqrt(ah, al), fsqrt(a))):
            if ref:
                worst = max(worst, relerr(exact(*got), ref))
    assert worst < 1e-30, worst
    # the same source elementwise on arrays gives the same bits as on scalars
    x, y = randoms(4, 50), randoms(5, 50)
    arr = dd.dd_mul(x, 0 * x, y, 0 * y)
    assert all(arr[0][k] == dd.dd_mul(x[k], 0.0, y[k], 0.0)[0] for k in range(50))


def exact_spring(xh, xl, lh, ll, diameters, eps=1.0):
    """Energy, forces, virial and overlaps of every pair in exact arithmetic: the law of
    ``potentials.spring_energy_force`` on Fractions, minimum image by rounding."""
    n, d = xh.shape
    x = [[exact(xh[k, a], xl[k, a]) for a in range(d)] for k in range(n)]
    box = [exact(lh[a], ll[a]) for a in range(d)]
    law = SpringParams(Fraction(2), Fraction(eps))
    forces = [[Fraction(0)] * d for _ in range(n)]
    virial = [[Fraction(0)] * d for _ in range(d)]
    energy, overlaps = Fraction(0), {}
    for i in range(n):
        for j in range(i + 1, n):
            dr = [x[i][a] - x[j][a] for a in range(d)]
            dr = [v - box[a] * round(v / box[a]) for a, v in enumerate(dr)]
            r = fsqrt(sum(v * v for v in dr))
            sigma = (Fraction(diameters[i]) + Fraction(diameters[j])) / 2
            overlaps[(i, j)] = sigma - r
            if r >= sigma:
                continue
            v, dv = spring_energy_force(r / sigma, law)
            energy += v
            for a in range(d):
                fa = -dv / (sigma * r) * dr[a]
                forces[i][a] += fa
                forces[j][a] -= fa
                for b in range(d):
                    virial[b][a] += dr[b] * fa
    return energy, forces, virial, overlaps


@pytest.mark.parametrize("n, dim, seed", [(12, 2, 0), (16, 2, 1), (8, 3, 2)])
def test_double_double_spring_agrees_with_exact_arithmetic(n, dim, seed):
    rng = np.random.default_rng(seed)
    diameters = np.where(rng.random(n) < 0.5, 1.0, 1.4)
    length = ((np.pi / 4 if dim == 2 else np.pi / 6) * np.sum(diameters**dim) / 0.9) ** (1 / dim)
    xh = rng.random((n, dim)) * length
    xl = xh * rng.uniform(-1, 1, (n, dim)) * 2**-53
    xh, xl = dd.fast_two_sum(xh, xl)
    lh = np.full(dim, length)
    ll = lh * 0.3 * 2**-53
    i, j = np.triu_indices(n, 1)
    got = spring_dd(xh, xl, lh, ll, diameters, i, j, 1.0)
    energy, forces, virial, overlaps = exact_spring(xh, xl, lh, ll, diameters)
    assert sum(1 for o in overlaps.values() if o > 0) >= n  # a dense, overlapping configuration
    fscale = max(abs(v) for row in forces for v in row)
    assert relerr(exact(*got.energy), energy) < 1e-30
    ferr = max(abs(float(exact(got.forces[0][k, a], got.forces[1][k, a]) - forces[k][a])) for k in range(n)
               for a in range(dim))
    assert ferr / float(fscale) < 1e-30
    wscale = max(abs(v) for row in virial for v in row)
    werr = max(abs(float(exact(got.virial[0][a, b], got.virial[1][a, b]) - virial[a][b])) for a in range(dim)
               for b in range(dim))
    assert werr / float(wscale) < 1e-30
    oerr = max(abs(float(exact(got.overlap[0][p], got.overlap[1][p]) - overlaps[(i[p], j[p])]))
               for p in range(len(i)))
    assert oerr < 1e-30  # overlaps in diameters


@pytest.mark.parametrize("delta", [1e-15, 3e-16, 1e-17])
def test_two_disks_at_overlaps_float64_cannot_resolve(delta):
    """Closed form: two unit disks at distance 1 - delta (delta not representable beside a coordinate
    of 7.3): overlap delta, force eps delta (sigma = 1), pressure delta (1 - delta) / (2 V)."""
    box_side = 20.0
    x0 = 7.3
    # x1 = x0 + 1 - delta exactly, as hi + lo
    x1h, x1l = dd.dd_add(*dd.two_sum(x0, 1.0), -delta, 0.0)
    xh = np.array([[x0, 5.0], [x1h, 5.0]])
    xl = np.array([[0.0, 0.0], [x1l, 0.0]])
    got = spring_dd(xh, xl, np.full(2, box_side), np.zeros(2), np.ones(2), [0], [1], 1.0)

    d_exact = 1 - (exact(x1h, x1l) - Fraction(x0))  # the overlap of the positions as stored
    assert abs(float(d_exact) - delta) < 1e-30  # the closed-form overlap
    assert relerr(exact(got.overlap[0][0], got.overlap[1][0]), d_exact) < 1e-28
    assert relerr(exact(got.forces[0][1, 0], got.forces[1][1, 0]), d_exact) < 1e-28  # pushes disk 1 along +x
    pressure = d_exact * (1 - d_exact) / (2 * Fraction(box_side) ** 2)
    p_dd = exact(got.virial[0][0, 0], got.virial[1][0, 0]) / (2 * Fraction(box_side) ** 2)
    assert relerr(p_dd, pressure) < 1e-28
    # float64 (the numpy reference on the rounded positions) gets the overlap wrong by > 10 % or misses it
    packing = Packing(xh, np.ones(2), Box.cube(box_side, 2))
    ref = energy_forces_pressure(packing)
    assert abs(ref.forces[1, 0] / delta - 1) > 0.1
