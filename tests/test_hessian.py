"""Dynamical matrix: closed form, finite differences of the numpy reference forces, and
LAMMPS's ``dynamical_matrix`` command (PHONON package) as a second implementation."""

import numpy as np
import pytest

from jamflow.mechanics.dynamical_matrix import DynamicalMatrix
from jamflow.mechanics.hessian import hessian, pair_stiffness
from jamflow.model.box import Box
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.model.packing import Packing
from jamflow.model.potentials import RepulsiveLJ, Spring
from test_contacts import triangular_lattice

POTENTIALS = [Spring(2.0), Spring(2.5), Spring(3.0), RepulsiveLJ()]


def perturbed_lattice(dim, seed, potential=Spring(), spacing=0.9, noise=0.01):
    """Sheared square (2D, 8x8) or cubic (3D, 4x4x4) lattice in a cell tilted by one spacing in
    every tilt, diameters 1.0-1.1, random displacements. Overlaps are 5-20 %, far from
    r = sigma, so finite differences never cross a contact edge."""
    rng = np.random.default_rng(seed)
    side = 8 if dim == 2 else 4
    sites = np.stack(np.meshgrid(*[np.arange(side)] * dim, indexing="ij"), -1).reshape(-1, dim)
    h = np.eye(dim) * side * spacing + np.triu(np.ones((dim, dim)), 1) * spacing
    box = Box(h)
    pos = box.wrap(sites @ (h / side).T + noise * rng.normal(size=sites.shape))
    return Packing(pos, 1.0 + 0.1 * rng.random(len(sites)), box, potential)


def finite_difference_columns(packing, columns, step):
    """Columns of -dF/dx by central differences of the all-pairs numpy forces."""
    n, d = packing.n, packing.dim
    out = np.zeros((n * d, len(columns)))
    for c, k in enumerate(columns):
        x = packing.positions.ravel().copy()
        x[k] += step
        plus = energy_forces_pressure(packing.with_positions(x.reshape(n, d))).forces.ravel()
        x[k] -= 2 * step
        minus = energy_forces_pressure(packing.with_positions(x.reshape(n, d))).forces.ravel()
        out[:, c] = -(plus - minus) / (2 * step)
    return out


def lammps_dynamical_matrix(packing, step, tmp_path):
    """LAMMPS ``dynamical_matrix all regular STEP`` (binary, 3N x 3N in atom-ID = packing order,
    divided by sqrt(m_i m_j) = 1), restricted to the packing's d coordinates."""
    from jamflow.engines.lammps.engine import LammpsEngine

    out = tmp_path / "dynmat.bin"
    with LammpsEngine(packing) as eng:
        eng.command(f"dynamical_matrix all regular {step:g} file {out} binary yes")
    raw = np.fromfile(out).reshape(3 * packing.n, 3 * packing.n)
    idx = (np.arange(packing.n)[:, None] * 3 + np.arange(packing.dim)).ravel()
    if packing.dim == 2:  # the z rows and columns of a 2D system are zero
        z = np.arange(packing.n) * 3 + 2
        assert np.all(raw[z] == 0) and np.all(raw[:, z] == 0)
    return raw[np.ix_(idx, idx)]


@pytest.mark.parametrize("pot", POTENTIALS, ids=lambda p: p.spec)
@pytest.mark.parametrize("dim", [2, 3])
def test_two_particle_closed_form(pot, dim):
    # one pair along a generic direction: eigenvalues 0 (d times), 2 V'' and 2 V'/r (d - 1 times)
    direction = np.array([0.6, 0.8, 0.0][:dim]) if dim == 2 else np.array([2.0, -1.0, 2.0]) / 3.0
    r, diam = 1.1, np.array([1.0, 1.4])
    sigma = diam.mean()
    pos = np.vstack([np.full(dim, 3.0), 3.0 + r * direction])
    p = Packing(pos, diam, Box.cube(6.0, dim), pot)
    h = DynamicalMatrix(remove_floaters=False).compute(p).matrix.toarray()
    v1, v2 = float(pot.dv_dr(r, sigma)), float(pot.d2v_dr2(r, sigma))
    n = -direction  # r_0 - r_1 points along -direction
    block = v2 * np.outer(n, n) + v1 / r * (np.eye(dim) - np.outer(n, n))
    assert np.allclose(h[:dim, :dim], block, rtol=1e-13, atol=0)
    assert np.allclose(h[:dim, dim:], -block, rtol=1e-13, atol=0)
    expected = np.sort([0.0] * dim + [2 * v2] + [2 * v1 / r] * (dim - 1))
    assert np.allclose(np.linalg.eigvalsh(h), expected, rtol=1e-12, atol=1e-12 * abs(v2))


def test_pair_stiffness_spring_alpha2_values():
    # linear spring, sigma = 1.2, r = 1.0: V'' = 1/sigma^2, V'/r = -(1 - r/sigma)/sigma / r
    k = pair_stiffness(Spring(2.0), np.array([[1.0, 0.0]]), np.array([1.0]), np.array([1.2]))[0]
    assert k[0, 0] == pytest.approx(1 / 1.44, rel=1e-15)
    assert k[1, 1] == pytest.approx(-(1 - 1 / 1.2) / 1.2, rel=1e-14)
    assert k[0, 1] == 0.0


@pytest.mark.parametrize("pot", POTENTIALS, ids=lambda p: p.spec)
@pytest.mark.parametrize("dim", [2, 3])
def test_hessian_matches_finite_differences(pot, dim):
    p = perturbed_lattice(dim, seed=dim, potential=pot)
    h = hessian(p).toarray()
    columns = np.random.default_rng(dim).choice(len(h), 24, replace=False)
    fd = finite_difference_columns(p, columns, step=1e-5)
    scale = np.abs(h).max()
    # central differences: error ~ step^2 V''' ~ 1e-10 relative; round-off ~ 1e-16 / step
    assert np.abs(h[:, columns] - fd).max() < 1e-8 * scale
    assert np.abs(h - h.T).max() < 1e-14 * scale


@pytest.mark.parametrize("pot", [Spring(2.0), Spring(2.5), RepulsiveLJ()], ids=lambda p: p.spec)
@pytest.mark.parametrize("dim", [2, 3])
def test_hessian_matches_lammps_dynamical_matrix(pot, dim, tmp_path):
    p = perturbed_lattice(dim, seed=10 + dim, potential=pot)
    h = hessian(p).toarray()
    lmp = lammps_dynamical_matrix(p, 1e-5, tmp_path)
    assert np.abs(h - lmp).max() < 1e-8 * np.abs(h).max()


def test_floater_and_its_contacts_are_dropped():
    lattice = triangular_lattice(6, 6, 0.98)  # rigid, z = 6
    pos, dia = lattice.positions.copy(), lattice.diameters.copy()
    pos[14] += [0.195, 0.0]  # a small disk pushed against its +x neighbour (site 15): one contact
    dia[14] = 0.6
    q = Packing(pos, dia, lattice.box)
    full = DynamicalMatrix(remove_floaters=False).compute(q).matrix.toarray()
    res = DynamicalMatrix().compute(q)
    assert res.contacts.floater[14] and res.contacts.n_floaters == 1 and res.n_total == q.n
    assert np.array_equal(res.particles, np.delete(np.arange(q.n), 14))
    # the reduced matrix is the Hessian of the packing with the floater deleted ...
    assert np.array_equal(res.matrix.toarray(), hessian(res.packing).toarray())
    # ... i.e. the full one without particle 14 and without the 14-15 pair on 15's diagonal
    keep = (res.particles[:, None] * 2 + np.arange(2)).ravel()
    diff = res.matrix.toarray() - full[np.ix_(keep, keep)]
    row = 2 * 14  # site 15 is row 14 once site 14 is gone
    assert np.allclose(diff[row:row + 2, row:row + 2], full[30:32, 28:30], rtol=1e-12, atol=0)
    diff[row:row + 2, row:row + 2] = 0.0
    assert np.abs(diff).max() < 1e-15


def test_translations_are_exact_zero_modes():
    p = perturbed_lattice(3, seed=1, potential=Spring(2.5))
    res = DynamicalMatrix(remove_floaters=False).compute(p)
    t = res.translations()
    assert np.allclose(t.T @ t, np.eye(3))
    assert np.abs(res.matrix @ t).max() < 1e-13 * abs(res.matrix).max()
