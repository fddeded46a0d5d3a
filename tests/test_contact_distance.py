"""Tests of jamflow.model.shapes.contact_distance (chapter section 2.3.2).

The reference used throughout is an independent brute-force maximisation of the
Perram-Wertheim contact function in its matrix form,
    h(lambda) = lambda (1 - lambda) r^T [(1 - lambda) A_i + lambda A_j]^{-1} r,
A = (a/2)^2 u u^T + (b/2)^2 (I - u u^T), with a dense lambda grid plus scipy's bounded
Brent search; it shares no code with the module.
"""

import importlib

import numpy as np
import pytest
from scipy.optimize import minimize, minimize_scalar

from jamflow.model.shapes import (APART, OVERLAPPING, TOUCHING, contact_distance, contact_distance_gradient,
                                  contact_function, contact_lambda, lambda_polynomial, overlap_state,
                                  truncation_fallbacks)
from jamflow.plots.ellipse_pair import draw_contact_pair, figure_2_12

cd_module = importlib.import_module("jamflow.model.shapes.contact_distance")  # the module, not the function

# --------------------------------------------------------------------------------------
# independent reference
# --------------------------------------------------------------------------------------


def shape_matrix(a, b, u):
    u = np.asarray(u, dtype=float)
    return (b / 2) ** 2 * np.eye(len(u)) + ((a / 2) ** 2 - (b / 2) ** 2) * np.outer(u, u)


def pw_h(lam, a_i, b_i, a_j, b_j, r, u_i, u_j):
    """Matrix-form contact function; lam may be an array (or complex for complex-step)."""
    lam = np.atleast_1d(lam)
    G = (1 - lam)[:, None, None] * shape_matrix(a_i, b_i, u_i) + lam[:, None, None] * shape_matrix(a_j, b_j, u_j)
    rr = np.broadcast_to(np.asarray(r, dtype=G.dtype), G.shape[:2])
    s = np.linalg.solve(G, rr[..., None])[..., 0]
    return lam * (1 - lam) * np.einsum("k,nk->n", np.asarray(r, float), s)


def brute_sigma(a_i, b_i, a_j, b_j, r, u_i, u_j):
    """(sigma, lambda_min) by dense grid + bounded Brent maximisation of pw_h."""
    args = (a_i, b_i, a_j, b_j, r, u_i, u_j)
    grid = np.linspace(0, 1, 201)[1:-1]
    k = int(np.argmax(pw_h(grid, *args)))
    lo, hi = (grid[k - 1] if k > 0 else 0.0), (grid[k + 1] if k + 1 < len(grid) else 1.0)
    res = minimize_scalar(lambda t: -pw_h(t, *args)[0], bounds=(lo, hi), method="bounded", options={"xatol": 1e-14})
    return (-res.fun) ** -0.5, res.x


RNG_SEED = 20240611


def unit(rng, n, d):
    v = rng.normal(size=(n, d))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def random_pairs(rng, n, dim, *, same_size, alpha_range, size_ratio_max=3.0):
    """Random axes: alpha log-uniform in alpha_range, size ratio a_j / a_i up to 3 either way."""
    lo, hi = np.log(alpha_range[0]), np.log(alpha_range[1])
    a_i = rng.uniform(0.5, 2.0, n)
    b_i = a_i / np.exp(rng.uniform(lo, hi, n))
    if same_size:
        a_j, b_j = a_i.copy(), b_i.copy()
    else:
        a_j = a_i * np.exp(rng.uniform(-np.log(size_ratio_max), np.log(size_ratio_max), n))
        b_j = a_j / np.exp(rng.uniform(lo, hi, n))
    return a_i, b_i, a_j, b_j, unit(rng, n, dim), unit(rng, n, dim), unit(rng, n, dim)


CASES = {
    "2d-mono": (2, True, (1.001, 10.0)),
    "2d-bi": (2, False, (1.001, 10.0)),
    "3d-mono-prolate-oblate": (3, True, (0.1, 10.0)),
    "3d-bi-prolate-oblate": (3, False, (0.1, 10.0)),
}


EXTREMES = [(1.001, 10.0, 3.0), (10.0, 10.0, 1 / 3), (1.001, 1.001, 3.0), (10.0, 1.001, 3.0)]


def extreme_pairs(rng, n, dim, same_size):
    """Pairs at alpha 1.001 and 10 (and 1/10, 1/1.001 oblate in 3D) with size ratio 3."""
    blocks = []
    for k, (al_i, al_j, s) in enumerate(EXTREMES):
        if dim == 3 and k % 2:
            al_i, al_j = 1 / al_i, 1 / al_j
        if same_size:
            al_j, s = al_i, 1.0
        axes = (np.ones(n), np.full(n, 1 / al_i), np.full(n, s), np.full(n, s / al_j))
        blocks.append(axes + (unit(rng, n, dim), unit(rng, n, dim), unit(rng, n, dim)))
    return tuple(np.concatenate(parts) for parts in zip(*blocks))


@pytest.fixture(scope="module", params=sorted(CASES))
def random_case(request):
    dim, same, alpha_range = CASES[request.param]
    rng = np.random.default_rng(RNG_SEED + sorted(CASES).index(request.param))
    bulk = random_pairs(rng, 150, dim, same_size=same, alpha_range=alpha_range)
    ext = extreme_pairs(rng, 10, dim, same)
    pairs = tuple(np.concatenate([x, y]) for x, y in zip(bulk, ext))
    ref = np.array([brute_sigma(*cfg) for cfg in zip(*pairs)])
    return request.param, pairs, ref


# --------------------------------------------------------------------------------------
# exact vs brute force
# --------------------------------------------------------------------------------------


def test_exact_matches_brute_force(random_case):
    name, pairs, ref = random_case
    sigma = contact_distance(*pairs, method="exact")
    rel = np.abs(sigma / ref[:, 0] - 1)
    assert rel.max() < 1e-12, f"{name}: worst relative difference {rel.max():.2e}"
    # lambda_min agrees to the brute-force search's own resolution (h is flat at its maximum)
    lam = contact_lambda(*pairs, method="exact")
    assert np.max(np.abs(lam - ref[:, 1])) < 1e-6


def test_polynomial_and_maximisation_paths_agree(random_case):
    """The quartic/quintic root and the generic safeguarded maximisation give the same lambda."""
    name, pairs, _ = random_case
    p = cd_module._validate(*pairs)
    lam_max = cd_module._lambda_maximise(p)
    if name.startswith("3d-bi"):
        with pytest.raises(ValueError, match="identical spheroids"):
            lambda_polynomial(*pairs)
        return
    lam_poly = cd_module._lambda_polynomial(p)
    assert np.max(np.abs(lam_poly - lam_max)) < 1e-10
    assert np.max(np.abs(cd_module._sigma_at(p, lam_poly) / cd_module._sigma_at(p, lam_max) - 1)) < 1e-14


def test_approximations_are_upper_bounds(random_case):
    """Every method evaluates sigma(lambda) at some lambda, so it cannot undercut the exact sigma."""
    name, pairs, ref = random_case
    methods = ["cleaver"] + (["linear", "quadratic"] if not name.startswith("3d-bi") else [])
    methods += ["gaussian"] if "mono" in name else []
    for method in methods:
        sigma = contact_distance(*pairs, method=method)
        assert np.all(sigma >= ref[:, 0] * (1 - 1e-13)), method


# --------------------------------------------------------------------------------------
# closed-form cases
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("dim", [2, 3])
def test_circles_and_spheres_of_any_two_sizes(dim):
    rng = np.random.default_rng(1)
    d_i, d_j = rng.uniform(0.2, 3, 50), rng.uniform(0.2, 3, 50)
    vecs = [unit(rng, 50, dim) for _ in range(3)]
    sigma = contact_distance(d_i, d_i, d_j, d_j, *vecs)
    np.testing.assert_allclose(sigma, (d_i + d_j) / 2, rtol=1e-14)
    assert float(contact_distance(1.0, 1.0, 1.0, 1.0, *(v[0] for v in vecs), method="gaussian")) == pytest.approx(1.0, rel=1e-15)


AXES_3D = [np.eye(3)[k] for k in range(3)]


@pytest.mark.parametrize("dim,alpha", [(2, 2.0), (2, 10.0), (3, 3.0), (3, 0.25)])
def test_equal_particles_end_to_end_side_by_side_end_to_side(dim, alpha):
    a, b = 1.3, 1.3 / alpha
    ex, ey = np.eye(dim)[0], np.eye(dim)[1]
    cases = [
        ("end to end", ex, ex, a),
        ("side by side", ey, ey, b),
        ("end to side", ex, ey, (a + b) / 2),
        ("side to end", ey, ex, (a + b) / 2),
    ]
    if dim == 3:
        cases.append(("crossed, both across r", ey, np.eye(3)[2], b))
    for label, u_i, u_j, expected in cases:
        # J = 0 (same angle with r_hat) makes lambda = 1/2 exact, so every method is exact there
        j_zero = abs(u_i @ ex) == abs(u_j @ ex)
        for method in ("exact", "linear", "quadratic", "gaussian") if j_zero else ("exact",):
            got = float(contact_distance(a, b, a, b, ex, u_i, u_j, method=method))
            assert got == pytest.approx(expected, rel=1e-13), (label, method)
        if not j_zero:  # the approximations are not exact end to side
            assert float(contact_distance(a, b, a, b, ex, u_i, u_j, method="linear")) > expected * (1 + 1e-6)


@pytest.mark.parametrize("dim", [2, 3])
def test_unequal_end_to_side_and_gaussian_side_to_end(dim):
    ex, ey = np.eye(dim)[0], np.eye(dim)[1]
    a_i, b_i, a_j, b_j = 1.0, 0.4, 2.1, 0.6
    assert float(contact_distance(a_i, b_i, a_j, b_j, ex, ex, ey)) == pytest.approx((a_i + b_j) / 2, rel=1e-13)
    assert float(contact_distance(a_i, b_i, a_j, b_j, ex, ey, ex)) == pytest.approx((b_i + a_j) / 2, rel=1e-13)
    # Berne-Pechukas: exact end to end and side by side, sqrt((a^2+b^2)/2) side to end (Fig. 2.12)
    a, b = 1.0, 0.5
    assert float(contact_distance(a, b, a, b, ex, ex, ex, method="gaussian")) == pytest.approx(a, rel=1e-14)
    assert float(contact_distance(a, b, a, b, ex, ey, ey, method="gaussian")) == pytest.approx(b, rel=1e-14)
    side_end = float(contact_distance(a, b, a, b, ex, ey, ex, method="gaussian"))
    assert side_end == pytest.approx(np.sqrt((a * a + b * b) / 2), rel=1e-14)
    assert side_end / 0.75 - 1 == pytest.approx(0.054, abs=5e-4)  # "5%" in Figure 2.12(b)


@pytest.mark.parametrize("ratio", [1.4, 1.2, 1.6])
def test_table_2_1_at_alpha_1_is_closed_form(ratio):
    """Table 2.1 at alpha = 1 (docs/notes/contact-distance.md): circles of diameters 1 and r. Exact sigma = (1 + r)/2;
    sigma(lambda) = sqrt(1/lambda + r^2/(1 - lambda)) / 2 (sigma_0(lambda), chi = 0); Cleaver (eq. 2.6)
    is lambda = 1/2; J = r^2 - 1, K = r^4 - 1, L = 2 r^2 - 2 in eqs 2.8-2.15 give q0 = -(r^2-1)(r^2+1)^2/16,
    q1 = -(r^4+1)(r^2+1)/2, q2 = -(r^2-1)(3 r^4 + 4 r^2 + 3)/2, the truncated roots y = lambda - 1/2 of
    eq. 2.26. The same error for every orientation: log10 -1.86, -3.69, -6.16 at r = 1.4 (chapter:
    -2.0, -3.9, -6.3; docs/notes/contact-distance.md). Berne-Pechukas (eq. 2.5) is exact for equal circles."""
    r2 = ratio * ratio
    q0, q1, q2 = -(r2 - 1) * (r2 + 1) ** 2 / 16, -(r2 * r2 + 1) * (r2 + 1) / 2, -(r2 - 1) * (3 * r2 * r2 + 4 * r2 + 3) / 2
    y = {"cleaver": 0.0, "linear": -q0 / q1, "quadratic": -2 * q0 / (q1 - np.sqrt(q1 * q1 - 4 * q0 * q2))}
    rng = np.random.default_rng(3)
    vecs = [unit(rng, 20, 2) for _ in range(3)]
    exact = contact_distance(1.0, 1.0, ratio, ratio, *vecs)
    np.testing.assert_allclose(exact, (1 + ratio) / 2, rtol=1e-14)
    for method, y_m in y.items():
        lam = 0.5 + y_m
        closed = np.sqrt(1 / lam + r2 / (1 - lam)) / 2
        np.testing.assert_allclose(contact_distance(1.0, 1.0, ratio, ratio, *vecs, method=method), closed, rtol=1e-14)
    if ratio == 1.4:
        logs = [np.log10(np.sqrt(1 / (0.5 + y_m) + r2 / (0.5 - y_m)) / 2 / 1.2 - 1) for y_m in y.values()]
        np.testing.assert_allclose(logs, [-1.860, -3.692, -6.160], atol=5e-4)
    np.testing.assert_allclose(contact_distance(1.0, 1.0, 1.0, 1.0, *vecs, method="gaussian"), 1.0, rtol=1e-15)


def test_berne_pechukas_largest_error_is_side_to_end():
    """Eq. 2.5 on identical ellipses: the largest relative error over all orientations is the side-to-end
    one, sqrt(2 (alpha^2 + 1)) / (alpha + 1) - 1 (0.41 % at alpha = 1.2): so no average of eq. 2.5 errors
    reaches Table 2.1's Gaussian entry -2.0 (1 %) at alpha = 1.2; the column is the unequal pair's eq. 2.6."""
    t = np.arange(180) * np.pi / 90  # 2-degree grid, side to end (0, pi/2) included
    ti, tj = (g.ravel() for g in np.meshgrid(t, t))
    u = lambda x: np.stack([np.cos(x), np.sin(x)], -1)
    for alpha in (1.2, 2.0, 5.0):
        args = (1.0, 1 / alpha, 1.0, 1 / alpha, u(0 * ti), u(ti), u(tj))
        err = contact_distance(*args, method="gaussian") / contact_distance(*args) - 1
        bound = np.sqrt(2 * (alpha**2 + 1)) / (alpha + 1) - 1
        assert err.max() == pytest.approx(bound, rel=1e-12), alpha
        assert err.min() > -1e-14  # eq. 2.5 never under-estimates
    assert np.log10(np.sqrt(2 * 2.44) / 2.2 - 1) < -2.3


def test_figure_2_12_relative_errors():
    _, errors = figure_2_12(None)
    np.testing.assert_allclose(errors, [0.0, 0.0541, 0.0138, 0.1065], atol=5e-4)


@pytest.mark.parametrize("dim", [2, 3])
def test_J_zero_symmetry_gives_lambda_one_half_and_gaussian(dim):
    """Equal particles whose directors make the same angle with r_hat: f(y) is odd, lambda = 1/2."""
    rng = np.random.default_rng(7)
    n = 40
    r = unit(rng, n, dim)
    u_i = unit(rng, n, dim)
    # u_j: reflection of u_i through the plane (line in 2D) normal to r or a rotation about r
    u_j = u_i - 2 * np.sum(u_i * r, 1)[:, None] * r
    if dim == 3:
        u_j = np.where(rng.random(n)[:, None] < 0.5, u_j, _rotate_about(u_i, r, rng.uniform(0, 2 * np.pi, n)))
    a, b = 1.0, rng.uniform(0.1, 3.0, n)  # prolate and oblate
    q = lambda_polynomial(a, b, a, b, r, u_i, u_j)
    assert np.max(np.abs(q[:, 0::2])) < 1e-12 * np.max(np.abs(q))
    np.testing.assert_allclose(contact_lambda(a, b, a, b, r, u_i, u_j), 0.5, atol=1e-12)
    np.testing.assert_allclose(
        contact_distance(a, b, a, b, r, u_i, u_j), contact_distance(a, b, a, b, r, u_i, u_j, method="gaussian"), rtol=1e-13
    )


def _rotate_about(v, axis, angle):
    c, s = np.cos(angle)[:, None], np.sin(angle)[:, None]
    return v * c + np.cross(axis, v) * s + axis * np.sum(axis * v, 1)[:, None] * (1 - c)


# --------------------------------------------------------------------------------------
# the chapter's formulas, transcribed here independently of the module
# --------------------------------------------------------------------------------------


def chapter_eq_2_6(a_i, b_i, a_j, b_j, r, u_i, u_j):
    """Cleaver et al., eq. 2.6 as printed (real only for two prolate or two oblate particles)."""
    s0 = np.sqrt((b_i**2 + b_j**2) / 2)
    chi = np.sqrt((a_i**2 - b_i**2) * (a_j**2 - b_j**2) / ((a_j**2 + b_i**2) * (a_i**2 + b_j**2)))
    beta = ((a_i**2 - b_i**2) * (a_j**2 + b_i**2) / ((a_j**2 - b_j**2) * (a_i**2 + b_j**2))) ** 0.25
    x, z, m = r @ u_i, r @ u_j, u_i @ u_j
    total = sum((beta * x + sg * z / beta) ** 2 / (1 + sg * chi * m) for sg in (1, -1))
    return s0 / np.sqrt(1 - chi / 2 * total)


def chapter_eq_2_5(a, b, r, u_i, u_j):
    chi = (a**2 - b**2) / (b**2 + a**2)
    x, z, m = r @ u_i, r @ u_j, u_i @ u_j
    total = sum((x + sg * z) ** 2 / (1 + sg * chi * m) for sg in (1, -1))
    return b / np.sqrt(1 - chi / 2 * total)


def chapter_quartic(a_i, b_i, a_j, b_j, r, u_i, u_j, l_sign):
    """Eqs 2.8-2.15; l_sign = +1 is eq. 2.15 as printed, -1 the corrected sign."""
    x, z, m = r @ u_i, r @ u_j, u_i @ u_j
    J = (a_j**2 - (a_j**2 - b_j**2) * z**2) / (a_i**2 - (a_i**2 - b_i**2) * x**2) - 1
    K = (a_j * b_j / (a_i * b_i)) ** 2 - 1
    L = (a_i**2 * a_j**2 + b_i**2 * b_j**2 + l_sign * (a_i**2 - b_i**2) * (a_j**2 - b_j**2) * m**2) / (a_i**2 * b_i**2) - 2
    return np.array(
        [J * (L + 4) / 16 - K * (J + 4) / 16, -(1 + K / 2) * (J + 2), -J * (L + 6) / 2 - K * (3 * J + 2) / 2, -2 * J * K, J * (L - K)]
    )


def chapter_quintic(alpha, r, u_i, u_j):
    """Eqs 2.16-2.25 as printed."""
    x, z, m = r @ u_i, r @ u_j, u_i @ u_j
    e = (alpha**2 - 1) / alpha**2
    J = e * (x**2 - z**2) / (1 - e * x**2)
    L = (alpha**2 - 1) ** 2 / alpha**2 * (1 - m**2)
    M = (alpha**2 - 1) ** 2 / alpha**2 / (1 - e * x**2) * (x**2 + z**2 - m * (2 * x * z - m) - 1)
    return np.array([J * (L + 4) / 16, -(J + 2) + M * (L + 8) / 8, -J * (L + 6) / 2, -M * (L + 4), J * L, 2 * M * L])


def definition_residual(q, a_i, b_i, a_j, b_j, r, u_i, u_j):
    """How far f(y) is from being proportional to dh/dy * det(G)^2 (G = (1-l) A_i + l A_j).

    For the chapter's f(y) = numerator of dh/dy, this product is s * f(y) with one constant s
    (det G is the denominator of h up to a constant factor in both the 2D and the 3D-mono case).
    dh/dlambda by complex step through the matrix form. Returns the relative residual of the fit.
    """
    ys = np.linspace(-0.45, 0.45, 9)
    lam = 0.5 + ys
    step = 1e-30
    dh = pw_h(lam + 1j * step, a_i, b_i, a_j, b_j, r, u_i, u_j).imag / step
    G = (1 - lam)[:, None, None] * shape_matrix(a_i, b_i, u_i) + lam[:, None, None] * shape_matrix(a_j, b_j, u_j)
    lhs = dh * np.linalg.det(G) ** 2
    f = np.polynomial.polynomial.polyval(ys, q)
    s = np.dot(lhs, f) / np.dot(f, f)
    return np.max(np.abs(lhs - s * f)) / np.max(np.abs(lhs))


def test_chapter_coefficients_against_the_definition():
    rng = np.random.default_rng(11)
    worst_fixed, worst_printed, worst_quintic = 0.0, 0.0, 0.0
    for a_i, b_i, a_j, b_j, r, u_i, u_j in zip(*random_pairs(rng, 40, 2, same_size=False, alpha_range=(1.2, 5))):
        args = (a_i, b_i, a_j, b_j, r, u_i, u_j)
        fixed = chapter_quartic(*args, l_sign=-1)
        np.testing.assert_allclose(lambda_polynomial(*args), fixed, rtol=1e-10, atol=1e-12 * np.abs(fixed).max())
        worst_fixed = max(worst_fixed, definition_residual(fixed, *args))
        worst_printed = max(worst_printed, definition_residual(chapter_quartic(*args, l_sign=+1), *args))
    for a_i, b_i, _, _, r, u_i, u_j in zip(*random_pairs(rng, 40, 3, same_size=True, alpha_range=(0.2, 5))):
        args = (a_i, b_i, a_i, b_i, r, u_i, u_j)
        printed = chapter_quintic(a_i / b_i, r, u_i, u_j)
        np.testing.assert_allclose(lambda_polynomial(*args), printed, rtol=1e-9, atol=1e-12 * np.abs(printed).max())
        worst_quintic = max(worst_quintic, definition_residual(printed, *args))
    assert worst_fixed < 1e-9  # eqs 2.8-2.14 with the corrected eq. 2.15 are exact
    assert worst_quintic < 1e-9  # eqs 2.16-2.25 are exact as printed
    assert worst_printed > 1e-2  # eq. 2.15 as printed (+ m^2 term) is not


def test_one_root_in_the_physical_interval_and_it_is_the_one_used():
    """f has other real roots, but exactly one in y in (-1/2, 1/2): the one we return."""
    rng = np.random.default_rng(5)
    pairs = random_pairs(rng, 200, 2, same_size=False, alpha_range=(1.001, 10))
    q = lambda_polynomial(*pairs)
    lam = contact_lambda(*pairs)
    outside = 0
    for k in range(len(q)):
        roots = np.roots(q[k, ::-1])
        real = roots[np.abs(roots.imag) < 1e-9].real
        inside = real[np.abs(real) < 0.5]
        outside += np.sum(np.abs(real) >= 0.5)
        assert len(inside) == 1
        assert inside[0] + 0.5 == pytest.approx(lam[k], abs=1e-7)
    assert outside > 0  # the spurious roots exist, so the choice matters


def test_cleaver_and_gaussian_are_perram_wertheim_at_one_half_and_match_eqs_2_5_2_6():
    rng = np.random.default_rng(3)
    for dim in (2, 3):
        pairs = random_pairs(rng, 40, dim, same_size=False, alpha_range=(1.05, 6))  # prolate pairs: eq 2.6 real
        cle = contact_distance(*pairs, method="cleaver")
        half = np.array([pw_h(0.5, *cfg)[0] ** -0.5 for cfg in zip(*pairs)])
        lit = np.array([chapter_eq_2_6(*cfg) for cfg in zip(*pairs)])
        np.testing.assert_allclose(cle, half, rtol=1e-13)
        np.testing.assert_allclose(cle, lit, rtol=1e-12)
        a, b, _, _, r, u_i, u_j = random_pairs(rng, 40, dim, same_size=True, alpha_range=(1.05, 6))
        gau = contact_distance(a, b, a, b, r, u_i, u_j, method="gaussian")
        np.testing.assert_allclose(gau, [chapter_eq_2_5(*cfg) for cfg in zip(a, b, r, u_i, u_j)], rtol=1e-12)


def chapter_sigma_of_lambda(lam, a_i, b_i, a_j, b_j, r, u_i, u_j):
    """The chapter's sigma(lambda) (text after eq. 2.6) with chi(lambda), beta(lambda) corrected:
    chi^2 = (a_i^2-b_i^2)(a_j^2-b_j^2) / ((a_j^2 + (1-l)/l b_i^2)(a_i^2 + l/(1-l) b_j^2)),
    beta^4 = (a_i^2-b_i^2)(a_j^2 + (1-l)/l b_i^2) / ((a_j^2-b_j^2)(a_i^2 + l/(1-l) b_j^2))."""
    s0 = 0.5 * np.sqrt(b_i**2 / lam + b_j**2 / (1 - lam))
    den_i, den_j = a_i**2 + lam / (1 - lam) * b_j**2, a_j**2 + (1 - lam) / lam * b_i**2
    chi = np.sqrt((a_i**2 - b_i**2) * (a_j**2 - b_j**2) / (den_j * den_i))
    beta = ((a_i**2 - b_i**2) * den_j / ((a_j**2 - b_j**2) * den_i)) ** 0.25
    x, z, m = r @ u_i, r @ u_j, u_i @ u_j
    total = sum((beta * x + sg * z / beta) ** 2 / (1 + sg * chi * m) for sg in (1, -1))
    return s0 / np.sqrt(1 - chi / 2 * total)


def test_chapter_sigma_of_lambda_with_corrected_parameters_is_the_contact_function():
    rng = np.random.default_rng(21)
    for dim in (2, 3):
        for cfg in zip(*random_pairs(rng, 20, dim, same_size=False, alpha_range=(1.05, 6))):
            for lam in (0.1, 0.37, 0.5, 0.8):
                assert chapter_sigma_of_lambda(lam, *cfg) == pytest.approx(pw_h(lam, *cfg)[0] ** -0.5, rel=1e-12)


def test_contact_function_matches_matrix_form():
    rng = np.random.default_rng(8)
    for dim in (2, 3):
        pairs = random_pairs(rng, 30, dim, same_size=False, alpha_range=(0.2, 8))
        lam = rng.uniform(0.01, 0.99, 30)
        ref = np.array([pw_h(t, *cfg)[0] for t, cfg in zip(lam, zip(*pairs))])
        np.testing.assert_allclose(contact_function(lam, *pairs), ref, rtol=1e-12)


def test_linear_and_quadratic_improve_on_cleaver_for_moderate_alpha():
    rng = np.random.default_rng(4)
    n = 4000
    th = rng.uniform(0, 2 * np.pi, (3, n))
    vec = lambda t: np.stack([np.cos(t), np.sin(t)], -1)  # noqa: E731
    for alpha in (1.2, 1.5, 2.0):
        args = (1.0, 1 / alpha, 1.4, 1.4 / alpha, vec(th[0]), vec(th[1]), vec(th[2]))
        exact = contact_distance(*args)
        err = {m: np.mean(contact_distance(*args, method=m) / exact - 1) for m in ("cleaver", "linear", "quadratic")}
        assert err["quadratic"] < err["linear"] < err["cleaver"], (alpha, err)


# --------------------------------------------------------------------------------------
# derivatives
# --------------------------------------------------------------------------------------


def _tangent(rng, v):
    t = rng.normal(size=v.shape)
    t -= np.sum(t * v, 1)[:, None] * v
    return t / np.linalg.norm(t, axis=1, keepdims=True)


GRADIENT_CASES = [(dim, method, same) for dim in (2, 3)
                  for method, same in [("exact", False), ("exact", True), ("cleaver", False), ("gaussian", True),
                                       ("linear", False), ("quadratic", False), ("linear", True), ("quadratic", True)]
                  if not (dim == 3 and method in ("linear", "quadratic") and not same)]  # refused there


@pytest.mark.parametrize("dim,method,same", GRADIENT_CASES)
def test_gradients_against_finite_differences(dim, method, same):
    """Every method's gradient is the derivative of its own sigma (for linear/quadratic including
    the change of their lambda; pairs whose truncation falls back to 1/2 within the step left out)."""
    rng = np.random.default_rng(100 + dim)
    pairs = random_pairs(rng, 200, dim, same_size=same, alpha_range=(0.25 if dim == 3 else 1.001, 6))
    axes, vecs = pairs[:4], list(pairs[4:])
    sigma, *grads = contact_distance_gradient(*pairs, method=method)
    np.testing.assert_allclose(sigma, contact_distance(*pairs, method=method), rtol=1e-14)
    h = 1e-6
    steady = lambda args: (truncation_fallbacks(*args, method=method) if method in ("linear", "quadratic")  # noqa: E731
                           else np.zeros(len(sigma), bool))
    checked = 0
    for k, grad in enumerate(grads):
        assert np.max(np.abs(np.sum(grad * vecs[k], 1))) < 1e-12 * sigma.max()  # tangential
        t = _tangent(rng, vecs[k])
        plus, minus = list(vecs), list(vecs)
        plus[k] = (vecs[k] + h * t) / np.linalg.norm(vecs[k] + h * t, axis=1, keepdims=True)
        minus[k] = (vecs[k] - h * t) / np.linalg.norm(vecs[k] - h * t, axis=1, keepdims=True)
        fd = (contact_distance(*axes, *plus, method=method) - contact_distance(*axes, *minus, method=method)) / (2 * h)
        same_branch = (steady((*axes, *plus)) == steady(pairs)) & (steady((*axes, *minus)) == steady(pairs))
        np.testing.assert_allclose(np.sum(grad * t, 1)[same_branch], fd[same_branch], atol=1e-8 * sigma.max())
        checked += same_branch.sum()
    assert checked > 0.9 * 3 * len(sigma)


def test_gradient_gives_2d_torque_derivative():
    """d sigma / d theta_i = dsigma_du_i . (-sin, cos) for u_i = (cos theta_i, sin theta_i)."""
    th, h = 0.7, 1e-6
    args = lambda t: (1.0, 0.4, 1.5, 0.5, np.array([1.0, 0.0]), np.array([np.cos(t), np.sin(t)]), np.array([0.0, 1.0]))  # noqa: E731
    _, _, d_ui, _ = contact_distance_gradient(*args(th))
    fd = (contact_distance(*args(th + h)) - contact_distance(*args(th - h))) / (2 * h)
    assert float(d_ui @ np.array([-np.sin(th), np.cos(th)])) == pytest.approx(float(fd), abs=1e-8)


def test_truncated_gradient_includes_the_change_of_lambda():
    """For linear/quadratic the fixed-lambda (envelope) gradient is wrong: the difference is
    dsigma/dlambda dlambda/dx, which finite differences see."""
    rng = np.random.default_rng(7)
    pairs = random_pairs(rng, 50, 2, same_size=False, alpha_range=(1.5, 2.5))
    p = cd_module._validate(*pairs)
    for method in ("linear", "quadratic"):
        _, d_full, _, _ = cd_module._sigma_gradient(p, cd_module._lambda(p, method), cd_module._root_partials(p, method))
        _, d_fixed, _, _ = cd_module._sigma_gradient(p, cd_module._lambda(p, method))
        assert np.max(np.abs(d_full - d_fixed)) > 1e-6


# --------------------------------------------------------------------------------------
# overlap test, checked geometrically
# --------------------------------------------------------------------------------------


def min_F_i_on_surface_of_j(a_i, b_i, a_j, b_j, r_vec, u_i, u_j):
    """min over the surface of j (centred at r_vec) of F_i = p^T A_i^{-1} p (i at the origin)."""
    Ai_inv = np.linalg.inv(shape_matrix(a_i, b_i, u_i))
    dim = len(r_vec)
    frame = np.linalg.qr(np.column_stack([u_j, np.eye(dim)]))[0][:, :dim]
    frame[:, 0] = u_j

    def point(params):
        if dim == 2:
            local = np.array([a_j / 2 * np.cos(params[0]), b_j / 2 * np.sin(params[0])])
        else:
            th, ph = params
            local = np.array([a_j / 2 * np.cos(th), b_j / 2 * np.sin(th) * np.cos(ph), b_j / 2 * np.sin(th) * np.sin(ph)])
        return r_vec + frame @ local

    F = lambda params: float(point(params) @ Ai_inv @ point(params))  # noqa: E731
    grid = [np.linspace(0, 2 * np.pi, 721)[:-1]] if dim == 2 else list(np.meshgrid(np.linspace(0, np.pi, 31), np.linspace(0, 2 * np.pi, 61)))
    pts = np.stack([g.ravel() for g in grid], 1)
    best = pts[np.argmin([F(pp) for pp in pts])]
    res = minimize(F, best, method="Nelder-Mead", options={"xatol": 1e-12, "fatol": 1e-15, "maxiter": 4000})
    return res.fun


@pytest.mark.parametrize("dim", [2, 3])
def test_overlap_state_touching_overlapping_apart(dim):
    rng = np.random.default_rng(50 + dim)
    a_i, b_i, a_j, b_j, r, u_i, u_j = random_pairs(rng, 4, dim, same_size=False, alpha_range=(0.3 if dim == 3 else 1.2, 4))
    sigma = contact_distance(a_i, b_i, a_j, b_j, r, u_i, u_j)
    for scale, state in ((1 - 1e-5, OVERLAPPING), (1.0, TOUCHING), (1 + 1e-5, APART)):
        r_vec = r * (scale * sigma)[:, None]
        np.testing.assert_array_equal(overlap_state(a_i, b_i, a_j, b_j, r_vec, u_i, u_j), state)
        geometric = np.array([min_F_i_on_surface_of_j(*cfg) for cfg in zip(a_i, b_i, a_j, b_j, r_vec, u_i, u_j)])
        if state == OVERLAPPING:
            assert np.all(geometric < 1 - 1e-7)
        elif state == APART:
            assert np.all(geometric > 1 + 1e-7)
        else:
            np.testing.assert_allclose(geometric, 1.0, atol=1e-8)


# --------------------------------------------------------------------------------------
# vectorisation, bad input, plot helper
# --------------------------------------------------------------------------------------


def test_broadcasting_over_leading_dimensions():
    rng = np.random.default_rng(9)
    r = unit(rng, 12, 3).reshape(3, 4, 3)
    u_i = unit(rng, 4, 3)  # broadcasts against (3, 4)
    u_j = unit(rng, 1, 3)[0]
    a_j = np.array([[1.0], [1.5], [2.0]])
    sigma = contact_distance(1.0, 0.3, a_j, 0.5, r, u_i, u_j)
    assert sigma.shape == (3, 4)
    for k in range(3):
        for m in range(4):
            assert sigma[k, m] == pytest.approx(brute_sigma(1.0, 0.3, a_j[k, 0], 0.5, r[k, m], u_i[m], u_j)[0], rel=1e-12)
    _, d_r, d_ui, _ = contact_distance_gradient(1.0, 0.3, a_j, 0.5, r, u_i, u_j)
    assert d_r.shape == d_ui.shape == (3, 4, 3)


E2 = np.array([1.0, 0.0])


@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(a_i=0.0), "a_i must be finite and > 0"),
        (dict(b_j=-1.0), "b_j must be finite and > 0"),
        (dict(r_hat=np.zeros(2)), "r_hat contains a zero vector"),
        (dict(u_i=np.array([1.0, 1.0])), "u_i must be unit vectors"),
        (dict(u_j=np.array([np.nan, 1.0])), "u_j contains NaN"),
        (dict(u_j=np.array([1.0, 0.0, 0.0])), "must all be 2D or all 3D"),
        (dict(r_hat=np.ones((3, 2)) / np.sqrt(2), u_i=np.ones((4, 2)) / np.sqrt(2)), "mismatched shapes"),
        (dict(r_hat=np.ones(4) / 2), "last dimension of 2"),
        (dict(method="bogus"), "unknown or unsupported method 'bogus'"),
        (dict(a_j=1.4, b_j=0.7, method="gaussian"), "identical particles"),
    ],
)
def test_bad_input_raises_clear_value_error(kwargs, match):
    base = dict(a_i=1.0, b_i=0.5, a_j=1.0, b_j=0.5, r_hat=E2, u_i=E2, u_j=E2, method="exact")
    base.update(kwargs)
    with pytest.raises(ValueError, match=match):
        contact_distance(**base)


def test_polynomial_approximations_refused_for_unequal_spheroids():
    e = np.array([1.0, 0.0, 0.0])
    for method in ("linear", "quadratic"):
        with pytest.raises(ValueError, match="identical spheroids"):
            contact_distance(1.0, 0.5, 2.0, 0.5, e, e, e, method=method)
    # ... but the exact method and Cleaver work there
    assert float(contact_distance(1.0, 0.5, 2.0, 0.5, e, e, e)) == pytest.approx(1.5, rel=1e-13)


def test_contact_function_rejects_lambda_outside_open_interval():
    with pytest.raises(ValueError, match="strictly between 0 and 1"):
        contact_function(1.0, 1, 0.5, 1, 0.5, E2, E2, E2)


def test_plot_helper_places_ellipses_at_contact(tmp_path):
    from matplotlib.figure import Figure

    fig = Figure()
    ax = fig.add_subplot()
    u_j = np.array([np.cos(0.6), np.sin(0.6)])
    r_hat = np.array([np.cos(0.2), np.sin(0.2)])
    sigma, c_j = draw_contact_pair(ax, 1.0, 0.5, 1.4, 0.7, r_hat, E2, u_j)
    assert len(ax.patches) == 2
    assert np.linalg.norm(c_j) == pytest.approx(sigma)
    assert overlap_state(1.0, 0.5, 1.4, 0.7, c_j, E2, u_j) == TOUCHING
    out = tmp_path / "fig.png"
    figure_2_12(out)
    assert out.stat().st_size > 1000


def test_failed_truncation_falls_back_to_cleaver():
    """At alpha = 10 the linear root often leaves (-1/2, 1/2), or lands where sigma(lambda) exceeds
    the Cleaver value; there 'linear' equals 'cleaver', elsewhere it improves on it."""
    rng = np.random.default_rng(12)
    th = rng.uniform(0, 2 * np.pi, (3, 400))
    vec = lambda t: np.stack([np.cos(t), np.sin(t)], -1)  # noqa: E731
    args = (1.0, 0.1, 1.4, 0.14, vec(th[0]), vec(th[1]), vec(th[2]))
    q = lambda_polynomial(*args)
    left = np.abs(q[:, 0] / q[:, 1]) >= 0.5
    failed = truncation_fallbacks(*args, method="linear")
    assert np.all(failed[left]) and failed.sum() > left.sum() > 0 and failed.sum() < len(failed)
    lin, cle = contact_distance(*args, method="linear"), contact_distance(*args, method="cleaver")
    np.testing.assert_array_equal(lin[failed], cle[failed])
    assert np.all(np.isfinite(lin)) and np.all(lin[~failed] < cle[~failed])


@pytest.mark.parametrize("method", ["linear", "quadratic"])
def test_truncations_never_exceed_cleaver(method):
    """Without the sigma test the linear root near the ends of (0, 1) gave sigma up to ~100x the
    exact one at alpha >= 3; with it every truncation is bounded by eq. 2.6 (as pair lists assume)."""
    rng = np.random.default_rng(3)
    for alpha in (3.0, 10.0):
        args = random_pairs(rng, 20000, 2, same_size=False, alpha_range=(alpha, alpha))
        assert np.all(contact_distance(*args, method=method) <= contact_distance(*args, method="cleaver"))
