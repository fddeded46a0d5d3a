"""Particles of large random starts numbered along the Morton curve: the same particles, relabelled."""

import numpy as np
import pytest

import jamflow.model.packing as packing_module
from jamflow.model.ordering import SPATIAL_ORDER_FROM, morton_order
from jamflow.model.packing import random_packing
from jamflow.model.pairs import candidate_pairs
from jamflow.model.shapes.parse import parse_shape
from jamflow.model.sizes import parse_sizes


def test_morton_order_visits_the_quadrants_in_z_order():
    # one point per quadrant of the unit square, given in scrambled order; the Z curve runs
    # (low x, low y), (high x, low y), (low x, high y), (high x, high y)
    points = np.array([[0.7, 0.8], [0.2, 0.3], [0.3, 0.9], [0.9, 0.1]])
    assert morton_order(points).tolist() == [1, 3, 2, 0]


def test_morton_order_is_a_permutation_and_wraps_cell_coordinates():
    rng = np.random.default_rng(0)
    s = rng.random((1000, 3))
    order = morton_order(s)
    assert sorted(order.tolist()) == list(range(1000))
    assert np.array_equal(morton_order(s + 1.0), order)  # the periodic image: the same cells


def _contact_index_distance(packing):
    i, j = candidate_pairs(packing, float(packing.diameters.max()))
    return float(np.median(np.abs(i - j)))


@pytest.mark.parametrize("dim", [2, 3])
def test_a_large_random_start_is_the_same_particles_numbered_along_the_curve(monkeypatch, dim):
    n = SPATIAL_ORDER_FROM
    particle = parse_shape("disk", dim)
    ordered = random_packing(n, dim, parse_sizes("bi:1.4:0.5"), 0.5, 7, shape=particle)
    monkeypatch.setattr(packing_module, "SPATIAL_ORDER_FROM", n + 1)
    drawn = random_packing(n, dim, parse_sizes("bi:1.4:0.5"), 0.5, 7, shape=particle)
    rows = lambda p: sorted(map(tuple, np.column_stack([p.positions, p.diameters])))
    assert rows(ordered) == rows(drawn)
    # neighbours in space are near in the arrays only after the ordering
    assert _contact_index_distance(ordered) < 0.02 * n < _contact_index_distance(drawn)


def test_orientations_move_with_their_particles(monkeypatch):
    n = SPATIAL_ORDER_FROM
    ellipse = parse_shape("ellipse:1.5", 2)
    ordered = random_packing(n, 2, parse_sizes("mono"), 0.5, 3, shape=ellipse)
    monkeypatch.setattr(packing_module, "SPATIAL_ORDER_FROM", n + 1)
    drawn = random_packing(n, 2, parse_sizes("mono"), 0.5, 3, shape=ellipse)
    by_position = {tuple(x): o for x, o in zip(drawn.positions, drawn.orientations)}
    assert all(by_position[tuple(x)] == o for x, o in zip(ordered.positions, ordered.orientations))


def test_smaller_starts_keep_the_order_they_were_drawn_in():
    sizes = parse_sizes("poly-uniform:0.4")
    start = random_packing(64, 2, sizes, 0.8, 5)
    rng = np.random.default_rng(5)  # diameters first, then positions, from one generator
    diameters = sizes.draw(64, rng)
    assert np.array_equal(start.diameters, diameters)
    assert np.array_equal(start.positions, rng.random((64, 2)) * start.box.lengths[0])
