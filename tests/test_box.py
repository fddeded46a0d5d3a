import numpy as np
import pytest

from jamflow.box import Box


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
