"""The float64 pair search (jamflow.model.pairs.neighbor_pairs) against brute force over every pair
and every periodic image, in orthogonal and strongly tilted cells, small and large."""

from itertools import product

import numpy as np
import pytest
from scipy.spatial import cKDTree

from jamflow.model.box import Box
from jamflow.model.pairs import candidate_pairs, neighbor_pairs


def sheared_cell(dim, side, fold):
    """A cell of the given side whose accumulated tilts are ``fold`` (several cell lengths)
    plus a fraction, and its reduced h known independently (h = reduced @ U^-1)."""
    red = np.eye(dim) * side
    red[0, 1] = 0.31 * side
    if dim == 3:
        red[0, 2], red[1, 2] = -0.22 * side, 0.17 * side
    u = np.eye(dim)
    u[0, 1:] = fold
    if dim == 3:
        u[1, 2] = -fold
    return Box(red @ np.round(np.linalg.inv(u))), red


def brute_pairs(x, red, rmax):
    """(i, j, separation) of every pair i < j whose shortest image over all shifts of up to 3
    reduced cells is below rmax (positions are first brought into the cell by rounding)."""
    i, j = np.triu_indices(len(x), 1)
    dr = x[i] - x[j]
    dr = dr - np.round(np.linalg.solve(red, dr.T).T) @ red.T
    shifts = np.array(list(product(range(-3, 4), repeat=len(red)))) @ red.T
    best = np.full(len(dr), np.inf)
    sep = np.zeros_like(dr)
    for s in shifts:
        cand = dr + s
        d = np.linalg.norm(cand, axis=1)
        better = d < best
        best[better], sep[better] = d[better], cand[better]
    keep = best < rmax
    return i[keep], j[keep], sep[keep], best[keep]


CASES = [  # (dim, side, n, fold): small dense cells and large sparse ones
    (2, 6.0, 80, 0), (2, 6.0, 80, 3), (2, 6.0, 80, -5),
    (3, 6.0, 80, 0), (3, 6.0, 80, 2), (3, 6.0, 80, -4),
    (2, 200.0, 300, 0), (2, 200.0, 300, 4), (3, 200.0, 200, 3),
]


@pytest.mark.parametrize("dim,side,n,fold", CASES)
@pytest.mark.parametrize("tilted", [False, True])
def test_neighbor_pairs_match_brute_force_over_all_images(dim, side, n, fold, tilted):
    box, red = sheared_cell(dim, side, fold) if tilted else (Box.cube(side, dim), np.eye(dim) * side)
    rng = np.random.default_rng(dim * 100 + n + fold)
    x = rng.uniform(-3 * side, 3 * side, (n, dim))  # raw positions spread over several cells
    rmax = 0.45 * box.widths.min()
    i, j, image = neighbor_pairs(x, box, rmax)
    bi, bj, bsep, bd = brute_pairs(x, red, rmax)
    assert len(bi) > 20 and np.all(i < j) and np.array_equal(np.lexsort((j, i)), np.arange(len(i)))
    assert np.array_equal(i, bi) and np.array_equal(j, bj)  # brute pairs come sorted as well
    assert image.dtype.kind == "i" and image.shape == (len(i), dim)
    sep = x[i] - x[j] + image @ box.h.T
    assert np.max(np.abs(sep - bsep)) < 1e-12
    assert np.max(np.abs(sep - box.minimum_image(x[i] - x[j]))) < 1e-12


def test_float32_misses_a_1e9_overlap_at_l150_and_float64_does_not():
    """The old tilted search (freud, float32, 1e-5 pad) against neighbor_pairs."""
    freud = pytest.importorskip("freud")
    side, sigma, overlap = 150.0, 1.0, 1e-9
    box = Box([[side, 2.3 * side, 0.0], [0, side, 0.0], [0, 0, side]])  # strain 2.3
    rng = np.random.default_rng(1)
    for _ in range(2000):  # a pair whose float32 distance is off by more than the old pad
        a = rng.uniform(0.55 * side, 0.95 * side, 3)
        u = rng.normal(size=3)
        x = np.array([a, a - sigma * (1 - overlap) * u / np.linalg.norm(u)])
        x32 = x.astype(np.float32).astype(float)
        if np.linalg.norm(x32[0] - x32[1]) - sigma > 1.2e-5:
            break
    fbox = box.to_freud()
    pts = fbox.wrap(x.astype(np.float32))
    found = freud.locality.AABBQuery(fbox, pts).query(pts, dict(r_max=sigma + 1e-5, exclude_ii=True))
    assert len(found.toNeighborList()) == 0  # float32 loses the contact
    i, j, image = neighbor_pairs(x, box, sigma)
    assert (i.tolist(), j.tolist()) == ([0], [1])
    r = np.linalg.norm(x[0] - x[1] + image[0] @ box.h.T)
    assert abs((1 - r / sigma) - overlap) < 1e-13


def test_candidate_pairs_are_unchanged_in_orthogonal_boxes(config):
    """Same pairs in the same order as the cKDTree search before neighbor_pairs existed."""
    for dim in (2, 3):
        p = config(300, dim, 0.8 if dim == 2 else 0.6, seed=dim)
        rmax = 1.4 * 1.3
        i, j = candidate_pairs(p, rmax)
        r = rmax * (1 + 1e-6) + 1e-9
        wrapped = p.box.wrap(p.positions)
        wrapped = np.where(wrapped >= p.box.lengths, 0.0, wrapped)
        pairs = cKDTree(wrapped, boxsize=p.box.lengths).query_pairs(r, output_type="ndarray")
        order = np.lexsort((pairs[:, 1], pairs[:, 0]))
        assert np.array_equal(i, pairs[order, 0]) and np.array_equal(j, pairs[order, 1])


@pytest.mark.parametrize("strain", [0.3, 2.6, -3.45])
def test_candidate_pairs_in_sheared_boxes_hold_every_close_pair(config, strain):
    from jamflow.model.pairs import all_pairs, separations

    p = config(200, 2, 0.85, seed=4, tilt=strain)
    i, j = candidate_pairs(p, p.diameters.max())
    ai, aj = all_pairs(p.n)
    close = np.linalg.norm(separations(p, ai, aj), axis=1) < p.diameters.max()
    assert set(zip(ai[close], aj[close])) <= set(zip(i, j)) and close.sum() > p.n


def test_no_pairs_gives_empty_arrays():
    box = Box([[20.0, 31.0], [0, 20.0]])
    i, j, image = neighbor_pairs(np.array([[1.0, 1.0], [10.0, 10.0]]), box, 1.0)
    assert i.shape == j.shape == (0,) and image.shape == (0, 2)


@pytest.mark.parametrize("positions,rmax,match", [
    (np.zeros((3, 3)), 1.0, "shape"), (np.zeros((3, 2)), 6.0, "half the smallest box width"),
    (np.zeros((3, 2)), 0.0, "rmax"), (np.zeros((3, 2)), float("nan"), "rmax"),
])
def test_bad_input_is_refused(positions, rmax, match):
    with pytest.raises(ValueError, match=match):
        neighbor_pairs(positions, Box([[10.0, 27.0], [0, 10.0]]), rmax)
