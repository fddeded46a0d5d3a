"""Correlation functions and lengths: synthetic envelopes with known xi, a perfect crystal,
an all-pairs brute-force implementation, freud's CorrelationFunction (float32), and a small
jammed packing (jamflow.protocols.compression) for G and the g(r) envelope."""

import math

import freud
import numpy as np
import pytest

from jamflow.analysis.correlations import (BondCorrelation, envelope_fit, fit_exponential,
                                           rdf_correlation_length)
from jamflow.analysis.order import TranslationalOrder, particle_bond_order
from jamflow.analysis.structure import rms_contact_distance, triangular_packing
from jamflow.model.packing import random_packing
from jamflow.model.sizes import parse_sizes


def gas(n, dim, phi, seed, gamma=0.0, sizes="mono"):
    p = random_packing(n, dim, parse_sizes(sizes), phi, seed)
    return p.with_positions(p.positions, p.box.with_shear_strain(gamma))


# --- fits ----------------------------------------------------------------------------------
def test_exponential_fit_recovers_a_pure_exponential():
    r = np.linspace(1, 8, 9)
    fit = fit_exponential(r, 0.7 * np.exp(-r / 2.3))
    assert fit.xi == pytest.approx(2.3, rel=1e-12)
    assert fit.amplitude == pytest.approx(0.7, rel=1e-12)


def test_envelope_of_a_damped_oscillation():
    """Maxima of exp(-r/xi) cos(2 pi r) lie on A' exp(-r/xi) (constant phase shift), so the
    envelope fit returns xi up to the grid's sampling of the maxima."""
    r = np.arange(0, 12, 1e-3)
    y = np.exp(-r / 1.8) * np.cos(2 * math.pi * r)
    fit = envelope_fit(r, y, np.full(len(r), 1e-6), r_from=0.5)
    assert len(fit.r_points) >= 8
    assert fit.xi == pytest.approx(1.8, rel=1e-4)


def test_envelope_stops_at_the_noise_floor():
    r = np.arange(0, 12, 1e-3)
    y = np.exp(-r / 1.8) * np.cos(2 * math.pi * r)
    fit = envelope_fit(r, y, np.full(len(r), 0.01), r_from=0.5)
    assert np.all(fit.y_points > 0.03) and fit.r_points.max() < 7


def test_too_few_maxima_give_nan_with_a_reason():
    fit = fit_exponential([1.0, 2.0], [0.5, 0.2])
    assert math.isnan(fit.xi) and "need 3" in fit.reason


# --- q6 correlations -----------------------------------------------------------------------------
def test_perfect_crystal_is_correlated_at_every_distance():
    res = BondCorrelation(dr=0.1).compute(triangular_packing(16, 16, tilted=True))
    full = res.counts > 0
    np.testing.assert_allclose(res.complex_corr[full], 1.0, atol=1e-12)
    np.testing.assert_allclose(res.magnitude_corr[full], 1.0, atol=1e-12)
    assert res.baseline == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(res.c[full], 0.0, atol=1e-12)


def _brute_force(p, r_cut, edges, l=6):
    """All ordered pairs i != j by the minimum image, one loop, no jamflow pair search."""
    q, n = particle_bond_order(p, r_cut, l)
    have = n > 0
    scale = rms_contact_distance(p.diameters)
    num, mag, cnt = np.zeros(len(edges) - 1), np.zeros(len(edges) - 1), np.zeros(len(edges) - 1)
    pairs = []
    for a in range(p.n):
        for b in range(p.n):
            if a == b or not (have[a] and have[b]):
                continue
            r = np.linalg.norm(p.box.minimum_image(p.positions[a] - p.positions[b])) / scale
            prod = np.vdot(q[b], q[a]).real  # Q_a . conj(Q_b)
            pairs.append(prod)
            k = np.searchsorted(edges, r, side="right") - 1
            if 0 <= k < len(cnt):
                num[k] += prod
                mag[k] += np.linalg.norm(q[a]) * np.linalg.norm(q[b])
                cnt[k] += 1
    return num / cnt, mag / cnt, np.mean(pairs)


@pytest.mark.parametrize("dim,gamma", [(2, 0.3), (3, 0.15)])
def test_bond_correlation_matches_brute_force(dim, gamma):
    p = gas(70, dim, 0.35, 4, gamma=gamma, sizes="bi:1.4:0.5")
    scale = rms_contact_distance(p.diameters)
    res = BondCorrelation(r_min=1.3, dr=0.25).compute(p)
    cplx, magn, base = _brute_force(p, 1.3 * scale, res.edges)
    np.testing.assert_allclose(res.complex_corr, cplx, rtol=1e-11, atol=1e-13)
    np.testing.assert_allclose(res.magnitude_corr, magn, rtol=1e-11)
    assert res.baseline == pytest.approx(base, rel=1e-11)


def test_bond_correlation_matches_freud_correlation_function():
    p = gas(400, 2, 0.5, 12, gamma=0.25)
    res = BondCorrelation(r_min=1.35, dr=0.5).compute(p)
    q, n = particle_bond_order(p, 1.35)
    have = n > 0  # particles without neighbours have no q6: give freud only the others
    fbox = p.box.to_freud()
    pts = fbox.wrap(np.column_stack([p.positions, np.zeros(p.n)]).astype(np.float32))[have]
    cf = freud.density.CorrelationFunction(bins=len(res.counts), r_max=res.edges[-1])
    cf.compute((fbox, pts), values=q[have, 0].astype(np.complex64),
               neighbors={"r_max": res.edges[-1], "exclude_ii": True})
    np.testing.assert_allclose(res.counts * 2, cf.bin_counts, atol=4)  # freud counts ordered pairs
    np.testing.assert_allclose(res.complex_corr, np.real(cf.correlation), atol=1e-4)


# --- a small jammed packing ------------------------------------------------------------------------
@pytest.fixture(scope="module")
def jammed():
    from jamflow.protocols.compression import jam

    return jam(n=128, dim=2, sizes="bi:1.4:0.5", seed=3).packing


def test_jammed_disks_have_a_finite_translational_order(jammed):
    """Seed section 4.3: G is zero for crystals (test_order.py) and finite for jammed packings."""
    g = TranslationalOrder().compute(jammed)
    assert g.g_min > 0.1 and 0.005 < g.G < 0.5
    assert 1.1 < g.r_min < 1.6 and g.r_max < g.r_min
    corr = BondCorrelation().compute(jammed)
    assert corr.r_min == pytest.approx(g.r_min, abs=0.05)  # both from the first minimum of g(r)
    assert abs(corr.baseline) < 0.05  # an amorphous packing has no global hexatic phase


def test_rdf_envelope_on_a_synthetic_liquid():
    """g = 1 + exp(-r/xi) cos(2 pi r) with negligible noise: rdf_correlation_length returns xi
    (smoothing of 0.05 damps each maximum by the same factor, so xi is unchanged)."""
    from jamflow.analysis.structure import RDFResult

    edges = np.arange(0, 10.0001, 0.01)
    r = 0.5 * (edges[1:] + edges[:-1])
    g = 1 + np.exp(-r / 1.5) * np.cos(2 * math.pi * r)
    ideal = np.full(len(r), 1e12)
    rdf = RDFResult(edges, g, g * ideal, ideal, np.empty(0), np.zeros((0, 0, len(r))), np.ones(1), 1)
    fit = rdf_correlation_length(rdf, r_min=1.5)
    assert len(fit.r_points) == 8 and fit.r_points[0] > 1.5
    assert fit.xi == pytest.approx(1.5, rel=2e-3)
