"""Rigid bodies in LAMMPS (docs/notes/nmers.md): sites as atoms with molecule ids, damped fix rigid (not
fix rigid/small: engine/lammps_bodies.py says why).
Cross-checked against LAMMPS's own rigid-body accounting (compute rigid/local), the numpy
reference and the compiled engine; box changes keep bodies rigid; minimisers that LAMMPS runs
without rigid bodies are refused."""

import numpy as np
import pytest
from conftest import rel, tilted

from jamflow.model.box import Box
from jamflow.engines.choose import engine_name
from jamflow.engines.compiled.engine import CompiledEngine
from jamflow.engines.lammps.engine import LammpsEngine
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.minimize.settings import MinimizerSettings
from jamflow.model.packing import random_packing
from jamflow.model.potentials import Spring
from jamflow.model.shapes import parse_shape
from jamflow.mechanics.checks import generalized_torques
from jamflow.model.sizes import parse_sizes
from jamflow.minimize.rules import minimize

SPECS = ["nmer:2:1.5", "nmer:2:2", "dimer:1.5:0.7", "trimer:2:0.3", "nmer:3:1.5"]


def bodies(spec, dim, phi=None, n=None, seed=3, tilt=0.0, potential=None, sizes="bi:1.4:0.5"):
    p = random_packing(n or (40 if dim == 2 else 100), dim, parse_sizes(sizes), phi or (0.95 if dim == 2 else 0.75),
                       seed, potential or Spring(), parse_shape(spec, dim))
    return tilted(p, tilt) if tilt else p


@pytest.mark.parametrize("tilt", [0.0, 0.37], ids=["orthogonal", "tilted"])
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("spec", SPECS)
def test_lammps_compiled_and_reference_agree(spec, dim, tilt):
    """Random overlapping configurations: energy, body forces, torques and the molecular pressure
    tensor, LAMMPS vs the compiled engine vs the reference, to 1e-12 relative."""
    for potential in (Spring(), Spring(2.5)):  # harmonic/cut and the plugin pair style
        p = bodies(spec, dim, tilt=tilt, potential=potential)
        ref = energy_forces_pressure(p)
        with LammpsEngine(p) as lmp, CompiledEngine(p) as num:
            got = {"lammps": lmp.evaluate(), "numba": num.evaluate()}
            assert np.abs(p.box.minimum_image(lmp.positions() - p.positions)).max() < 1e-12
        for name, s in got.items():
            assert s.energy == pytest.approx(ref.energy, rel=1e-12), name
            assert rel(s.forces, ref.forces) < 1e-12, name
            assert rel(s.torques, ref.torques) < 1e-12, name
            assert rel(s.pressure_tensor, ref.pressure_tensor) < 1e-12, name


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("spec", ["dimer:1.5:0.7", "trimer:2:0.3"])
def test_lammps_rigid_body_centres_are_jamflows(spec, dim):
    """LAMMPS's own rigid bodies (fix rigid/small, compute rigid/local): centres (mass-weighted
    sites) at jamflow's union centres of mass, and its body forces and torques equal jamflow's."""
    p = bodies(spec, dim)
    ref = energy_forces_pressure(p)
    with LammpsEngine(p) as eng:
        eng.run_commands(["fix jf_rigid all rigid/small molecule", "compute rl all rigid/local jf_rigid id x y z "
                          "fx fy fz tqx tqy tqz", "run 0"])
        local = eng.lmp.numpy.extract_compute("rl", 2, 2)
        local = local[np.argsort(local[:, 0])]
    assert np.abs(p.box.minimum_image(local[:, 1:1 + dim] - p.positions)).max() < 1e-12
    assert rel(local[:, 4:4 + dim], ref.forces) < 1e-12
    assert rel(local[:, 9] if dim == 2 else local[:, 7:10], ref.torques) < 1e-12


@pytest.mark.parametrize("dim", [2, 3])
def test_box_changes_move_centres_and_keep_bodies_rigid(dim):
    """set_box: centres move affinely (fractional coordinates kept), orientations and every
    site-site distance inside a body stay (change_box ... remap would stretch them)."""
    p = bodies("trimer:2:0.3", dim, phi=0.5)
    h = p.box.h * 0.93
    h[0, 1] = 0.2 * h[1, 1]
    with LammpsEngine(p) as eng:
        eng.set_box(Box(h))
        eng.evaluate()
        out = eng.packing()
    d = out.box.to_fractional(out.positions) - p.box.to_fractional(p.positions)
    assert np.max(np.abs(d - np.round(d))) < 1e-12
    before = p.shape.world_sites(p.positions, p.orientations, p.diameters)
    after = out.shape.world_sites(out.positions, out.orientations, out.diameters)
    internal = lambda w: np.linalg.norm(w[:, :, None] - w[:, None, :], axis=-1)
    assert np.abs(internal(after) - internal(before)).max() < 1e-12
    assert np.abs(after - out.positions[:, None, :] - (before - p.positions[:, None, :])).max() < 1e-12


@pytest.mark.parametrize("dim", [2, 3])
def test_damped_rigid_bodies_reach_force_and_torque_balance(dim):
    """An overcompressed packing relaxed by LAMMPS (damped fix rigid) through jamflow's
    stopping rules: every force and generalized torque below 1e-12 by the independent reference."""
    p = bodies("nmer:2:1.5", dim, phi=0.9 if dim == 2 else 0.72, n=40)
    start = energy_forces_pressure(p)
    with LammpsEngine(p) as eng:
        r = minimize(eng, MinimizerSettings(method="md", force_tol=1e-13))
        end = eng.packing()
        state = eng.state()
    ref = energy_forces_pressure(end)
    g = generalized_torques(end, ref.torques)
    assert r.reason == "force" and r.converged and r.max_torque < 1e-13
    assert 0 < ref.energy < start.energy and ref.energy == pytest.approx(state.energy, rel=1e-12)
    assert np.abs(ref.forces).max() < 1e-12 and np.abs(g).max() < 1e-12


def test_damped_rigid_bodies_are_reproducible_in_one_process():
    """The same packing relaxed by four LAMMPS instances, with other allocations in between: the
    same steps and the same positions, bit for bit. With fix rigid/small the first half-step of a
    run integrated uninitialised Langevin forces (engine/lammps_bodies.py): there one of four such
    runs took 3000 instead of 9500 steps and ended 5.6 diameters away."""
    runs, keep = [], []
    for k in range(4):
        keep.append(np.ones(1000 * (k + 1)))  # changes what the allocator hands LAMMPS next
        p = bodies("nmer:2:1.5", 2, phi=0.9, n=16)
        with LammpsEngine(p) as eng:
            r = minimize(eng, MinimizerSettings(method="md", force_tol=1e-13))
            runs.append((r.iterations, eng.packing().positions))
    assert all(k == runs[0][0] for k, _ in runs) and runs[0][0] > 1000
    assert all(np.array_equal(x, runs[0][1]) for _, x in runs)


@pytest.mark.parametrize("method", ["fire", "cg"])
def test_lammps_minimisers_are_refused_for_rigid_bodies(method):
    """LAMMPS's minimize ignores fix rigid (bodies come apart): only damped dynamics is offered."""
    p = bodies("nmer:2:1.5", 2)
    with pytest.raises(ValueError, match=f"engine lammps cannot run minimizer {method} on nmer:2:1.5 particles: "
                                         r"LAMMPS's minimisers ignore fix rigid.*\(it runs md there\)"):
        engine_name(p, method, "lammps")
    assert engine_name(p, "md", "auto") == "lammps" and engine_name(p, "fire", "auto") == "numba"
    with LammpsEngine(p) as eng, pytest.raises(ValueError, match="minimisers ignore rigid bodies"):
        minimize(eng, MinimizerSettings(method=method))


def test_sheared_past_a_cell_flip_bodies_stay_exact():
    """Tilt 0.3 -> 0.7 l (LAMMPS flips its reduced cell): the engine's state equals the reference
    of the packing it reports, and the centres kept their fractional coordinates."""
    p = bodies("dimer:1.5:0.7", 2, phi=0.85, n=60)
    with LammpsEngine(p) as eng:
        for gamma in (0.3, 0.7):
            eng.set_box(p.box.with_shear_strain(gamma))
            state = eng.evaluate()
            out = eng.packing()
            ref = energy_forces_pressure(out)
            assert state.energy == pytest.approx(ref.energy, rel=1e-12)
            assert rel(state.forces, ref.forces) < 1e-12 and rel(state.torques, ref.torques) < 1e-12
            assert rel(state.pressure_tensor, ref.pressure_tensor) < 1e-12
            d = out.box.to_fractional(out.positions) - p.box.to_fractional(p.positions)
            assert np.max(np.abs(d - np.round(d))) < 1e-12
