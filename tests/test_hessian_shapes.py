"""Dynamical matrix with rotational coordinates (rigid bodies, ellipses, spheroids).

Closed forms: two identical ellipses end to end and side by side (osculating circles at the
touching vertices give sigma to second order), two dimers touching at one site pair. Second
implementations: second differences of the numpy reference energy (Richardson-extrapolated,
1e-8 of max |M|), the reference torques (the Jacobian of the generalized forces has M as its
symmetric part and (1/2) eps_abc tau_c / (d_a d_b) as its antisymmetric part), the disk Hessian
against the ellipse machinery at zero asphericity. Invariance: M T = 0 for the d translations."""

import dataclasses

import numpy as np
import pytest

from jamflow.mechanics.deformation import displaced
from jamflow.mechanics.hessian import (Coordinates, _local_index, _PairFrame, hessian, pair_stiffness, pair_terms,
                                       reduced_distance_derivatives)
from jamflow.model.box import Box
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.model.packing import Packing, random_packing
from jamflow.model.pairs import candidate_pairs, contact_distances, separations, site_packing
from jamflow.model.potentials import Spring
from jamflow.model.shapes import Ellipsoid
from jamflow.model.shapes.rotations import rotation_matrices
from jamflow.model.sizes import parse_sizes
from test_engines import dimer, sample

MODELS = [("dimer", 2), ("dimer", 3), ("asym-dimer", 2), ("trimer", 2), ("trimer", 3), ("ellipsoid", 2),
          ("ellipsoid", 3), ("prolate", 3)]


def clear_of_contact_edges(p: Packing, margin: float) -> Packing:
    """Drop particles until no pair (of sites, for bodies) has |r / sigma - 1| < margin, so that
    finite differences never cross the edge of the contact law."""
    while True:
        q, body = site_packing(p) if p.shape.kind == "rigid" else (p, np.arange(p.n))
        i, j = candidate_pairs(q, 2 * float(q.shape.reach(q.diameters).max()))
        i, j = i[body[i] != body[j]], j[body[i] != body[j]]
        dr = separations(q, i, j)
        near = np.abs(np.linalg.norm(dr, axis=1) / contact_distances(q, i, j, dr) - 1) < margin
        if not near.any():
            return p
        p = p.subset(np.setdiff1d(np.arange(p.n), body[i[near]][:1]))


def model_packing(model, dim, alpha=2.0):
    """A random overlapping packing of the model (5-20 % overlaps), clear of contact edges."""
    if model == "prolate":
        p = random_packing(40, 3, parse_sizes("bi:1.4:0.5"), 0.55, 5, shape=Ellipsoid(1.6))
    else:
        p = sample(model, dim, n=16 if dim == 2 else 40, seed=5)
    return clear_of_contact_edges(dataclasses.replace(p, potential=Spring(alpha)), 0.03)


def energy(p, xi):
    u, w = Coordinates.of(p).split(xi)
    return energy_forces_pressure(displaced(p, u, w)).energy


def second_difference(p, a, b, h):
    """d^2 V / d xi_a d xi_b by central differences of the reference energy, Richardson on h, 2h."""
    n = Coordinates.of(p).size

    def d(step):
        ea, eb = np.zeros(n), np.zeros(n)
        ea[a], eb[b] = step, step
        return (energy(p, ea + eb) - energy(p, ea - eb) - energy(p, eb - ea) + energy(p, -ea - eb)) / (4 * step**2)

    return (4 * d(h) - d(2 * h)) / 3


def busiest_particle_entries(p, m):
    """(row, column) pairs: every coordinate of the particle with the most couplings against
    every coordinate of itself and of its partners (rotation-rotation, rotation-translation, ...)."""
    c = Coordinates.of(p)
    owner = np.concatenate([np.repeat(np.arange(p.n), p.dim), np.repeat(np.arange(p.n), c.n_rot)])
    coupled = [np.unique(owner[m[:, owner == k].nonzero()[0]]) for k in range(p.n)]
    k = int(np.argmax([len(x) for x in coupled]))
    cols = np.flatnonzero(owner == k)
    rows = np.flatnonzero(np.isin(owner, coupled[k]))
    return [(r, col) for col in cols for r in rows if r >= col]


CASES = [(m, d, 2.0) for m, d in MODELS] + [("dimer", 2, 2.5), ("ellipsoid", 2, 2.5), ("trimer", 3, 2.5)]


@pytest.mark.parametrize("model,dim,alpha", CASES, ids=[f"{m}-{d}d-alpha{a:g}" for m, d, a in CASES])
def test_hessian_matches_second_differences_of_the_reference_energy(model, dim, alpha):
    p = model_packing(model, dim, alpha)
    m = hessian(p).toarray()
    entries = busiest_particle_entries(p, m)
    fd = np.array([second_difference(p, a, b, 3e-4) for a, b in entries])
    got = np.array([m[a, b] for a, b in entries])
    scale = np.abs(m).max()
    # round-off ~ 1e-16 |V| / h^2 ~ 1e-9, truncation ~ h^4 ~ 1e-9 (benchmarks/modes_shapes_check.py)
    assert np.abs(got - fd).max() < 1e-8 * scale
    c = Coordinates.of(p)
    assert any(a >= c.n_translational and b >= c.n_translational for a, b in entries)  # rotations were tested
    assert np.abs(m - m.T).max() < 1e-14 * scale
    assert np.abs(m @ c.translations()).max() < 1e-13 * scale  # translational invariance


@pytest.mark.parametrize("model,dim", MODELS, ids=[f"{m}-{d}d" for m, d in MODELS])
def test_pair_gradients_sum_to_the_reference_forces_and_torques(model, dim):
    p = model_packing(model, dim)
    terms = pair_terms(p)
    c = Coordinates.of(p)
    total = np.zeros(c.size)
    np.add.at(total, _local_index(c, terms.i, terms.j).ravel(), terms.gradient.ravel())
    expected = generalized_forces(p)[0]
    assert np.abs(total + expected).max() < 1e-12 * np.abs(expected).max()


def generalized_forces(p):
    """-dV/dxi at the current state: forces and body-frame torques tau_a / d_k."""
    c = Coordinates.of(p)
    ref = energy_forces_pressure(p)
    rot = rotation_matrices(p.orientations, p.dim)
    if p.dim == 2:
        body = ref.torques[:, None]
    else:
        body = np.einsum("nab,na->nb", rot, ref.torques)[:, list(c.axes)]
    return np.concatenate([ref.forces.ravel(), (body / c.lengths).ravel()]), body[0] if p.dim == 3 else None


@pytest.mark.parametrize("model,dim", [("trimer", 3), ("ellipsoid", 2), ("dimer", 2), ("prolate", 3)])
def test_jacobian_of_generalized_forces_is_the_hessian_plus_a_torque_term(model, dim):
    """-d g / d xi (central differences of the reference forces and torques) has M as its
    symmetric part; its antisymmetric part is (1/2) eps_abc tau_c / (d_a d_b) between two
    rotations of one particle (tau in the body frame) and zero elsewhere, so the two agree at
    torque balance. In 2D rotations commute and they agree everywhere."""
    p = model_packing(model, dim)
    c = Coordinates.of(p)
    m = hessian(p).toarray()
    k = int(np.argmax(np.abs(m[:, c.n_translational:]).sum(0))) // c.n_rot  # a particle with contacts
    cols = [c.n_translational + k * c.n_rot + a for a in range(c.n_rot)] + [k * dim, k * dim + 1]
    jac = np.zeros((c.size, len(cols)))
    for n, col in enumerate(cols):
        def d(h):
            e = np.zeros(c.size)
            e[col] = h
            return -(generalized_forces(displaced(p, *c.split(e)))[0]
                     - generalized_forces(displaced(p, *c.split(-e)))[0]) / (2 * h)
        jac[:, n] = (4 * d(1e-4) - d(2e-4)) / 3
    scale = np.abs(m).max()
    r = c.n_rot
    block = jac[cols[:r], :r]
    sym = 0.5 * (block + block.T)
    outside = np.delete(jac[:, :r], cols[:r], axis=0) - np.delete(m[:, cols[:r]], cols[:r], axis=0)
    assert np.abs(sym - m[np.ix_(cols[:r], cols[:r])]).max() < 1e-8 * scale
    assert np.abs(outside).max() < 1e-8 * scale
    assert np.abs(jac[:, r:] - m[:, cols[r:]]).max() < 1e-8 * scale
    anti = 0.5 * (block - block.T)
    if dim == 2:
        assert np.abs(anti).max() < 1e-8 * scale
        return
    rot = rotation_matrices(p.orientations, 3)
    tau = rot[k].T @ energy_forces_pressure(p).torques[k]
    d_k = c.lengths[k]
    eps = np.zeros((3, 3, 3))
    eps[0, 1, 2] = eps[1, 2, 0] = eps[2, 0, 1] = 1.0
    eps[0, 2, 1] = eps[2, 1, 0] = eps[1, 0, 2] = -1.0
    full = 0.5 * np.einsum("abc,c->ab", eps, tau)
    expected = full[np.ix_(c.axes, c.axes)] / np.outer(d_k, d_k)
    assert np.abs(anti - expected).max() < 1e-8 * scale
    if model == "trimer":
        assert np.abs(expected).max() > 1e-3 * scale  # off balance the torque term is really there


def osculating_hessian(pot, r0, sigma0, vertex, curvature_radius, lateral_sign, d_k):
    """Closed form for two identical ellipses touching at vertices (end to end: the tips;
    side by side: the flanks), centre separation r0 along the line through both vertices.
    Near a vertex at distance ``vertex`` from the centre with radius of curvature rho the
    boundary is the circle of radius rho about the point D = vertex - rho on the axis, so
    sigma = 2 vertex - D (a^2 + b^2) / 2 - D^2 (a + b)^2 / (4 rho) + O(4) with a = phi - theta_i,
    b = phi - theta_j (phi: angle of r_hat from the contact line). With s = r / sigma,
    s = s0 + dX / sigma0 + Y^2 / (2 r0 sigma0) + r0 Q / sigma0^2, Q = sigma0 - sigma, for
    dX, Y the changes of r_j - r_i along and across the line. Coordinates (x_i, y_i, x_j, y_j,
    d theta_i, d theta_j) in the frame of the line; phi = lateral_sign * Y / r0."""
    s0 = r0 / sigma0
    v1 = float(pot.energy_force(s0, pot.params)[1])
    v2 = float(pot.curvature(s0, pot.params))
    dd = vertex - curvature_radius
    grad = np.zeros(6)
    grad[0], grad[2] = -1 / sigma0, 1 / sigma0  # along the line: X = x_j - x_i
    # second-order terms as a quadratic form in (Y, theta_i, theta_j): a = sY/r0 - theta_i, ...
    sgn = lateral_sign
    a = np.array([sgn / r0, -1.0, 0.0])
    b = np.array([sgn / r0, 0.0, -1.0])
    q = dd / 2 * (np.outer(a, a) + np.outer(b, b)) + dd**2 / (4 * curvature_radius) * np.outer(a + b, a + b)
    form = 2 * r0 / sigma0**2 * q  # Hessian of r0 Q / sigma0^2
    form[0, 0] += 1 / (r0 * sigma0)  # Hessian of Y^2 / (2 r0 sigma0)
    # map (Y, theta_i, theta_j) to the coordinates: Y = y_j - y_i, theta = w / d_k
    jac = np.zeros((3, 6))
    jac[0, 1], jac[0, 3] = -1.0, 1.0
    jac[1, 4], jac[2, 5] = 1 / d_k, 1 / d_k
    d2s = jac.T @ form @ jac
    return v2 * np.outer(grad, grad) + v1 * d2s


@pytest.mark.parametrize("pot", [Spring(2.0), Spring(2.5)], ids=["spring", "hertz"])
@pytest.mark.parametrize("layout", ["end-to-end", "side-by-side"])
def test_two_ellipses_closed_form(layout, pot):
    alpha, b = 1.8, 1.0
    big_a, big_b = alpha * b / 2, b / 2  # semi-axes
    if layout == "end-to-end":
        r0 = 0.97 * 2 * big_a
        sep, vertex, rho, sign = np.array([r0, 0.0]), big_a, big_b**2 / big_a, 1.0
    else:
        r0 = 0.97 * 2 * big_b
        sep, vertex, rho, sign = np.array([0.0, r0]), big_b, big_a**2 / big_b, -1.0
    p = Packing(np.array([[4.0, 4.0], 4.0 + sep]), np.array([b, b]), Box.cube(8.0, 2), pot, shape=Ellipsoid(alpha),
                orientations=[0.0, 0.0])
    m = hessian(p).toarray()
    d_k = float(p.rotational_lengths[0, 0])
    expected = osculating_hessian(pot, r0, 2 * vertex, vertex, rho, sign, d_k)
    # the matrix is ordered (x_0, y_0, x_1, y_1, w_0, w_1); side by side the line is y
    order = [0, 1, 2, 3, 4, 5] if layout == "end-to-end" else [1, 0, 3, 2, 4, 5]
    got = m[np.ix_(order, order)]
    assert np.allclose(got, expected, rtol=0, atol=1e-10 * np.abs(expected).max())


def test_two_dimers_closed_form():
    """Dimer 0 along x (sites at +-0.25), dimer 1 turned upright above its right site: only
    site (0, right) at (0.25, 0) and site (1, lower) at (0.25, 0.9) overlap. dr = site_0 - site_1
    = (0, -0.9); turning dimer 0 lifts its site (z x (0.25, 0) = (0, 0.25)), turning dimer 1
    moves its lower site sideways (-(z x (0, -0.25)) = (-0.25, 0)) and, at second order, up by
    0.25 theta^2 / 2 (the curvature terms -l_0 and +l_1)."""
    body = dimer(2)
    pot = Spring(2.0)
    p = Packing([[0.0, 0.0], [0.25, 0.9 + 0.25]], [1.0, 1.0], Box.cube(10.0, 2), pot, shape=body,
                orientations=[0.0, np.pi / 2])
    g = float(p.rotational_lengths[0, 0])
    k_n, k_t = 1.0, -(1 - 0.9) / 0.9  # V''(r), V'(r)/r (sigma = 1)
    force = np.array([0.0, 0.1])  # dV/d dr = V'(r) n, n = (0, -1), V'(r) = -0.1
    row_x = np.array([1.0, 0.0, -1.0, 0.0, 0.0, -0.25 / g])  # d dr_x / d(x0, y0, x1, y1, w0, w1)
    row_y = np.array([0.0, 1.0, 0.0, -1.0, 0.25 / g, 0.0])
    expected = k_t * np.outer(row_x, row_x) + k_n * np.outer(row_y, row_y)
    expected[4, 4] += force @ np.array([-0.25, 0.0]) / g**2
    expected[5, 5] += force @ np.array([0.0, -0.25]) / g**2
    assert np.allclose(hessian(p).toarray(), expected, rtol=0, atol=1e-14)
    assert expected[5, 5] < 0  # turning dimer 1 relieves the overlap at second order


def test_ellipse_machinery_reduces_to_the_disk_stiffness():
    """With equal semi-axes (A = beta^2 I) the Perram-Wertheim derivatives give the disk pair
    stiffness K = V'' n n^T + V'/r (I - n n^T), lambda* = beta_i / (beta_i + beta_j)."""
    rng = np.random.default_rng(2)
    p_pairs = 5
    dr = rng.normal(size=(p_pairs, 2))
    dr *= (0.9 * 1.2 / np.linalg.norm(dr, axis=1))[:, None]
    beta_i, beta_j = np.full(p_pairs, 0.5), np.full(p_pairs, 0.7)
    u = np.column_stack([np.cos(rng.random(p_pairs) * 6), np.sin(rng.random(p_pairs) * 6), np.zeros(p_pairs)])
    frame = _PairFrame(2, 1, np.broadcast_to([[[0, 0, 1.0]]], (p_pairs, 1, 3)),
                       np.broadcast_to([[[0, 0, 1.0]]], (p_pairs, 1, 3)), np.ones((p_pairs, 1)), np.ones((p_pairs, 1)))
    lam = beta_i / (beta_i + beta_j)
    semi_i, semi_j = np.column_stack([beta_i, beta_i]), np.column_stack([beta_j, beta_j])
    rvec = np.column_stack([dr, np.zeros(p_pairs)])
    s, ds, d2s = reduced_distance_derivatives(frame, rvec, u, u, semi_i, semi_j, lam, envelope=True)
    pot = Spring(2.0)
    sigma = 1.2
    r = np.linalg.norm(dr, axis=1)
    assert np.allclose(s, r / sigma, rtol=1e-14)
    v1 = pot.energy_force(s, pot.params)[1]
    v2 = pot.curvature(s, pot.params)
    h = v2[:, None, None] * ds[:, :, None] * ds[:, None, :] + v1[:, None, None] * d2s
    k = pair_stiffness(pot, -dr, r, np.full(p_pairs, sigma))  # r_i - r_j = -(r_j - r_i)
    assert np.allclose(h[:, :2, :2], k, rtol=0, atol=1e-13)
    assert np.allclose(h[:, 4:, :], 0.0, atol=1e-13)  # turning a circle changes nothing


def test_linear_contact_methods_are_refused():
    p = dataclasses.replace(model_packing("ellipsoid", 2), shape=Ellipsoid(1.6, "linear"))
    with pytest.raises(ValueError, match="contact 'exact'"):
        hessian(p)
