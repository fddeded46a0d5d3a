"""The compiled engine (numba FIRE 2.0 + spring) against the numpy reference and against
LAMMPS running the same algorithm (a second implementation of both)."""

import numpy as np
import pytest

from jamflow import jam
from jamflow.engine.lammps import LammpsEngine
from jamflow.engine.native import NumbaEngine, unsupported_reason
from jamflow.engine.reference import energy_forces_pressure
from jamflow.engine.select import engine_name, open_engine
from jamflow.minimize import MinimizerSettings
from jamflow.potentials import RepulsiveLJ, Spring


@pytest.mark.parametrize("pot", [Spring(2.0), Spring(2.5), Spring(1.5, epsilon=0.7)], ids=lambda p: p.spec)
@pytest.mark.parametrize("dim", [2, 3])
def test_energy_forces_pressure_match_reference(config, pot, dim):
    p = config(100, dim, 0.9 if dim == 2 else 0.7, seed=11, potential=pot)
    ref = energy_forces_pressure(p)
    with NumbaEngine(p) as eng:
        got = eng.evaluate()
    assert got.energy == pytest.approx(ref.energy, rel=1e-12)
    assert np.max(np.abs(got.forces - ref.forces)) <= 1e-12 * np.max(np.abs(ref.forces))
    assert np.max(np.abs(got.pressure_tensor - ref.pressure_tensor)) <= 1e-12 * np.max(np.abs(ref.pressure_tensor))


def test_two_disks_closed_form():
    from jamflow.box import Box
    from jamflow.packing import Packing

    # overlap 1 - r/sigma = 0.1: V = 0.1^2 / 2, |F| = 0.1 / sigma, across the periodic boundary
    p = Packing(np.array([[0.2, 5.0], [9.3, 5.0]]), np.array([1.0, 1.0]), Box(np.eye(2) * 10.0), Spring())
    with NumbaEngine(p) as eng:
        s = eng.evaluate()
    assert s.energy == pytest.approx(0.005, rel=1e-13)
    assert s.forces[0] == pytest.approx([0.1, 0.0], abs=1e-14)  # 0.2 - 9.3 + 10 carries 4e-16
    assert s.forces[1] == pytest.approx([-0.1, 0.0], abs=1e-14)
    # virial P_xx = r f / V = 0.9 * 0.1 / 100
    assert s.pressure_tensor[0, 0] == pytest.approx(0.9 * 0.1 / 100, rel=1e-12)


@pytest.mark.parametrize("dim", [2, 3])
def test_fire_reaches_the_lammps_minimum(config, dim):
    """Same FIRE 2.0 from the same overcompressed start: same minimum, similar work."""
    d = np.where(np.arange(128) % 2 == 0, 1.0, 1.4)
    p = config(128, dim, 0.86 if dim == 2 else 0.68, seed=5, diameters=d)
    settings = MinimizerSettings(force_tol=1e-13)
    results = {}
    for engine in (LammpsEngine, NumbaEngine):
        with engine(p) as eng:
            r = eng.minimize(settings)
            results[engine.name] = (r, eng.state(), eng.packing())
    (rl, sl, pl), (rn, sn, pn) = results["lammps"], results["numba"]
    assert rl.reason == rn.reason == "force"
    assert rn.energy_per_particle == pytest.approx(rl.energy_per_particle, rel=1e-9)
    assert np.allclose(sn.pressure_tensor, sl.pressure_tensor, rtol=1e-7, atol=1e-12)
    assert np.max(np.abs(p.box.minimum_image(pn.positions - pl.positions))) < 1e-6
    assert 0.5 < rn.iterations / rl.iterations < 2.0


def test_dilute_start_ends_unjammed_like_lammps(config):
    # all overlaps can vanish in one step (V = 0, F = 0): the force rule then fires first, in
    # both engines and in the deck; the protocol counts V <= V_tol as below jamming either way
    p = config(200, 2, 0.5, seed=2)
    for engine in (LammpsEngine, NumbaEngine):
        with engine(p) as eng:
            r = eng.minimize(MinimizerSettings())
        assert r.converged and r.energy_per_particle < 1e-16, engine.name


def test_pair_list_rebuilds_when_particles_travel(config):
    """From a random start particles move far more than the skin: forces must stay exact."""
    p = config(150, 2, 0.84, seed=9)
    with NumbaEngine(p, skin=0.05) as eng:
        eng.minimize(MinimizerSettings(max_iterations=3000, window=1000))
        moved = np.abs(p.box.minimum_image(eng.positions() - p.positions)).max()
        state = eng.state()
        end = eng.packing()
    assert moved > 0.05
    ref = energy_forces_pressure(end)
    assert state.energy == pytest.approx(ref.energy, rel=1e-10)
    assert np.max(np.abs(state.forces - ref.forces)) <= 1e-13 + 1e-10 * np.max(np.abs(ref.forces))  # round-off


@pytest.mark.parametrize("engine", [LammpsEngine, NumbaEngine], ids=lambda e: e.name)
def test_set_box_is_affine_and_exact(config, engine):
    p = config(40, 3, 0.3, seed=4)
    new = p.box.scaled(0.9)
    with engine(p) as eng:
        eng.set_box(new)
        x = eng.positions()
        assert eng.box == new
    d = new.to_fractional(x) - p.box.to_fractional(p.positions)
    assert np.max(np.abs(d - np.round(d))) < 1e-13


def test_selection_rule(config):
    ortho, tilted = config(20, 2, 0.5, seed=1), config(20, 2, 0.5, seed=1, tilt=0.2)
    rlj = config(20, 2, 0.5, seed=1, potential=RepulsiveLJ())
    assert engine_name(ortho, "fire") == "numba"
    assert engine_name(ortho, "cg") == "lammps"
    assert engine_name(tilted, "fire") == "lammps"
    assert engine_name(rlj, "fire") == "lammps"
    assert engine_name(ortho, "fire", "lammps") == "lammps"
    assert unsupported_reason(ortho, "fire", comm=object()) is not None
    with open_engine(ortho, "fire") as eng:
        assert eng.name == "numba"


@pytest.mark.parametrize("packing,method,match", [("tilted", "fire", "tilted"), ("rlj", "fire", "rlj"),
                                                   ("ortho", "md", "minimizer md")])
def test_forcing_numba_where_it_cannot_run_is_a_clear_error(config, packing, method, match):
    p = {"ortho": config(20, 2, 0.5, seed=1), "tilted": config(20, 2, 0.5, seed=1, tilt=0.2),
         "rlj": config(20, 2, 0.5, seed=1, potential=RepulsiveLJ())}[packing]
    with pytest.raises(ValueError, match=match):
        engine_name(p, method, "numba")


def test_unknown_engine_rejected_before_work():
    with pytest.raises(ValueError, match="unknown engine"):
        jam(n=16, engine="gpu")


def test_jam_with_either_engine_reaches_the_window():
    for engine in ("numba", "lammps"):
        r = jam(n=32, seed=4, engine=engine)
        assert r.engine == engine
        assert 1e-16 < r.energy_per_particle < 2e-16
        assert r.max_force < 1e-13
