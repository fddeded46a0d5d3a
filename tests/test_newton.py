"""The trust-region Newton-Krylov minimiser (jamflow.minimize.newton): closed cases, the exact
Hessian against finite differences of the gradient, the gradient against the engine's forces,
the piecewise line minimum against brute force, FIRE's minimum reached again, and a jam that uses
it passing its checks, bit-identical on a rerun."""

from dataclasses import replace

import numpy as np
import pytest

import jamflow
from jamflow.engines.compiled.engine import CompiledEngine
from jamflow.mechanics.checks import check_packing
from jamflow.minimize import cholesky, newton
from jamflow.minimize.rules import minimize
from jamflow.minimize.settings import MinimizerSettings
from jamflow.model.box import Box
from jamflow.model.packing import Packing
from jamflow.model.potentials import Spring
from jamflow.protocols.settings import fast_protocol

from conftest import tilted


def _engine(positions, diameters, length=10.0):
    box = Box.cube(length, len(positions[0]))
    return CompiledEngine(Packing(np.asarray(positions, float), np.asarray(diameters, float), box, Spring()))


def _compressed(packing, dphi):
    """An onset packing compressed affinely by dphi (not minimised)."""
    box = packing.box.scaled((packing.phi / (packing.phi + dphi)) ** (1 / packing.dim))
    return packing.with_positions(box.to_cartesian(packing.box.to_fractional(packing.positions)), box=box)


def test_two_disks_end_exactly_at_contact():
    eng = _engine([[5.0, 5.0], [5.9, 5.0]], [1.0, 1.0])
    res = newton.relax(eng, 1e-14)
    x = eng.positions()
    assert res.converged and res.steps <= 5  # the tension term makes the perpendicular curvature negative: shifted steps
    assert np.linalg.norm(x[1] - x[0]) == pytest.approx(1.0, abs=1e-12)
    assert np.allclose(x.mean(axis=0), [5.45, 5.0], atol=1e-12)  # central forces: the centre stays


def test_three_spheres_in_a_line_open_every_overlap():
    eng = _engine([[4.2, 5.0, 5.0], [5.0, 5.0, 5.0], [5.7, 5.0, 5.0]], [1.0, 1.0, 1.0])
    res = newton.relax(eng, 1e-14)
    gaps = np.diff(eng.positions()[:, 0]) - 1.0
    assert res.converged and np.all(gaps > -1e-12) and eng.evaluate().energy < 1e-28


@pytest.mark.parametrize("dim,tilt", [(2, 0.0), (2, 0.3), (3, 0.0)])
def test_hessian_matches_finite_differences_and_gradient_the_engine(config, dim, tilt):
    p = tilted(config(24, dim, 0.9 if dim == 2 else 0.7, seed=3), tilt)
    eng = CompiledEngine(p)
    x = eng.positions()
    m = newton.Model.at(eng.packing(), x)
    assert np.any(m.delta > 0) and np.any(m.delta < 0)
    assert np.allclose(m.gradient, -eng.evaluate().forces.ravel(), atol=1e-13)
    on = m.delta > 0
    hess = m.jac[on].T @ m.jac[on] + m.tension
    v = np.random.default_rng(1).standard_normal(x.size)
    h = 1e-6
    plus = newton.Model.at(eng.packing(), x + h * v.reshape(x.shape)).gradient
    minus = newton.Model.at(eng.packing(), x - h * v.reshape(x.shape)).gradient
    fd = (plus - minus) / (2 * h)
    assert np.max(np.abs(hess @ v - fd)) < 1e-6 * np.max(np.abs(fd))
    assert np.max(np.abs(m.tension @ v)) > 1e-3 * np.max(np.abs(fd))  # the tension term is not negligible here


def test_line_minimum_matches_brute_force():
    rng = np.random.default_rng(7)
    t = np.linspace(0.0, 1.0, 200_001)
    for _ in range(20):
        a, b = rng.standard_normal(30), 3 * rng.standard_normal(30)
        q, c = rng.standard_normal(), rng.standard_normal()
        f = 0.5 * (np.maximum(a[:, None] + t * b[:, None], 0.0) ** 2).sum(axis=0) + c * t + 0.5 * q * t**2
        best = newton.line_minimum(a, b, q, c)
        fb = 0.5 * np.sum(np.maximum(a + best * b, 0.0) ** 2) + c * best + 0.5 * q * best**2
        assert 0.0 <= best <= 1.0
        assert fb <= f.min() + 1e-9 * max(1.0, abs(f.min()))


@pytest.mark.parametrize("dim,dphi", [(2, 1e-6), (2, 1e-4), (3, 1e-5)])
def test_reaches_fires_minimum(dim, dphi):
    onset = jamflow.jam(n=64, dim=dim, sizes="bi:1.4:0.5" if dim == 2 else "mono", seed=2).packing
    start = _compressed(onset, dphi)
    settings = MinimizerSettings(creep="off")
    with CompiledEngine(start) as fire_engine:
        fire = minimize(fire_engine, settings)
        fire_state = fire_engine.state()
    with CompiledEngine(start) as eng:
        ftol = settings.force_tol_for(eng.template, box=eng.box)
        res = newton.relax(eng, ftol)
        state = eng.state()
    assert fire.converged and res.converged and state.max_force < ftol
    assert state.energy == pytest.approx(fire_state.energy, rel=1e-8)
    assert state.pressure == pytest.approx(fire_state.pressure, rel=1e-6)


def test_refuses_what_it_does_not_model():
    onset = jamflow.jam(n=16, seed=1).packing
    assert newton.newton_reason(onset) == ""
    assert "spring" in newton.newton_reason(replace(onset, potential=jamflow.model.potentials.parse_potential("hertz")))
    with pytest.raises(ValueError, match="creep method 'newton'"):
        jamflow.jam(n=16, seed=1, shape="ellipse:1.3", settings=fast_protocol(minimizer=MinimizerSettings(creep="newton")))


@pytest.mark.parametrize("dim", [2, 3])
def test_jam_with_newton_passes_its_checks_and_repeats_bit_for_bit(dim):
    settings = fast_protocol(minimizer=MinimizerSettings(creep="newton", creep_after=500))
    kw = dict(n=128, dim=dim, sizes="bi:1.4:0.5" if dim == 2 else "mono", seed=4, settings=settings)
    first, second = jamflow.jam(**kw), jamflow.jam(**kw)
    checks = check_packing(first.packing, first.energy_per_particle, None, 1e-16)
    assert checks.passed, checks.problems()
    assert np.array_equal(first.packing.positions, second.packing.positions)
    assert first.phi_j == second.phi_j
    assert 1e-16 < first.energy_per_particle < 2e-16


def test_without_cholespy_it_warns_once_and_factorises_with_superlu(monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "cholespy", None)  # import cholespy raises ImportError
    cholesky._cholmod.cache_clear()
    try:
        with pytest.warns(UserWarning, match="cholespy cannot be imported"):
            eng = _engine([[5.0, 5.0], [5.9, 5.0]], [1.0, 1.0])
            res = newton.relax(eng, 1e-14)
        assert res.converged
        assert np.linalg.norm(np.diff(eng.positions(), axis=0)) == pytest.approx(1.0, abs=1e-12)
    finally:
        cholesky._cholmod.cache_clear()


def test_the_polish_of_a_large_packing_factorises_with_cholmod_and_solves_the_same_system(monkeypatch):
    """From ``CHOLMOD_FROM_DOF`` coordinates on the polish's factorisation is CHOLMOD's, below it
    SuperLU's; both solve J_a^T J_a + mu I x = b."""
    import scipy.sparse as sp

    from jamflow.minimize import polish

    rng = np.random.default_rng(3)
    for dof in (cholesky.CHOLMOD_FROM_DOF - 2, cholesky.CHOLMOD_FROM_DOF):
        # the rows of a chain of springs (x_k - x_k+1) and of springs to fixed points: banded, quick to factorise
        ja = sp.vstack([sp.eye(dof - 1, dof, format="csr") - sp.eye(dof - 1, dof, k=1, format="csr"),
                        sp.eye(dof, format="csr")]).tocsr()
        calls = []
        monkeypatch.setattr(cholesky, "factorise", lambda m, calls=calls, f=cholesky.factorise: calls.append(1) or f(m))
        b = rng.standard_normal(dof)
        x = polish.factorisation(ja, None, 1e-12).solve(b)
        matrix = ja.T @ ja + 1e-12 * sp.identity(dof)
        assert np.linalg.norm(matrix @ x - b) < 1e-8 * np.linalg.norm(b)
        assert bool(calls) == (dof >= cholesky.CHOLMOD_FROM_DOF)
