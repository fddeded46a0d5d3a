from itertools import product

import numpy as np
import pytest

from jamflow.model.box import Box


def test_lammps_round_trip_3d():
    box = Box([[5.0, 1.2, -0.7], [0, 4.0, 0.3], [0, 0, 6.0]])
    lo = box.to_lammps()
    back = Box.from_lammps(3, (lo["xhi"] - lo["xlo"], lo["yhi"] - lo["ylo"], lo["zhi"] - lo["zlo"]),
                           (lo["xy"], lo["xz"], lo["yz"]))
    assert np.array_equal(back.h, box.h)


def test_freud_round_trip_uses_dimensionless_tilt():
    box = Box([[5.0, 1.5], [0, 3.0]])
    fb = box.to_freud()
    assert fb.xy == pytest.approx(0.5)
    assert np.allclose(fb.to_matrix()[:2, :2], box.h)


def test_shear_strain_is_tilt_over_height():
    box = Box.cube(4.0, 2).with_shear_strain(0.25)
    assert box.tilts[0] == 1.0 and box.shear_strain == 0.25


def test_minimum_image_matches_brute_force_in_strongly_tilted_box():
    rng = np.random.default_rng(0)
    box = Box([[4.0, 3.1], [0, 2.0]])
    dr = rng.uniform(-10, 10, (500, 2))
    got = box.minimum_image(dr)
    images = np.array([[i, j] for i in range(-8, 9) for j in range(-8, 9)]) @ box.h.T
    brute = dr[:, None, :] + images[None]
    best = brute[np.arange(500), np.argmin((brute**2).sum(-1), axis=1)]
    assert np.allclose(np.linalg.norm(got, axis=1), np.linalg.norm(best, axis=1), rtol=0, atol=1e-12)


def test_wrap_keeps_fractional_coordinates_in_unit_cell():
    box = Box([[3.0, 1.0, 0.5], [0, 2.0, -0.4], [0, 0, 2.5]])
    pos = np.random.default_rng(1).uniform(-20, 20, (100, 3))
    s = box.to_fractional(box.wrap(pos))
    assert np.all((s >= 0) & (s < 1))
    assert np.allclose(np.linalg.norm(box.minimum_image(box.wrap(pos) - pos), axis=1), 0, atol=1e-11)


@pytest.mark.parametrize("h", [[[1.0, 0], [1.0, 1.0]], [[0.0, 0], [0, 1.0]], [[1, 0, 0], [0, 1, 0]],
                               [[np.nan, 0], [0, 1]]])
def test_bad_boxes_are_rejected(h):
    with pytest.raises(ValueError):
        Box(h)


def test_minimum_image_orthogonal_fast_path_matches_general_path():
    rng = np.random.default_rng(5)
    dr = rng.uniform(-9, 9, (300, 3))
    ortho = Box(np.diag([3.0, 4.0, 5.0]))
    tiny_tilt = Box([[3.0, 1e-300, 0], [0, 4.0, 0], [0, 0, 5.0]])  # takes the general path
    assert np.allclose(ortho.minimum_image(dr), tiny_tilt.minimum_image(dr), atol=1e-12)


# Lees-Edwards: accumulated strain and the reduced cell ------------------------------------------
def random_tilted_box(rng, dim, max_fold):
    """(box, reduced h): a random cell in LAMMPS's tilt range (sides 3..6), sheared by a
    random integer upper-unitriangular U (entries up to ``max_fold``): h = reduced @ U^-1, so
    tilts reach several cell lengths and the test knows the reduced lattice independently."""
    red = np.diag(rng.uniform(3.0, 6.0, dim))
    red[0, 1:] = rng.uniform(-0.5, 0.5, dim - 1) * red[0, 0]
    if dim == 3:
        red[1, 2] = rng.uniform(-0.5, 0.5) * red[1, 1]
    u = np.eye(dim) + np.triu(rng.integers(-max_fold, max_fold + 1, (dim, dim)), 1)
    return Box(red @ np.round(np.linalg.inv(u))), red


def random_samples(seed, dim, count, spread):
    """``count`` random sheared cells (folds up to 5), each with 300 vectors in [-spread, spread]^d."""
    rng = np.random.default_rng(seed)
    for _ in range(count):
        box, known = random_tilted_box(rng, dim, 5)
        yield box, known, rng.uniform(-spread, spread, (300, dim))


def assert_whole_cells_apart(box, a, b):
    """a - b is a lattice vector of ``box`` for every row."""
    n = box.to_fractional(a - b)
    assert np.max(np.abs(n - np.round(n))) < 1e-9


def brute_minimum_image(red, dr):
    """Shortest image by rounding in the reduced cell ``red``, then every image within 4 cells."""
    images = np.array(list(product(range(-4, 5), repeat=len(red))))
    dr = dr - np.round(np.linalg.solve(red, dr.T).T) @ red.T
    cand = dr[:, None, :] + (images @ red.T)[None]
    return cand[np.arange(len(dr)), np.argmin((cand**2).sum(-1), axis=1)]


@pytest.mark.parametrize("dim", [2, 3])
def test_reduced_cell_is_the_same_lattice_with_tilts_in_lammps_range(dim):
    rng = np.random.default_rng(dim)
    for _ in range(200):
        box, known = random_tilted_box(rng, dim, 6)
        red, fold = box.reduction()
        assert np.allclose(red.h, known, rtol=0, atol=1e-12 * np.abs(box.h).max())  # unique
        xy, xz, yz = red.tilts
        lx, ly = red.lengths[:2]
        assert -lx / 2 <= xy < lx / 2 and -lx / 2 <= xz < lx / 2 and -ly / 2 <= yz < ly / 2
        assert np.array_equal(red.lengths, box.lengths) and red.volume == pytest.approx(box.volume, rel=1e-14)
        assert fold.dtype.kind == "i" and np.array_equal(np.diag(fold), np.ones(dim))
        assert np.array_equal(np.tril(fold, -1), np.zeros((dim, dim)))
        assert np.allclose(red.h, box.h @ fold, rtol=0, atol=1e-12 * np.abs(box.h).max())
        assert box.is_same_lattice(red) and red.is_same_lattice(box)
        assert red.reduction()[0] is red  # already reduced: returned as it is
        assert np.array_equal(red.to_lammps()["xy"], box.to_lammps()["xy"])


def test_is_same_lattice_knows_the_lees_edwards_period():
    square = Box.cube(5.0, 2)
    assert square.with_shear_strain(0.3).is_same_lattice(square.with_shear_strain(1.3))
    assert square.with_shear_strain(0.3).is_same_lattice(square.with_shear_strain(-2.7))
    assert not square.with_shear_strain(0.3).is_same_lattice(square.with_shear_strain(0.8))
    assert not square.with_shear_strain(0.3).is_same_lattice(square.with_shear_strain(0.3 + 1e-6))
    wide = Box(np.diag([8.0, 4.0]))  # period lx / ly = 2 in gamma
    assert wide.with_shear_strain(0.1).is_same_lattice(wide.with_shear_strain(2.1))
    assert not wide.with_shear_strain(0.1).is_same_lattice(wide.with_shear_strain(1.1))
    assert not square.is_same_lattice(Box.cube(5.0, 3)) and not square.is_same_lattice(Box.cube(5.1, 2))


@pytest.mark.parametrize("dim", [2, 3])
def test_positions_wrapped_in_either_cell_are_the_same_lattice_points(dim):
    for box, _, pos in random_samples(10 + dim, dim, count=20, spread=60):
        s = box.to_fractional(pos)  # wrapped in the accumulated cell itself
        in_accumulated = box.to_cartesian(s - np.floor(s))
        got = box.wrap(pos)
        s_red = box.reduced().to_fractional(got)
        assert np.all((s_red >= 0) & (s_red < 1))
        assert_whole_cells_apart(box, got, in_accumulated)
        assert np.allclose(box.minimum_image(got - pos), 0, atol=1e-11)


@pytest.mark.parametrize("dim", [2, 3])
def test_minimum_image_is_exact_in_strongly_tilted_cells(dim):
    for box, known, dr in random_samples(20 + dim, dim, count=10, spread=40):
        got = box.minimum_image(dr)
        best = brute_minimum_image(known, dr)
        assert np.allclose(np.linalg.norm(got, axis=1), np.linalg.norm(best, axis=1), rtol=0, atol=1e-12)
        assert_whole_cells_apart(box, got, dr)


def test_widths_do_not_depend_on_the_accumulated_strain():
    square = Box.cube(7.0, 2)
    for gamma in (1.0, 3.0, -5.0):
        assert np.allclose(square.with_shear_strain(gamma).widths, 7.0, rtol=1e-14)
    sheared = square.with_shear_strain(4.3)
    assert np.allclose(sheared.widths, square.with_shear_strain(0.3).widths, rtol=1e-12)
    assert np.linalg.norm(np.linalg.inv(sheared.h), axis=1).max() > 0.5  # h's own faces are 1/4.4 apart
    from jamflow.model.packing import Packing

    Packing([[1.0, 1.0], [4.0, 4.0]], [1.0, 1.0], sheared)  # valid: the reduced cell is wide


def test_to_lammps_sends_the_reduced_cell():
    box = Box([[4.0, 9.0, -7.0], [0, 5.0, 6.5], [0, 0, 6.0]])
    lo = box.to_lammps()
    assert (lo["xy"], lo["yz"]) == pytest.approx((1.0, 1.5)) and abs(lo["xz"]) <= 2.0
    assert Box.from_lammps(3, (4.0, 5.0, 6.0), (lo["xy"], lo["xz"], lo["yz"])).is_same_lattice(box)


def _mirror_pressure(dim):
    """Sign of each pressure-tensor entry under x -> -x."""
    sign = np.ones((dim, dim))
    sign[0, 1:] = sign[1:, 0] = -1
    return sign


@pytest.mark.parametrize("dim", [2, 3])
def test_strain_gamma_plus_one_is_the_same_square_cell(config, dim):
    """Seed Fig. 2.4(d): shear-periodic boundaries have unit period for a square cell."""
    from jamflow.mechanics.reference import energy_forces_pressure

    base = config(60, dim, 0.9 if dim == 2 else 0.7, seed=30 + dim)
    for gamma in (0.3, 0.5, -0.2):
        a = base.with_positions(base.positions, base.box.with_shear_strain(gamma))
        b = base.with_positions(base.positions, base.box.with_shear_strain(gamma + 1.0))
        assert np.allclose(a.box.wrap(a.positions), b.box.wrap(b.positions), rtol=0, atol=1e-12)
        ea, eb = energy_forces_pressure(a), energy_forces_pressure(b)
        assert ea.energy > 0 and eb.energy == pytest.approx(ea.energy, rel=1e-12)
        assert np.allclose(eb.pressure_tensor, ea.pressure_tensor, rtol=1e-12, atol=0)


@pytest.mark.parametrize("dim", [2, 3])
def test_strain_one_minus_gamma_is_the_mirror_image(config, dim):
    """Seed Fig. 2.4(c): x -> -x maps the cell at gamma onto the cell at 1 - gamma (square)."""
    from jamflow.mechanics.reference import energy_forces_pressure

    base = config(60, dim, 0.9 if dim == 2 else 0.7, seed=40 + dim)
    for gamma in (0.2, 0.37):
        p = base.with_positions(base.positions, base.box.with_shear_strain(gamma))
        mirrored = p.positions * np.r_[-1.0, np.ones(dim - 1)]
        q = p.with_positions(mirrored, p.box.with_shear_strain(1.0 - gamma))
        ep, eq = energy_forces_pressure(p), energy_forces_pressure(q)
        assert ep.energy > 0 and eq.energy == pytest.approx(ep.energy, rel=1e-12)
        assert np.allclose(eq.pressure_tensor, _mirror_pressure(dim) * ep.pressure_tensor, rtol=1e-12, atol=1e-15)
        assert np.allclose(eq.forces[:, 0], -ep.forces[:, 0], rtol=0, atol=1e-12)
        # ... and it is a different configuration: the cell at gamma itself does not give it
        other = energy_forces_pressure(p.with_positions(mirrored))
        assert other.energy != pytest.approx(ep.energy, rel=1e-6)
