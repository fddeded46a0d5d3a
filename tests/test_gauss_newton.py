"""The Gauss-Newton active-set polish (jamflow.minimize.polish): closed cases, derivatives against finite
differences and the engine's forces, and a displaced jammed packing back at FIRE's minimum."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from jamflow.mechanics.contacts import Contacts
from jamflow.mechanics.hessian import Coordinates
from jamflow.mechanics.checks import generalized_forces
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.io.packing_file import load_packing
from jamflow.protocols.above import compress_above
from jamflow.model.box import Box
from jamflow.engines.compiled import spheres
from jamflow.engines.compiled.engine import CompiledEngine
from jamflow.minimize.settings import MinimizerSettings
from jamflow.minimize.rules import _creep_method, minimize
from jamflow.model.packing import Packing
from jamflow.minimize.creep import Creep, CreepTrigger
from jamflow.minimize.polish import (PolishResult, PolishSteps, model, model_step, model_value, moved, overlaps, polish,
                                     polish_reason)
from jamflow.model.potentials import Spring, parse_potential

from conftest import tilted


def _engine(positions, diameters, length=10.0):
    box = Box.cube(length, len(positions[0]))
    return CompiledEngine(Packing(np.asarray(positions, float), np.asarray(diameters, float), box, Spring()))


def test_two_disks_end_exactly_at_contact():
    eng = _engine([[5.0, 5.0], [5.9, 5.0]], [1.0, 1.0])
    res = polish(eng, 1e-14)
    x = eng.positions()
    assert res.converged and len(res.steps) <= 3
    assert np.linalg.norm(x[1] - x[0]) == pytest.approx(1.0, abs=1e-12)
    assert np.allclose(x.mean(axis=0), [5.45, 5.0], atol=1e-12)  # forces are central: the centre stays


def test_three_disks_in_a_line_open_every_overlap():
    eng = _engine([[4.2, 5.0, 5.0], [5.0, 5.0, 5.0], [5.7, 5.0, 5.0]], [1.0, 1.0, 1.0])
    res = polish(eng, 1e-14)
    gaps = np.diff(eng.positions()[:, 0]) - 1.0
    assert res.converged and np.all(gaps > -1e-12) and eng.evaluate().energy < 1e-28


@pytest.mark.parametrize("dim,tilt", [(2, 0.0), (2, 0.3), (3, 0.0)])
def test_jacobian_matches_finite_differences_and_the_engine_forces(config, dim, tilt):
    p = tilted(config(24, dim, 0.9 if dim == 2 else 0.7, seed=3), tilt)
    eng = CompiledEngine(p)
    x = eng.positions()
    pairs = spheres.build(eng.packing(), x, 0.05)
    delta, jac = overlaps(x, pairs)
    assert np.any(delta > 0) and np.any(delta < 0)
    forces = eng.evaluate().forces.ravel()
    assert np.allclose(jac.T @ np.maximum(delta, 0.0), -forces, atol=1e-13)  # grad V = J^T delta_+
    rng = np.random.default_rng(0)
    v = rng.standard_normal(x.size)
    h = 1e-6
    fd = (overlaps(x + h * v.reshape(x.shape), pairs)[0] - overlaps(x - h * v.reshape(x.shape), pairs)[0]) / (2 * h)
    assert np.allclose(jac @ v, fd, atol=1e-8)


def test_model_step_lowers_the_model_and_descends(config):
    eng = CompiledEngine(config(64, 2, 0.86, seed=4))
    x = eng.positions()
    delta, jac = overlaps(x, spheres.build(eng.packing(), x, 0.05))
    dx, active, inner = model_step(delta, jac, 1e-12)
    grad = -eng.evaluate().forces.ravel()
    assert model_value(delta, jac, dx, 1e-12) < 0.5 * model_value(delta, jac, 0 * dx, 1e-12)
    assert grad @ dx < 0 and active > 0 and inner >= 1


def _back_at_minimum(eng, x0) -> float:
    """Largest displacement of the non-rattlers from x0 (net translation removed)."""
    kept = Contacts().compute(eng.packing()).kept  # rattlers keep their displacement: no force on them
    dx = eng.box.minimum_image(eng.positions() - x0)[kept]
    return float(np.abs(dx - dx.mean(axis=0)).max())


def test_gauss_newton_returns_a_displaced_packing_near_onset_to_its_minimum():
    """A jammed N = 64 packing compressed 1e-3 above onset (P ~ 1e-3), displaced by 1e-6:
    Gauss-Newton alone converges linearly (rate ~ tension / stiffness, small near onset)."""
    from jamflow.protocols.compression import jam

    res = jam(n=64, seed=3, engine="numba")
    eng = CompiledEngine(res.packing)
    eng.set_box(Box(res.packing.box.h * (res.phi_j / (res.phi_j + 1e-3)) ** 0.5))
    first = minimize(eng, MinimizerSettings(v_min=1e-30, force_tol=1e-14))
    assert first.reason == "force" and first.energy_per_particle > 1e-8  # still jammed
    x0, e0 = eng.positions(), eng.evaluate().energy
    eng.set_positions(x0 + 1e-6 * np.random.default_rng(0).standard_normal(x0.shape))
    out = polish(eng, 1e-14)
    assert out.converged and len(out.steps) <= 12
    assert all(b.force_after < a.force_after for a, b in zip(out.steps, out.steps[1:]))
    assert _back_at_minimum(eng, x0) < 1e-9
    assert eng.evaluate().energy == pytest.approx(e0, rel=1e-9)


@pytest.mark.parametrize("dim,phi", [(2, 0.88), (3, 0.70)])
def test_gauss_newton_returns_a_displaced_compressed_packing_to_the_fire_minimum(config, dim, phi):
    """Far above onset (P ~ 1e-2): Gauss-Newton converges linearly to ~5e-12 (it leaves the
    tension terms out; the full Newton step that went further was an option
    no jam used, since removed); asked for 1e-30 it stops unconverged (a refused step, or out
    of steps) and the engine keeps the best state."""
    from jamflow.minimize.polish import MAX_STEPS

    d = np.where(np.arange(64) % 2 == 0, 1.0, 1.4)
    eng = CompiledEngine(config(64, dim, phi, seed=1, diameters=d))
    first = minimize(eng, MinimizerSettings(force_tol=1e-13))
    assert first.reason == "force" and first.energy_per_particle > 1e-6  # jammed
    x0, e0 = eng.positions(), eng.evaluate().energy
    eng.set_positions(x0 + 1e-6 * np.random.default_rng(0).standard_normal(x0.shape))
    out = polish(eng, 1e-11)
    assert out.converged and out.max_force < 1e-5 * out.steps[0].force_before  # 32-36 steps measured
    assert _back_at_minimum(eng, x0) < 1e-8  # max force 1e-11 leaves ~1e-9 diameters (measured 1.4e-9 in 2D)
    assert eng.evaluate().energy == pytest.approx(e0, rel=1e-10)
    f1 = eng.evaluate().max_force
    again = polish(eng, 1e-30)
    assert not again.converged and again.max_force <= f1
    assert again.steps[-1].alpha == 0.0 or len(again.steps) == MAX_STEPS  # refused, or out of steps (2D)
    assert eng.evaluate().max_force == again.max_force and _back_at_minimum(eng, x0) < 1e-8


@pytest.mark.parametrize("change,words", [(dict(potential=parse_potential("hertz")), "linear spring"),
                                          (dict(box=Box(np.eye(2) * 8.0, periodic=(True, False))), "walls")])
def test_unsupported_packings_are_refused_before_work(config, change, words):
    p = config(16, 2, 0.8, seed=0)
    p = Packing(p.positions, p.diameters, change.get("box", p.box), change.get("potential", p.potential))
    assert words in polish_reason(p)
    with pytest.raises(ValueError, match="minimise with FIRE alone"):
        polish(CompiledEngine(p), 1e-14)


def test_a_bad_tolerance_is_refused():
    eng = _engine([[5.0, 5.0], [5.9, 5.0]], [1.0, 1.0])
    with pytest.raises(ValueError, match="finite positive"):
        polish(eng, 0.0)


# --- rigid bodies: site pairs in generalized coordinates (centres, rotations d_k theta) ---------------

DATA = Path(__file__).parent / "data"
DIMERS = {2: "dimer2d_a1.5_n32_s0.h5", 3: "dimer3d_a1.5_n128_s8_creeping.h5"}


@pytest.mark.parametrize("dim", [2, 3])
def test_rigid_body_jacobian_against_moved_sites(dim):
    """J dx against the change of delta when the bodies are moved and turned by dx
    (``analysis.deformation.displaced``, site positions recomputed from the orientations): the
    difference is second order (dx ~ 1e-7: |J dx| ~ 4e-7, measured residual ~1.5e-13)."""
    p = load_packing(DATA / DIMERS[dim])
    delta, jac = model(p)
    dx = 1e-7 * np.random.default_rng(dim).standard_normal(Coordinates.of(p).size)
    q = moved(p, dx)
    after, _ = model(q)
    assert len(after) == len(delta) and len(delta) > p.n  # the same site pairs within the skin
    assert np.abs((after - delta) - jac @ dx).max() < 1e-5 * np.abs(jac @ dx).max()


@pytest.mark.parametrize("dim", [2, 3])
def test_rigid_body_model_gradient_is_minus_the_reference_forces_and_torques(dim):
    """J^T max(delta, 0) = dV/dxi: the numpy reference's forces and tau_a / d_k (eps/diameter), to
    the round-off of site positions in a box of length ~10 (eps x 10 ~ 2e-15; measured 2.3e-15 and
    4.3e-15 where the forces are 9e-15 and 8e-11)."""
    p = load_packing(DATA / DIMERS[dim])
    delta, jac = model(p)
    expected = generalized_forces(p, energy_forces_pressure(p))
    assert np.abs(jac.T @ np.maximum(delta, 0) + expected).max() < 2e-14


def test_displaced_rigid_bodies_return_to_the_minimum():
    """2D dimers 1e-3 above onset, every body moved and turned by ~1e-6: the polish converges
    and takes the energy back to FIRE's minimum. Convergence is linear (the model leaves out the
    tensions, which 1e-3 above onset are not small against the softest modes' J^T J): measured 33
    steps, the last ones at a rate ~0.8."""
    packing = compress_above(load_packing(DATA / DIMERS[2]), 1e-3).packing
    with CompiledEngine(packing) as eng:
        e0 = eng.evaluate().energy
    dx = 1e-6 * np.random.default_rng(0).standard_normal(Coordinates.of(packing).size)
    with CompiledEngine(moved(packing, dx)) as eng:
        assert eng.evaluate().energy > e0 * (1 + 1e-9)
        out = polish(eng, 1e-13)
        assert out.converged
        assert eng.evaluate().energy == pytest.approx(e0, rel=1e-9)


def test_the_creeping_3d_dimer_state_is_polished():
    """The stored state of a 3D minimisation that crept into the iteration cap (max force 8.3e-11,
    tests/data/README.md): three Gauss-Newton steps take it below 1e-14 (measured 3.0e-15) with a
    lower energy, where 20 000 FIRE iterations leave it creeping (test_soft_modes.py)."""
    packing = load_packing(DATA / DIMERS[3])
    with CompiledEngine(packing) as eng:
        e0 = eng.evaluate().energy
        out = polish(eng, 1e-14)
        assert out.converged and len(out.steps) <= 5 and eng.evaluate().energy < e0
        final = eng.packing()
    ref = energy_forces_pressure(final)  # independent of the engine
    assert np.abs(generalized_forces(final, ref)).max() < 1e-13


def test_a_polish_runs_once_or_every_so_many_iterations(monkeypatch):
    calls = []
    monkeypatch.setattr("jamflow.minimize.polish.polish", lambda engine, ftol: calls.append(ftol) or PolishResult(True, (), 0.0, 0.0))
    once = Creep(CreepTrigger(100, aligned=True), PolishSteps(1e-14))
    every = Creep(CreepTrigger(100, every=200, aligned=True), PolishSteps(1e-14))
    for p in (once, every):
        assert not p.due(100, 2e-9) and p.due(100, 5e-10) and not p.due(150, 5e-10)  # creeping, at a multiple of after
        p.step(None, 100)
    assert not once.due(300, 5e-10) and not once.due(10_000, 5e-10)
    assert not every.due(200, 5e-10) and every.due(300, 5e-10)
    assert len(calls) == 2


def test_auto_polishes_creeping_rigid_bodies():
    """``creep="auto"`` on rigid bodies with the linear spring is the repeated polish: the stored
    creeping 3D state converges within 20 000 iterations (measured: one polish at 10 000, then
    force balance), where FIRE alone keeps creeping (test_soft_modes.py)."""
    packing = load_packing(DATA / DIMERS[3])
    with CompiledEngine(packing) as engine:
        out = minimize(engine, MinimizerSettings(creep_after=10_000, max_iterations=20_000))
    assert out.converged and out.creep_steps >= 1
    with CompiledEngine(dataclasses.replace(packing, potential=parse_potential("hertz"))) as engine:  # no least squares: soft modes
        assert type(_creep_method(engine, MinimizerSettings(), 1.0, 1e-14).strategy).__name__ == "SoftModeSteps"
