"""Order parameters: closed-form crystals, the Legendre addition theorem as a second
implementation of 3D Q6, freud (float32) Hexatic / Steinhardt / Nematic, and bad input."""

import math
from itertools import product

import freud
import numpy as np
import pytest
from numpy.polynomial import legendre

from jamflow.analysis.order import (BondOrder, TranslationalOrder, first_minimum, neighbour_rdf, particle_bond_order,
                                    translational_order)
from jamflow.model.nematic import Nematic
from jamflow.analysis.structure import fcc_packing, rms_contact_distance, triangular_packing
from jamflow.model.box import Box
from jamflow.model.packing import Packing, random_packing
from jamflow.model.sizes import parse_sizes


def p6(x):
    return legendre.legval(x, [0, 0, 0, 0, 0, 0, 1])


def cubic_packing(n, dim):
    pos = np.array(list(product(range(n), repeat=dim)), float)
    return Packing(pos, np.ones(len(pos)), Box.cube(n, dim))


def gas(n, dim, phi, seed, gamma=0.0):
    p = random_packing(n, dim, parse_sizes("mono"), phi, seed)
    return p.with_positions(p.positions, p.box.with_shear_strain(gamma))


# --- closed forms --------------------------------------------------------------------------
@pytest.mark.parametrize("tilted", [False, True])
def test_triangular_crystal_has_q6_one_and_g_zero(tilted):
    """Seed section 4.2-4.3: perfect hexagonal order, Q6 global = local = 1; G = 0."""
    p = triangular_packing(12, 12, tilted=tilted)
    rdf = neighbour_rdf(p)
    r_min = first_minimum(rdf)
    assert 1.0 < r_min < math.sqrt(3)
    res = BondOrder().compute(p)
    assert res.global_order == pytest.approx(1.0, abs=1e-12)
    assert res.local_order == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_array_equal(res.n_neighbours, 6)
    g = translational_order(rdf)
    assert g.G == 0.0 and g.r_max == pytest.approx(1.0, abs=rdf.dr)


def test_square_lattice_has_no_sixfold_but_full_fourfold_order():
    """Four bonds at 0, 90, 180, 270 degrees: sum exp(6 i theta) = 1 - 1 + 1 - 1 = 0; l = 4 gives 1."""
    p = cubic_packing(10, 2)
    assert BondOrder().compute(p).local_order == pytest.approx(0.0, abs=1e-12)
    four = BondOrder(l=4).compute(p)
    assert four.global_order == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("lattice,expected,bonds", [
    ("fcc", 0.57452, (12, {1.0: 12, 0.5: 48, 0.0: 24, -0.5: 48, -1.0: 12})),
    ("sc", 0.35355, (6, {1.0: 6, 0.0: 24, -1.0: 6})),
])
def test_3d_crystals_have_the_textbook_q6(lattice, expected, bonds):
    """Closed form by the addition theorem, q6^2 = n^-2 sum_jk P6(cos gamma_jk) over the bond
    pairs (cosines: multiplicities), and the published values (Steinhardt, Nelson, Ronchetti,
    PRB 28, 784 (1983), Table I: FCC 0.57452, SC 0.35355)."""
    p = fcc_packing(4) if lattice == "fcc" else cubic_packing(6, 3)
    n, pairs = bonds
    closed = math.sqrt(sum(m * p6(c) for c, m in pairs.items()) / n**2)
    assert closed == pytest.approx(expected, abs=5e-6)
    res = BondOrder().compute(p)
    np.testing.assert_array_equal(res.n_neighbours, n)
    assert res.global_order == pytest.approx(closed, rel=1e-12)
    assert res.local_order == pytest.approx(closed, rel=1e-12)


# --- second implementations -------------------------------------------------------------------
def test_local_q6_in_3d_matches_the_legendre_addition_theorem():
    """q6(i)^2 = n_i^-2 sum_{j,k} P6(rhat_ij . rhat_ik): no spherical harmonics involved."""
    p = gas(120, 3, 0.15, 3, gamma=0.3)
    r_cut = 1.5
    res = BondOrder(r_min=r_cut / rms_contact_distance(p.diameters)).compute(p)
    i, j = np.nonzero(~np.eye(p.n, dtype=bool))
    dr = p.box.minimum_image(p.positions[j] - p.positions[i])
    r = np.linalg.norm(dr, axis=1)
    q2 = np.zeros(p.n)
    for a in range(p.n):
        u = dr[(i == a) & (r < r_cut)]
        u = u / np.linalg.norm(u, axis=1)[:, None]
        q2[a] = p6(u @ u.T).sum() / len(u) ** 2 if len(u) else np.nan
    have = ~np.isnan(q2)
    assert res.n_isolated == np.sum(~have) > 0
    np.testing.assert_allclose(res.magnitudes[have], np.sqrt(q2[have]), rtol=1e-11)
    assert res.local_order == pytest.approx(math.sqrt(np.mean(q2[have])), rel=1e-12)


def _freud_neighbours(p, r_cut):
    fbox = p.box.to_freud()
    pts = p.positions if p.dim == 3 else np.column_stack([p.positions, np.zeros(p.n)])
    return (fbox, fbox.wrap(pts.astype(np.float32))), {"r_max": r_cut, "exclude_ii": True}


def _assert_no_pair_near(p, r_cut):
    i, j = np.triu_indices(p.n, 1)
    r = np.linalg.norm(p.box.minimum_image(p.positions[i] - p.positions[j]), axis=1)
    assert np.min(np.abs(r - r_cut)) > 1e-4  # float32 cannot move a pair across the cutoff


def test_2d_q6_matches_freud_hexatic():
    """Per-particle psi_6 differs by up to ~1.2e-4 (measured; worst for one-neighbour particles,
    whose psi_6 is a single float32 bond angle times 6); the averages agree to ~1e-5."""
    p = gas(300, 2, 0.5, 8, gamma=0.35)
    r_cut = 1.3
    _assert_no_pair_near(p, r_cut)
    q, n = particle_bond_order(p, r_cut)
    hexatic = freud.order.Hexatic(k=6)
    hexatic.compute(*_freud_neighbours(p, r_cut))
    have = n > 0
    assert np.all(np.isnan(hexatic.particle_order[~have]))  # freud's NaN for particles without neighbours
    np.testing.assert_allclose(q[have, 0], hexatic.particle_order[have], atol=3e-4)
    res = BondOrder(r_min=r_cut / rms_contact_distance(p.diameters)).compute(p)
    ref = hexatic.particle_order[have]
    assert res.global_order == pytest.approx(abs(ref.mean()), abs=2e-5)
    assert res.local_order == pytest.approx(np.abs(ref).mean(), abs=2e-5)


def test_3d_q6_matches_freud_steinhardt():
    p = gas(300, 3, 0.15, 6, gamma=0.2)
    r_cut = 1.4
    _assert_no_pair_near(p, r_cut)
    res = BondOrder(r_min=r_cut / rms_contact_distance(p.diameters)).compute(p)
    st = freud.order.Steinhardt(l=6)
    st.compute(*_freud_neighbours(p, r_cut))
    have = res.n_neighbours > 0
    assert res.n_isolated > 0 and np.all(np.isnan(st.particle_order[~have]))  # freud's NaN pitfall
    np.testing.assert_allclose(res.magnitudes[have], st.particle_order[have], atol=2e-5)
    # freud pitfall: one particle without neighbours makes the system-wide order NaN. jamflow
    # leaves such particles out; the same average over freud's q_lm of the others agrees.
    assert np.isnan(st.order)
    qlm = np.asarray(st.particle_harmonics, complex)[have]
    ref = math.sqrt(4 * math.pi / 13 * np.sum(np.abs(qlm.mean(axis=0)) ** 2))
    assert res.global_order == pytest.approx(ref, abs=2e-5)


# --- nematic -------------------------------------------------------------------------------
@pytest.mark.parametrize("dim", [2, 3])
def test_aligned_rods_have_p2_one(dim):
    axis = np.arange(1, dim + 1) / np.linalg.norm(np.arange(1, dim + 1))
    signs = np.where(np.arange(50) % 2, 1.0, -1.0)[:, None]  # head and tail are equivalent
    res = Nematic().compute(signs * axis)
    assert res.p2 == pytest.approx(1.0, abs=1e-14)
    assert abs(res.director @ axis) == pytest.approx(1.0, abs=1e-14)


def test_2d_nematic_closed_form_and_freud():
    """Rods at +-theta0 about x: P2 = <cos 2 theta> = cos 2 theta0 (2D form). freud's 3D tensor on
    the same in-plane rods gives (3 P2_2D + 1) / 4."""
    theta0 = 0.3
    angles = np.tile([theta0, -theta0], 20)
    res = Nematic().compute(angles)
    assert res.p2 == pytest.approx(math.cos(2 * theta0), rel=1e-14)
    np.testing.assert_allclose(np.abs(res.director), [1.0, 0.0], atol=1e-14)
    nem = freud.order.Nematic()
    nem.compute(np.column_stack([np.cos(angles), np.sin(angles), np.zeros(len(angles))]).astype(np.float32))
    assert nem.order == pytest.approx((3 * res.p2 + 1) / 4, abs=1e-6)


def test_3d_nematic_matches_freud_and_vanishes_for_random_axes():
    rng = np.random.default_rng(0)
    u = rng.normal(size=(20000, 3))
    res = Nematic().compute(u)
    assert res.p2 < 5 / math.sqrt(len(u))  # seed: P2 ~ 1/sqrt(N) without nematic order
    tilted = u + np.array([0.0, 0.0, 2.0])
    mine = Nematic().compute(tilted)
    nem = freud.order.Nematic()
    nem.compute((tilted / np.linalg.norm(tilted, axis=1)[:, None]).astype(np.float32))
    assert mine.p2 == pytest.approx(nem.order, abs=1e-5)
    assert abs(mine.director @ np.asarray(nem.director, float)) == pytest.approx(1.0, abs=1e-5)


@pytest.mark.parametrize("dim", [2, 3])
def test_nematic_of_a_packing_uses_its_directors(dim):
    """Aligned ellipses/spheroids: P2 = 1; uniformly random orientations (the random start):
    P2 ~ 1/sqrt(N); disks and spheres have no axis and are refused."""
    from jamflow.model.shapes import Ellipsoid

    n = 2000
    p = random_packing(n, dim, parse_sizes("bi:1.4:0.5"), 0.3, 1, shape=Ellipsoid(1.5))
    assert Nematic().compute(p).p2 < 5 / math.sqrt(n)
    aligned = np.zeros(n) + 0.7 if dim == 2 else np.tile([np.cos(0.35), 0.0, 0.0, np.sin(0.35)], (n, 1))
    res = Nematic().compute(p.with_positions(p.positions, orientations=aligned))
    assert res.p2 == pytest.approx(1.0, abs=1e-12)
    expected = [np.cos(0.7), np.sin(0.7)] + [0.0] * (dim - 2)  # 3D: body x turned by 0.7 about z
    assert abs(res.director @ expected) == pytest.approx(1.0, abs=1e-12)
    with pytest.raises(ValueError, match="needs particles with an axis"):
        Nematic().compute(random_packing(20, dim, parse_sizes("mono"), 0.3, 1))


# --- r_min, G, errors ----------------------------------------------------------------------------
def test_first_minimum_refuses_a_gas():
    p = gas(1500, 2, 0.05, 2)
    with pytest.raises(ValueError, match="r_min"):
        BondOrder().compute(p)
    with pytest.raises(ValueError, match="r_min"):
        TranslationalOrder().compute(p)


def test_first_minimum_of_a_synthetic_liquid_curve():
    """Smoothed g = 1 + 2 exp(-(r-1)^2/0.02) - 0.6 exp(-(r-1.45)^2/0.02) + noise-free: the first
    minimum is where its derivative vanishes (found by bisection here)."""
    from jamflow.analysis.structure import RDFResult

    edges = np.arange(0, 3.0001, 0.005)
    r = 0.5 * (edges[1:] + edges[:-1])

    def g(x):
        return 1 + 2 * np.exp(-(x - 1) ** 2 / 0.02) - 0.6 * np.exp(-(x - 1.45) ** 2 / 0.02)

    counts = np.full(len(r), 1e8)
    rdf = RDFResult(edges, g(r), counts, counts / g(r), np.empty(0), np.zeros((0, 0, len(r))), np.ones(1), 1)
    lo, hi = 1.1, 1.6
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if g(mid + 1e-7) < g(mid) else (lo, mid)
    assert first_minimum(rdf, smooth=1e-6) == pytest.approx(lo, abs=0.005)


def test_bond_order_bad_input():
    p = triangular_packing(8, 8)
    with pytest.raises(ValueError, match="even"):
        particle_bond_order(p, 1.2, l=5)
    with pytest.raises(ValueError, match="positive"):
        BondOrder(r_min=-1.0)
    with pytest.raises(ValueError, match="no particle has a neighbour"):
        BondOrder(r_min=0.5).compute(p)
    with pytest.raises(ValueError, match="orientations"):
        Nematic().compute(np.zeros((3, 4)))
    with pytest.raises(ValueError, match="non-zero"):
        Nematic().compute(np.zeros((3, 2)))
