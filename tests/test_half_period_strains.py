"""Shear strains at half periods, gamma = k + 1/2 and its float64 neighbours, where the Lees-Edwards
fold changes sign (docs/hardening.md has the catalogue): the box folds into range and stays
reduced, the pair search finds every pair, contacts and floaters are those at gamma = 1/2, and
jam at gamma = 2.5 passes its checks."""

import numpy as np
import pytest
from conftest import run_jam

import jamflow
from jamflow.io.packing_file import read_attrs, read_checks


def half_period_strains():
    """gamma = +-(k + 1/2), k = 0..3, and its two float64 neighbours on each side."""
    strains = []
    for centre in (0.5, 1.5, 2.5, 3.5, -0.5, -1.5, -2.5, -3.5):
        below = np.nextafter(centre, -np.inf)
        above = np.nextafter(centre, np.inf)
        strains += [np.nextafter(below, -np.inf), below, centre, above, np.nextafter(above, np.inf)]
    return strains


HALF_PERIODS = half_period_strains()


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("side", [5.123456789, 7.3, 3.3333333333])
def test_a_half_period_strain_folds_into_range_and_stays_reduced(dim, side):
    # was: gamma = 2.5 (L = 5.123456789) folded to xy = -0.5000000000000002 L, outside [-L/2, L/2):
    # the reduced cell folded once more under its own reduction, and the pair search lost pairs
    from jamflow.model.box import Box

    for gamma in HALF_PERIODS:
        h = np.eye(dim) * side
        h[0, 1] = gamma * side
        if dim == 3:
            h[0, 2], h[1, 2] = -gamma * side, gamma * side
        box = Box(h)
        red, fold = box.reduction()
        assert all(-side / 2 <= t < side / 2 for t in red.tilts), (gamma, red.tilts)
        assert red.reduction()[0] is red, gamma  # reduced: its own reduction
        assert np.allclose(red.h, box.h @ fold, rtol=0, atol=1e-12 * np.abs(box.h).max())


def all_pairs_minimum_image(x, box, rmax):
    """(i, j) of every pair i < j whose shortest image over shifts of up to 5 cells of the
    *accumulated* cell (no reduction) is below rmax."""
    from itertools import product

    i, j = np.triu_indices(len(x), 1)
    dr = x[i] - x[j]
    shifts = np.array(list(product(range(-5, 6), repeat=box.dim)), float) @ box.h.T
    best = np.min(np.linalg.norm(dr[:, None, :] + shifts[None, :, :], axis=2), axis=1)
    keep = best < rmax
    return i[keep], j[keep]


@pytest.mark.parametrize("dim", [2, 3])
def test_pair_search_at_half_period_strains_matches_all_pairs(dim):
    # was: at gamma = k + 1/2 (and ulps off it) whole sets of pairs were missing -> "every particle is a floater"
    from jamflow.model.box import Box
    from jamflow.model.pairs import neighbor_pairs

    side = 5.123456789
    rng = np.random.default_rng(29)
    x = rng.uniform(0, side, (60 if dim == 2 else 80, dim))
    for gamma in HALF_PERIODS:
        box = Box.cube(side, dim).with_shear_strain(gamma)
        rmax = 0.45 * box.widths.min()
        i, j, image = neighbor_pairs(x, box, rmax)
        bi, bj = all_pairs_minimum_image(x, box, rmax)
        assert len(bi) > 20 and np.array_equal(i, bi) and np.array_equal(j, bj), gamma
        sep = x[i] - x[j] + image @ box.h.T
        assert np.all(np.linalg.norm(sep, axis=1) < rmax), gamma


@pytest.fixture(scope="module")
def half_period_packing():
    """A packing jammed through the API at gamma = 1/2 (N = 32)."""
    return jamflow.jam(n=32, seed=4, gamma=0.5).packing


def test_contacts_and_floaters_at_half_period_strains_are_those_at_one_half(half_period_packing):
    # was: a packing at gamma = 2.5 made through the API was "all floaters" to `jamflow modes`
    from jamflow.mechanics.checks import check_packing
    from jamflow.mechanics.contacts import Contacts

    base = Contacts().compute(half_period_packing)
    assert base.floater.sum() < half_period_packing.n / 2
    pairs = set(zip(base.i.tolist(), base.j.tolist()))
    for gamma in HALF_PERIODS:
        box = half_period_packing.box.with_shear_strain(gamma)
        packing = half_period_packing.with_positions(half_period_packing.positions, box=box)
        got = Contacts().compute(packing)
        assert np.array_equal(got.floater, base.floater) and set(zip(got.i.tolist(), got.j.tolist())) == pairs, gamma
        assert check_packing(packing).jammed, gamma


def test_jam_at_gamma_two_and_a_half_passes_its_checks(tmp_path, capsys):
    # was: exit 3, "not jammed: every particle is a floater (no contact network)", nothing written
    out = tmp_path / "g.h5"
    code, err = run_jam(tmp_path, capsys, "--n", "32", "--gamma", "2.5", "--out", str(out))
    assert code == 0, err
    checks = read_checks(out)
    assert checks.passed and checks.jammed
    assert read_attrs(out)["gamma"] == 2.5
