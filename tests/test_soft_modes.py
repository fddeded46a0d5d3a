"""Soft-mode Newton steps of creeping minimisations (``jamflow.minimize.soft_modes``).

Closed form: at a force-balanced packing displaced by a along one eigenmode e of its
dynamical matrix, the harmonic gradient is a lambda e, so the soft-subspace Newton step is
-a e (to O(a^2)) and takes the energy back to the minimum's."""

from pathlib import Path

import numpy as np
import pytest

from jamflow.mechanics.dynamical_matrix import DynamicalMatrix
from jamflow.engines.compiled.engine import CompiledEngine
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.io.packing_file import load_packing
from jamflow.protocols.above import compress_above
from jamflow.minimize.settings import MinimizerSettings
from jamflow.minimize.rules import minimize
from jamflow.minimize.soft_modes import _moved, newton_step

DATA = Path(__file__).parent / "data"

AMPLITUDE = 1e-6  # diameters along a unit mode: harmonic at overlaps ~1e-3 (no contact opens), energy change far above round-off


@pytest.fixture(scope="module")
def displaced_dimers():
    """The 2D dimer fixture (alpha 1.5, N = 32) compressed 1e-3 above onset (overlaps ~1e-3, so
    the displacement opens no contact), displaced along its softest nontrivial mode."""
    packing = compress_above(load_packing(DATA / "dimer2d_a1.5_n32_s0.h5"), 1e-3).packing
    dyn = DynamicalMatrix().compute(packing)
    values, vectors = np.linalg.eigh(dyn.matrix.toarray())
    k = int(np.argmax(values > 1e-10))  # the first mode above the d translations
    return packing, dyn, values[k], vectors[:, k], _moved(packing, dyn, AMPLITUDE * vectors[:, k])


def test_newton_step_undoes_a_displacement_along_a_mode(displaced_dimers):
    packing, dyn, value, mode, moved = displaced_dimers
    assert value > 0 and len(dyn.particles) == packing.n  # no floaters: same coordinates before and after
    ref = energy_forces_pressure(moved)
    xi = newton_step(DynamicalMatrix().compute(moved), ref, moved)
    assert np.linalg.norm(xi + AMPLITUDE * mode) < 1e-3 * AMPLITUDE
    e0, e_moved = energy_forces_pressure(packing).energy, ref.energy
    e_back = energy_forces_pressure(_moved(moved, dyn, xi)).energy
    assert e_moved - e0 == pytest.approx(0.5 * value * AMPLITUDE**2, rel=1e-2)  # harmonic
    assert abs(e_back - e0) < 1e-2 * (e_moved - e0)  # back at the minimum (measured 1.4e-3 of the raise)


def test_a_creeping_minimisation_takes_the_step(displaced_dimers):
    """From the displaced state (max force ~ lambda a, below the creep threshold) with FIRE
    restarted every 100 iterations: with the stepper one step is kept after the first window and
    the minimisation converges by force (measured: 180 iterations); without it the same windows
    stall at max force 2.4e-11 ('no-progress' after 2100 iterations)."""
    *_, moved = displaced_dimers
    results = {}
    for creep in ("soft-modes", "off"):
        with CompiledEngine(moved) as engine:
            results[creep] = minimize(engine, MinimizerSettings(creep=creep, creep_after=100,
                                                                     window=100))
    on, off = results["soft-modes"], results["off"]
    assert on.reason == "force" and on.creep_steps >= 1 and on.iterations < 1000
    assert off.creep_steps == 0 and off.iterations > on.iterations


def test_an_explicit_creep_method_is_refused_where_it_cannot_run(displaced_dimers):
    *_, moved = displaced_dimers
    with CompiledEngine(moved) as engine, pytest.raises(ValueError, match="fixed periodic box"):
        minimize(engine, MinimizerSettings(creep="soft-modes", pressure=1e-3))
    ellipses = load_packing(DATA / "ellipse1.5_n16_s0.h5")
    with CompiledEngine(ellipses) as engine, pytest.raises(ValueError, match="rigid bodies of fused sites, not ellipsoid"):
        minimize(engine, MinimizerSettings(creep="polish"))


def test_soft_mode_settings_are_checked():
    with pytest.raises(ValueError, match="creep method"):
        MinimizerSettings(creep="yes")
    with pytest.raises(ValueError, match="creep_after"):
        MinimizerSettings(creep_after=0)


def test_the_creeping_3d_dimer_state_is_resolved():
    """The stored state of a minimisation that crept into the iteration cap (docs/notes/soft-modes.md):
    with the steps it ends by a converged rule within 20 000 iterations (measured: one step, the
    energy 2.29e-14 -> 1.5e-16, then below V_min: it was unjamming); without, 20 000 more FIRE
    iterations leave it creeping."""
    packing = load_packing(DATA / "dimer3d_a1.5_n128_s8_creeping.h5")
    results = {}
    for creep in ("soft-modes", "off"):
        with CompiledEngine(packing) as engine:
            results[creep] = minimize(engine, MinimizerSettings(creep=creep, creep_after=10_000,
                                                                     max_iterations=20_000))
    assert results["soft-modes"].converged and results["soft-modes"].creep_steps == 1
    assert results["soft-modes"].energy_per_particle < 1e-16
    assert results["off"].reason == "iteration-cap" and results["off"].energy_per_particle > 1e-16


def test_the_lowest_eigenpairs_repeat_bit_for_bit():
    """ARPACK starts from a fixed vector (scipy's default draws a fresh random one per call)."""
    import scipy.sparse as sp

    from jamflow.mechanics.eigen import lowest_eigenpairs

    rng = np.random.default_rng(7)
    a = sp.random(400, 400, density=0.02, random_state=rng)
    matrix = (a @ a.T + sp.identity(400) * 1e-3).tocsr()
    first, second = (lowest_eigenpairs(matrix, 6, 1e-6) for _ in range(2))
    assert np.array_equal(first[0], second[0]) and np.array_equal(first[1], second[1])


def test_an_ellipse_jam_with_soft_mode_steps_repeats_bit_for_bit():
    """N = 32 ellipses, seed 3: the soft-mode steps run (33 384 iterations, one step; 73 319 with the steps
    every 50 000 iterations, the old default); before the fixed start
    vector two runs of the same jam ended at different positions (docs/notes/soft-modes.md)."""
    from jamflow import jam

    a, b = (jam(n=32, dim=2, shape="ellipse:1.6", sizes="mono", seed=3) for _ in range(2))
    assert np.array_equal(a.packing.positions, b.packing.positions)
    assert np.array_equal(a.packing.orientations, b.packing.orientations) and a.iterations == b.iterations


def test_the_soft_mode_trigger_waits_after_iterations_then_repeats():
    """The soft-mode steps' trigger: the first attempt at >= ``after`` iterations while creeping
    (not only at multiples of it), then every ``after`` iterations from the last attempt."""
    from jamflow.minimize.creep import CreepTrigger

    t = CreepTrigger(50_000, every=50_000)
    assert not t.due(40_000, 1e-10) and not t.due(60_000, 2e-9) and t.due(60_000, 1e-10)
    t.fired(60_000)
    assert not t.due(100_000, 1e-10) and t.due(110_000, 1e-10)


def test_soft_mode_steps_run_every_10_000_iterations_for_ellipses_and_spheroids():
    """The measured defaults (docs/notes/ellipses.md, "FIRE's time unit and the oblate creep"): 10 000 iterations for
    ellipses and spheroids, 50 000 for the other shapes that take soft-mode steps (rigid bodies
    under the Hertz law); an explicit ``creep_after`` wins. Disks and spheres keep their creep
    method (2D: the polish once at 20 000 iterations; 3D: none), so their runs do not change."""
    import dataclasses

    from jamflow.minimize.rules import _creep_method
    from jamflow.model.potentials import parse_potential
    from jamflow.protocols.compression import initial_packing

    def creep(packing, **settings):
        with CompiledEngine(packing) as engine:
            return _creep_method(engine, MinimizerSettings(**settings), 1.0, 1e-14)

    for shape, dim in (("ellipse:1.5", 2), ("spheroid:0.6", 3), ("spheroid:1.5", 3)):
        c = creep(initial_packing(32, dim, "mono", "spring", 0, 0.5, shape))
        assert type(c.strategy).__name__ == "SoftModeSteps" and (c.trigger.after, c.trigger.every) == (10_000, 10_000)
    dimers = dataclasses.replace(load_packing(DATA / "dimer2d_a1.5_n32_s0.h5"), potential=parse_potential("hertz"))
    assert type(creep(dimers).strategy).__name__ == "SoftModeSteps" and creep(dimers).trigger.after == 50_000
    disks = creep(initial_packing(32, 2, "bi:1.4:0.5", "spring", 0, 0.5))
    assert type(disks.strategy).__name__ == "PolishSteps" and (disks.trigger.after, disks.trigger.every) == (20_000, None)
    assert creep(initial_packing(32, 3, "bi:1.4:0.5", "spring", 0, 0.5)) is None
    explicit = creep(dimers, creep_after=7_000).trigger
    assert (explicit.after, explicit.every) == (7_000, 7_000)


@pytest.mark.slow
def test_an_oblate_jam_takes_soft_mode_steps_every_10_000_iterations():
    """24 oblate spheroids (0.6), seed 1, the default jam: 87 668 iterations with the steps every
    10 000 iterations, 194 449 with every 50 000 (the old default), same phi_J
    0.6978862503 (`python benchmarks/creep_after.py run --dim 3 --sizes mono --shape spheroid:0.6
    --n 24 --seeds 1 --creep-after 50000 10000`). Counts, not times."""
    from jamflow.protocols.spec import JamSpec, run_jam

    result, checks = run_jam(JamSpec(n=24, dim=3, shape="spheroid:0.6", sizes="mono", seed=1))  # `jamflow jam`
    assert checks.passed and result.iterations < 130_000
