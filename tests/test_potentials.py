"""Closed-form checks of the potentials (chapter eqs. 2.1, 2.2) and their derivatives."""

import numpy as np
import pytest

from jamflow.model.box import Box
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.model.packing import Packing
from jamflow.model.potentials import RepulsiveLJ, Spring, parse_potential

POTENTIALS = [Spring(2.0), Spring(2.5), Spring(1.5), Spring(3.0, epsilon=2.0), RepulsiveLJ(), RepulsiveLJ(0.5)]


@pytest.mark.parametrize("pot", POTENTIALS, ids=lambda p: p.spec)
def test_derivatives_match_finite_differences(pot):
    r = np.linspace(0.9, 1.19, 40)
    sigma, h = 1.2, 1e-6
    fd1 = (pot.energy(r + h, sigma) - pot.energy(r - h, sigma)) / (2 * h)
    fd2 = (pot.dv_dr(r + h, sigma) - pot.dv_dr(r - h, sigma)) / (2 * h)
    assert np.allclose(pot.dv_dr(r, sigma), fd1, rtol=1e-7, atol=1e-12)
    assert np.allclose(pot.d2v_dr2(r, sigma), fd2, rtol=1e-6, atol=1e-10)


@pytest.mark.parametrize("pot", POTENTIALS, ids=lambda p: p.spec)
def test_zero_at_and_beyond_contact(pot):
    assert np.all(pot.energy(np.array([1.0, 1.3]), 1.0) == 0)
    assert np.all(pot.dv_dr(np.array([1.0, 1.3]), 1.0) == 0)


def test_two_disks_closed_form_energy_force_pressure():
    """Disks of diameters 1 and 1.4 (sigma = 1.2) along x at r = 1.1: delta = 1 - r/sigma."""
    box = Box.cube(10.0, 2)
    p = Packing([[2.0, 3.0], [3.1, 3.0]], [1.0, 1.4], box, Spring(2.5))
    res = energy_forces_pressure(p)
    x = 1 - 1.1 / 1.2
    assert res.energy == pytest.approx(x**2.5 / 2.5, rel=1e-14)
    f = x**1.5 / 1.2  # repulsive magnitude eps/sigma x^(alpha-1)
    assert res.forces[0] == pytest.approx([-f, 0.0], rel=1e-14, abs=1e-300)
    assert res.forces[1] == pytest.approx([f, 0.0], rel=1e-14, abs=1e-300)
    # virial: r_ij f_ij / V with r_ij = r_i - r_j = (-1.1, 0), f_ij = (-f, 0)
    assert res.pressure_tensor[0, 0] == pytest.approx(1.1 * f / 100.0, rel=1e-14)
    assert res.pressure_tensor[1, 1] == 0 and res.pressure_tensor[0, 1] == 0


def test_rlj_closed_form_two_spheres():
    box = Box.cube(8.0, 3)
    p = Packing([[1, 1, 1], [1, 1, 1.9]], [1.0, 1.0], box, RepulsiveLJ())
    res = energy_forces_pressure(p)
    q = (1 / 0.9) ** 6
    assert res.energy == pytest.approx(q * q - 2 * q + 1, rel=1e-14)
    assert res.forces[1, 2] == pytest.approx(12 / 0.9 * (q * q - q), rel=1e-14)


@pytest.mark.parametrize("spec,expected", [("spring", Spring(2.0)), ("hertz", Spring(2.5)),
                                           ("spring:3.5", Spring(3.5)), ("RLJ", RepulsiveLJ())])
def test_parse_potential(spec, expected):
    assert parse_potential(spec) == expected


@pytest.mark.parametrize("spec", ["spring:1", "spring:x", "morse", "spring:nan", "spring:-2"])
def test_bad_potential_specs_say_what_to_write(spec):
    with pytest.raises(ValueError, match="spring|alpha"):
        parse_potential(spec)
