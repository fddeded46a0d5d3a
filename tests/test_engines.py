"""Every engine against the numpy reference, for every model it runs, in orthogonal and tilted
boxes (2D and 3D): energy, forces, torques and the pressure tensor to 1e-12 relative. Then
the compiled engine's closed forms, its FIRE against LAMMPS's, the engine contract (selection,
options, refusals) and minimisation with rotations."""

import numpy as np
import pytest
from conftest import rel, tilted

from jamflow import jam
from jamflow.model.box import Box
from jamflow.engines.choose import engine_name, open_engine
from jamflow.engines.compiled.engine import CompiledEngine
from jamflow.engines.lammps.engine import LammpsEngine
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.minimize.settings import MinimizerSettings
from jamflow.model.packing import Packing, random_packing
from jamflow.model.potentials import RepulsiveLJ, Spring
from jamflow.model.shapes import SPHERE, Ellipsoid, RigidBody
from jamflow.model.sizes import parse_sizes
from jamflow.minimize.rules import minimize

ENGINES = {"lammps": LammpsEngine, "numba": CompiledEngine}


def dimer(dim, alpha=1.5, s=1.0):
    """A dimer of site diameters 1 and s, total length alpha (chapter Figure 2.9)."""
    return RigidBody([[0.0] * dim, [alpha - 0.5 - 0.5 * s] + [0.0] * (dim - 1)], [1.0, s], f"dimer:{alpha}:{s}")


def trimer(dim):
    return RigidBody([[0.0] * dim, [0.6] + [0.0] * (dim - 1), [0.3, 0.45] + [0.0] * (dim - 2)], [1.0, 0.9, 0.8], "trimer")


MODELS = {  # name -> (shape factory(dim), packing fraction 2D, 3D)
    "sphere": (lambda dim: None, 0.9, 0.7),
    "dimer": (lambda dim: dimer(dim), 0.95, 0.75),
    "asym-dimer": (lambda dim: dimer(dim, 1.6, 0.7), 0.95, 0.75),
    "trimer": (trimer, 0.95, 0.75),
    "ellipsoid": (lambda dim: Ellipsoid(1.6 if dim == 2 else 0.6), 0.9, 0.65),
}


def sample(model, dim, tilt=0.0, potential=None, n=None, seed=3):
    factory, phi2, phi3 = MODELS[model]
    n = n or (40 if dim == 2 else 100)
    shape = factory(dim)
    p = random_packing(n, dim, parse_sizes("bi:1.4:0.5"), phi2 if dim == 2 else phi3, seed,
                       potential or Spring(2.5), shape or SPHERE)
    return tilted(p, tilt) if tilt else p


@pytest.mark.parametrize("tilt", [0.0, 0.37], ids=["orthogonal", "tilted"])
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("model", list(MODELS))
@pytest.mark.parametrize("engine", list(ENGINES))
def test_engine_matches_reference(engine, model, dim, tilt):
    for potential in (Spring(2.5), RepulsiveLJ()) if model == "sphere" else (Spring(2.5),):
        p = sample(model, dim, tilt, potential, seed=3 if potential.name == "spring" else 8)
        if potential.name == "rlj":  # keep RLJ overlaps moderate
            p = p.scaled_to_phi(0.7 if dim == 2 else 0.5)
        reason = ENGINES[engine].CAPABILITIES.reason(p, method=None)  # models it evaluates (any minimiser)
        if reason:  # a model an engine does not run must be refused, not run
            with pytest.raises(ValueError, match="cannot run"):
                ENGINES[engine](p)
            continue
        ref = energy_forces_pressure(p)
        with ENGINES[engine](p) as eng:
            got = eng.evaluate()
        assert ref.energy > 0
        assert got.energy == pytest.approx(ref.energy, rel=1e-12)
        assert rel(got.forces, ref.forces) < 1e-12
        assert rel(got.pressure_tensor, ref.pressure_tensor) < 1e-12
        if ref.torques is None:
            assert got.torques is None
        else:
            assert rel(got.torques, ref.torques) < 1e-12


def _turned(p: Packing, k: int, angle: float, axis: int = 2) -> Packing:
    """p with particle k turned by ``angle`` about the world axis (z in 2D)."""
    o = p.orientations.copy()
    if p.dim == 2:
        o[k] += angle
    else:
        dq = np.zeros(4)
        dq[0], dq[1 + axis] = np.cos(angle / 2), np.sin(angle / 2)
        w1, v1, (w2, *v2) = dq[0], dq[1:], o[k]
        o[k] = [w1 * w2 - v1 @ v2, *(w1 * np.array(v2) + w2 * v1 + np.cross(v1, v2))]
    return p.with_positions(p.positions, orientations=o)


def assert_energy_derivatives(p: Packing, stride: int, h: float = 1e-6) -> None:
    """Central finite differences (step h) of the reference energy: forces and torques of every
    stride-th particle to 1e-6 relative (1e-8 absolute)."""
    ref = energy_forces_pressure(p)
    for k in range(0, p.n, stride):
        for a in range(p.dim):
            dx = np.zeros_like(p.positions)
            dx[k, a] = h
            fd = -(energy_forces_pressure(p.with_positions(p.positions + dx)).energy
                   - energy_forces_pressure(p.with_positions(p.positions - dx)).energy) / (2 * h)
            assert fd == pytest.approx(ref.forces[k, a], rel=1e-6, abs=1e-8)
        for axis in ([2] if p.dim == 2 else [0, 1, 2]):
            fd = -(energy_forces_pressure(_turned(p, k, h, axis)).energy
                   - energy_forces_pressure(_turned(p, k, -h, axis)).energy) / (2 * h)
            torque = ref.torques[k] if p.dim == 2 else ref.torques[k, axis]
            assert fd == pytest.approx(torque, rel=1e-6, abs=1e-8)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("model", ["dimer", "asym-dimer", "trimer", "ellipsoid"])
def test_reference_forces_and_torques_are_energy_derivatives(model, dim):
    """Central finite differences of the reference energy (step 1e-6): forces and torques to 1e-8."""
    assert_energy_derivatives(sample(model, dim, n=24 if dim == 2 else 100, seed=5), 5 if dim == 2 else 12)


@pytest.mark.parametrize("dim", [2, 3])
def test_compiled_rotation_formulas_match_the_numpy_reference(dim):
    """The quaternion (angle) -> rotation matrix and world torque -> generalized torque of the
    compiled kernels (``engines.compiled.rotation``) against ``model.shapes.rotations``, the
    numpy reference: to round-off on random unit quaternions, torques and lengths."""
    from jamflow.engines.compiled import start_numba
    from jamflow.engines.compiled.rotation import generalized_torques as compiled_torques
    from jamflow.engines.compiled.rotation import rotation_matrix
    from jamflow.model.shapes.rotations import angle_matrices, generalized_torques, quaternion_matrices

    start_numba()
    rng = np.random.default_rng(7)
    n, r = 200, (1 if dim == 2 else 3)
    if dim == 2:
        orientations = rng.uniform(-np.pi, np.pi, n)
        o, tau, reference = orientations[:, None], rng.normal(size=n), angle_matrices(orientations)
    else:
        orientations = rng.normal(size=(n, 4))
        orientations /= np.linalg.norm(orientations, axis=1)[:, None]
        o, tau, reference = orientations, rng.normal(size=(n, 3)), quaternion_matrices(orientations)
    matrices = np.zeros((n, dim, dim))
    for i in range(n):
        rotation_matrix(o, i, matrices[i])
    assert np.abs(matrices - reference).max() <= 4e-16
    dk, mask = rng.uniform(0.2, 1.0, (n, r)), np.array([1.0] if dim == 2 else [0.0, 1.0, 1.0])
    g = np.zeros((n, r))
    compiled_torques(o, np.ascontiguousarray(tau.reshape(n, -1)), dk, mask, g)
    expected = generalized_torques(orientations, tau, dim, dk, mask)
    assert np.abs(g - expected).max() <= 1e-15 * np.abs(expected).max()
    assert (g[:, mask == 0] == 0).all() and np.abs(g).max() > 0


def test_two_dimers_closed_form_torque():
    """Two dimers (sites 1 and 1 at +-0.25 along x), the second above the first's right site,
    turned by 90 degrees: only sites (0, right) and (1, lower) overlap, by r = 0.9."""
    body = dimer(2)
    p = Packing([[0.0, 0.0], [0.25, 0.9 + 0.25]], [1.0, 1.0], Box.cube(10.0, 2), Spring(), shape=body,
                orientations=[0.0, np.pi / 2])
    ref = energy_forces_pressure(p)
    x = 1 - 0.9  # overlap of the two touching sites (sigma = 1)
    assert ref.energy == pytest.approx(0.5 * x * x, rel=1e-12)
    assert ref.forces[1] == pytest.approx([0.0, x], abs=1e-14)  # along +y, magnitude eps x / sigma
    # lever of dimer 0's right site (0.25, 0) x force (0, -x): torque -0.25 x... sign: z of (0.25,0) x (0,-x)
    assert ref.torques[0] == pytest.approx(-0.25 * x, rel=1e-12)
    assert ref.torques[1] == pytest.approx(0.0, abs=1e-15)  # its lower site lies on the force line
    with CompiledEngine(p) as eng:
        s = eng.evaluate()
    assert s.torques == pytest.approx(ref.torques, abs=1e-15)


def test_two_disks_closed_form():
    # overlap 1 - r/sigma = 0.1: V = 0.1^2 / 2, |F| = 0.1 / sigma, across the periodic boundary
    p = Packing(np.array([[0.2, 5.0], [9.3, 5.0]]), np.array([1.0, 1.0]), Box(np.eye(2) * 10.0), Spring())
    with CompiledEngine(p) as eng:
        s = eng.evaluate()
    assert s.energy == pytest.approx(0.005, rel=1e-13)
    assert s.forces[0] == pytest.approx([0.1, 0.0], abs=1e-14)  # 0.2 - 9.3 + 10 carries 4e-16
    assert s.forces[1] == pytest.approx([-0.1, 0.0], abs=1e-14)
    assert s.pressure_tensor[0, 0] == pytest.approx(0.9 * 0.1 / 100, rel=1e-12)  # r f / V


@pytest.mark.parametrize("tilt", [0.0, 0.3], ids=["orthogonal", "tilted"])
@pytest.mark.parametrize("dim", [2, 3])
def test_fire_reaches_the_lammps_minimum(config, dim, tilt):
    """Same FIRE 2.0 from the same overcompressed start: same minimum, similar work, also in a
    tilted box."""
    d = np.where(np.arange(128) % 2 == 0, 1.0, 1.4)
    p = config(128, dim, 0.86 if dim == 2 else 0.68, seed=5, diameters=d, tilt=tilt)
    settings = MinimizerSettings(force_tol=1e-13)
    results = {}
    for engine in (LammpsEngine, CompiledEngine):
        with engine(p) as eng:
            r = minimize(eng, settings)
            results[engine.name] = (r, eng.state(), eng.packing())
    (rl, sl, pl), (rn, sn, pn) = results["lammps"], results["numba"]
    assert rl.reason == rn.reason == "force"
    assert rn.energy_per_particle == pytest.approx(rl.energy_per_particle, rel=1e-9)
    assert np.allclose(sn.pressure_tensor, sl.pressure_tensor, rtol=1e-7, atol=1e-12)
    assert np.max(np.abs(p.box.minimum_image(pn.positions - pl.positions))) < 1e-6
    assert 0.5 < rn.iterations / rl.iterations < 2.0


def test_dilute_start_ends_unjammed_like_lammps(config):
    # all overlaps can vanish in one step (V = 0, F = 0): the force rule then fires first
    p = config(200, 2, 0.5, seed=2)
    for engine in (LammpsEngine, CompiledEngine):
        with engine(p) as eng:
            r = minimize(eng, MinimizerSettings())
        assert r.converged and r.energy_per_particle < 1e-16, engine.name


@pytest.mark.parametrize("model", ["sphere", "dimer"])
def test_pair_list_rebuilds_when_particles_travel(model):
    """From a random start particles move (and turn) far more than the skin: forces stay exact."""
    p = sample(model, 2, n=120, seed=9)
    with CompiledEngine(p, skin=0.05) as eng:
        minimize(eng, MinimizerSettings(max_iterations=3000, window=1000))
        moved = np.abs(p.box.minimum_image(eng.positions() - p.positions)).max()
        state = eng.state()
        end = eng.packing()
    assert moved > 0.05
    ref = energy_forces_pressure(end)
    assert state.energy == pytest.approx(ref.energy, rel=1e-10)
    assert np.max(np.abs(state.forces - ref.forces)) <= 1e-13 + 1e-10 * np.max(np.abs(ref.forces))


@pytest.mark.parametrize("tilt", [0.0, 0.25], ids=["orthogonal", "tilted"])
@pytest.mark.parametrize("engine", [LammpsEngine, CompiledEngine], ids=lambda e: e.name)
def test_set_box_is_affine_and_exact(config, engine, tilt):
    p = config(40, 3, 0.3, seed=4)
    h = p.box.h * 0.9
    h[0, 1] = tilt * h[1, 1]
    new = Box(h)
    with engine(p) as eng:
        eng.set_box(new)
        x = eng.positions()
        assert eng.box == new
    d = new.to_fractional(x) - p.box.to_fractional(p.positions)
    assert np.max(np.abs(d - np.round(d))) < 1e-13


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("model", ["dimer", "trimer"])
def test_fire_with_rotations_balances_forces_and_torques(model, dim):
    """An overcompressed packing of rigid bodies minimised by the compiled FIRE: at the end every
    force and torque vanishes by the independent reference, and the energy went down."""
    p = sample(model, dim, n=40, seed=2).scaled_to_phi(0.9 if dim == 2 else 0.72)
    start = energy_forces_pressure(p)
    with CompiledEngine(p) as eng:
        r = minimize(eng, MinimizerSettings(force_tol=1e-12))
        end = eng.packing()
    ref = energy_forces_pressure(end)
    assert r.reason == "force" and r.converged
    assert 0 < ref.energy < start.energy
    assert np.abs(ref.forces).max() < 1e-11
    assert np.abs(ref.torques).max() < 1e-11


def test_selection_rule(config):
    ortho, tilted = config(20, 2, 0.5, seed=1), config(20, 2, 0.5, seed=1, tilt=0.2)
    rlj = config(20, 2, 0.5, seed=1, potential=RepulsiveLJ())
    assert engine_name(ortho, "fire") == "numba"
    assert engine_name(ortho, "cg") == "lammps"
    assert engine_name(tilted, "fire") == "numba"
    assert engine_name(rlj, "fire") == "numba"
    assert engine_name(ortho, "fire", "lammps") == "lammps"
    assert engine_name(ortho, "fire", comm=object()) == "lammps"
    assert engine_name(sample("dimer", 2), "fire") == "numba"
    with open_engine(ortho, "fire") as eng:
        assert eng.name == "numba"


@pytest.mark.parametrize("packing,method,engine,match", [
    ("ortho", "md", "numba", "minimizer md"), ("ortho", "cg", "numba", "minimizer cg"),
    ("dimer", "fire", "lammps", "dimer"), ("dimer", "cg", "auto", "no engine runs")])
def test_forcing_an_engine_where_it_cannot_run_is_a_clear_error(config, packing, method, engine, match):
    p = {"ortho": config(20, 2, 0.5, seed=1), "dimer": sample("dimer", 2)}[packing]
    with pytest.raises(ValueError, match=match):
        engine_name(p, method, engine)


def test_options_are_passed_or_refused(config):
    p = config(20, 2, 0.5, seed=1)
    with open_engine(p, "fire", "numba", skin=0.2) as eng:
        assert eng.skin == 0.2
    with pytest.raises(ValueError, match="takes no option comm"):
        open_engine(p, "fire", "numba", comm=None, skin=0.2)
    with pytest.raises(ValueError, match="takes no option bogus"):
        open_engine(p, "fire", "lammps", bogus=1)


@pytest.mark.parametrize("engine", sorted(ENGINES))
def test_every_engine_implements_the_whole_contract(engine):
    """Each member of the ``Engine`` protocol is on both engines (callers need no hasattr)."""
    from jamflow.engines.base import Engine

    methods = {m for m, v in vars(Engine).items() if callable(v) and (not m.startswith("_") or m in ("__enter__", "__exit__"))}
    assert {"counters", "minimizer_session", "orientations", "close", "__enter__"} <= methods
    with ENGINES[engine](random_packing(8, 2, parse_sizes("bi:1.4:0.5"), 0.5, seed=1)) as eng:
        assert not [m for m in methods if not callable(getattr(eng, m, None))]
        assert not [a for a in Engine.__annotations__ if not hasattr(eng, a)]
        assert isinstance(eng.counters(), dict)


def test_compiled_engine_starts_no_lammps(monkeypatch):
    """The compiled path neither starts LAMMPS nor asks it for its version."""
    import jamflow.engines.lammps.library as lib

    def refuse(*a, **k):
        raise AssertionError("a LAMMPS instance was started")

    monkeypatch.setattr(lib, "new_lammps", refuse)
    r = jam(n=16, seed=1, engine="numba")
    assert r.engine == "numba" and r.lammps_version > 20200000


def test_unknown_engine_rejected_before_work():
    with pytest.raises(ValueError, match="unknown engine"):
        jam(n=16, engine="gpu")


def test_jam_with_either_engine_reaches_the_window():
    for engine in ("numba", "lammps"):
        r = jam(n=32, seed=4, engine=engine)
        assert r.engine == engine
        assert 1e-16 < r.energy_per_particle < 2e-16
        assert r.max_force < 1e-13
