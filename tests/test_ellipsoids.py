"""Ellipses and spheroids in every engine (docs/notes/ellipses.md): the compiled kernel and the LAMMPS plugin
against the numpy reference for every contact-distance method (1e-12), the reference against
finite differences, a two-ellipse closed form, minimisation with rotations in both engines,
packings checked by an independent brute-force energy, bad input refused before work, and the
count of truncation fallbacks."""

import subprocess
import warnings

import numpy as np
import pytest

from jamflow import jam
from jamflow.analysis.independent import brute_contact_distance, independent_check
from jamflow.model.box import Box
from jamflow.cli.app import main
from jamflow.engines.choose import engine_name
from jamflow.engines.compiled.engine import CompiledEngine
from jamflow.engines.lammps.engine import LammpsEngine
from jamflow.engines.lammps.library import new_lammps
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.minimize.settings import MinimizerSettings
from jamflow.model.packing import Packing, random_packing
from jamflow.model.potentials import RepulsiveLJ, Spring
from jamflow.protocols.compression import compress, initial_packing
from jamflow.protocols.settings import fast_protocol
from jamflow.model.shapes import SPHERE, Ellipsoid, contact_distance
from jamflow.model.sizes import parse_sizes
from jamflow.minimize.rules import minimize
from test_engines import assert_energy_derivatives, rel, tilted

ENGINES = {"lammps": LammpsEngine, "numba": CompiledEngine}

# (dim, alpha, sizes, method, tilt): every method where it is defined, prolate and oblate spheroids,
# 3D pairs of different sizes (maximisation path) and identical ones (quintic), alpha = 5 where the
# truncations fall back to lambda = 1/2
CASES = [
    (2, 1.6, "bi:1.4:0.5", "exact", 0.0), (2, 2.0, "bi:1.4:0.5", "exact", 0.37),
    (2, 2.0, "bi:1.4:0.5", "cleaver", 0.0), (2, 2.0, "mono", "gaussian", 0.0),
    (2, 2.0, "bi:1.4:0.5", "linear", 0.0), (2, 2.0, "bi:1.4:0.5", "quadratic", 0.0),
    (2, 5.0, "bi:1.4:0.5", "linear", 0.0), (2, 5.0, "bi:1.4:0.5", "quadratic", 0.0),
    (3, 1.8, "bi:1.4:0.5", "exact", 0.0), (3, 0.6, "bi:1.4:0.5", "exact", 0.3),
    (3, 0.6, "mono", "exact", 0.0), (3, 1.8, "bi:1.4:0.5", "cleaver", 0.0),
    (3, 1.8, "mono", "gaussian", 0.0), (3, 1.8, "mono", "quadratic", 0.0), (3, 0.5, "mono", "linear", 0.0),
]


def sample(dim, alpha, sizes, method, tilt=0.0, n=None, seed=3, potential=None, phi=None):
    n = n or (40 if dim == 2 else 100)
    p = random_packing(n, dim, parse_sizes(sizes), phi or (0.9 if dim == 2 else 0.65), seed,
                       potential or Spring(2.5), Ellipsoid(alpha, method))
    return tilted(p, tilt) if tilt else p


@pytest.mark.parametrize("engine", list(ENGINES))
@pytest.mark.parametrize("dim,alpha,sizes,method,tilt", CASES)
def test_engine_matches_reference_for_every_contact_method(engine, dim, alpha, sizes, method, tilt):
    p = sample(dim, alpha, sizes, method, tilt)
    ref = energy_forces_pressure(p)
    with ENGINES[engine](p) as eng:
        got = eng.evaluate()
        counts = eng.counters()
    assert ref.energy > 0
    assert got.energy == pytest.approx(ref.energy, rel=1e-12)
    assert rel(got.forces, ref.forces) < 1e-12
    assert rel(got.torques, ref.torques) < 1e-12
    assert rel(got.pressure_tensor, ref.pressure_tensor) < 1e-12
    assert counts["invalid"] == 0
    approximate = method in ("linear", "quadratic")
    assert (counts["approximate"] > 0) == approximate
    if not approximate or alpha < 3:
        assert counts["fallbacks"] == 0
    elif method == "linear":
        assert counts["fallbacks"] > 0


def test_engines_count_the_same_fallbacks():
    p = sample(2, 5.0, "bi:1.4:0.5", "linear")
    counts = []
    for engine in ENGINES.values():
        with engine(p) as eng:
            eng.evaluate()
            counts.append(eng.counters())
    assert counts[0] == counts[1] and counts[0]["fallbacks"] > 0


def test_lammps_rlj_and_hertz_laws_on_ellipsoids():
    for potential in (RepulsiveLJ(), Spring(2.0), Spring(3.0)):
        p = sample(2, 1.6, "bi:1.4:0.5", "exact", potential=potential, phi=0.75)
        ref = energy_forces_pressure(p)
        with LammpsEngine(p) as eng:
            got = eng.evaluate()
        assert got.energy == pytest.approx(ref.energy, rel=1e-12), potential.spec
        assert rel(got.forces, ref.forces) < 1e-12 and rel(got.torques, ref.torques) < 1e-12


@pytest.mark.parametrize("dim,method", [(2, "linear"), (2, "quadratic"), (3, "quadratic"), (2, "cleaver")])
def test_reference_forces_and_torques_are_energy_derivatives_for_approximations(dim, method):
    """Central differences (step 1e-6) of the reference energy with the truncated lambda."""
    p = sample(dim, 1.8, "bi:1.4:0.5" if dim == 2 else "mono", method, n=24 if dim == 2 else 60, seed=5)
    assert_energy_derivatives(p, 6)


@pytest.mark.parametrize("engine", ["reference", *ENGINES])
@pytest.mark.parametrize("phi_angle", [0.0, np.pi / 2, 0.6])
def test_two_parallel_ellipses_closed_form(engine, phi_angle):
    """Two identical parallel ellipses (a = 2, b = 1), directors at angle phi to r_hat: they touch at
    sigma(phi) = (cos^2 phi / a^2 + sin^2 phi / b^2)^-1/2 (end-to-end a, side-by-side b), the
    difference body being the ellipse doubled. Turning both directors by d turns the pair's
    geometry like phi + d, and exchange symmetry splits it equally: dsigma/dtheta_i =
    sigma'(phi) / 2, so with V = (1 - s)^2 / 2 the torque on each is -(1 - s) r sigma'(phi) / (2 sigma^2)."""
    a, b = 2.0, 1.0
    sig = (np.cos(phi_angle) ** 2 / a**2 + np.sin(phi_angle) ** 2 / b**2) ** -0.5
    dsig = -(sig**3) * np.sin(phi_angle) * np.cos(phi_angle) * (1 / b**2 - 1 / a**2)
    r = 0.95 * sig
    rhat = np.array([np.cos(0.3), np.sin(0.3)])  # the pair's direction in the box
    theta = 0.3 + phi_angle
    p = Packing([[5.0, 5.0], list(np.array([5.0, 5.0]) - r * rhat)], [1.0, 1.0], Box.cube(12.0, 2), Spring(),
                shape=Ellipsoid(a / b), orientations=[theta, theta])
    if engine == "reference":
        got = energy_forces_pressure(p)
    else:
        with ENGINES[engine](p) as eng:
            got = eng.evaluate()
    s = r / sig
    assert got.energy == pytest.approx(0.5 * (1 - s) ** 2, rel=1e-12)
    torque = -(1 - s) * r * dsig / (2 * sig**2)
    assert got.torques[0] == pytest.approx(torque, rel=1e-10, abs=1e-15)
    assert got.torques[1] == pytest.approx(torque, rel=1e-10, abs=1e-15)
    # force on 0 (r_0 - r_1 = r rhat): radial (1 - s)/sigma; turning r_hat by psi at fixed directors turns
    # phi by -psi, so d sigma / d psi = -sigma'(phi)
    t_hat = np.array([-rhat[1], rhat[0]])
    force = (1 - s) * (rhat / sig + dsig * t_hat / sig**2)
    assert got.forces[0] == pytest.approx(force, rel=1e-10, abs=1e-15)
    assert got.forces[1] == pytest.approx(-force, rel=1e-10, abs=1e-15)


def test_lammps_reads_the_quaternions_it_was_given(tmp_path):
    """Orientations reach the plugin: a data file's quaternions read back to round-off, and
    ``set atom ID quat`` (axis, angle in degrees) gives the quaternion of that rotation."""
    p = sample(3, 1.8, "bi:1.4:0.5", "exact", n=60)
    with LammpsEngine(p) as eng:
        q = eng.orientations()
        assert np.max(np.abs(q - p.orientations)) < 4e-16
        eng.command("set atom 3 quat 0.6 -0.8 0.0 71.5")  # a unit axis (LAMMPS normalises only the result)
        half = np.radians(71.5) / 2
        expected = np.array([np.cos(half), 0.6 * np.sin(half), -0.8 * np.sin(half), 0.0])
        eng.command("run 0")
        assert np.max(np.abs(eng.orientations()[2] - expected)) < 4e-16
        eng.set_positions(p.positions, p.orientations)  # set_positions goes through set ... quat
        assert np.max(np.abs(eng.orientations() - p.orientations)) < 1e-15
        turned = p.with_positions(p.positions, orientations=eng.orientations())
        ref = energy_forces_pressure(turned)
        assert rel(eng.evaluate().torques, ref.torques) < 1e-12  # the plugin sees the new orientation


def test_plugin_refuses_a_lammps_version_it_was_not_built_for(tmp_path):
    from jamflow.engines.lammps import plugin_build

    compiler = plugin_build.find_compiler()
    flags = [*plugin_build.CXXFLAGS, "-DLAMMPS_SMALLBIG", '-DJAMFLOW_LAMMPS_VERSION="1 Jan 2000"',
             *(f"-I{d}" for d in plugin_build.include_dirs())]
    target = tmp_path / "old.so"
    subprocess.run([*compiler, *flags, str(plugin_build.PLUGIN_DIR / "pair_jamflow.cpp"), "-o", str(target)],
                   check=True, capture_output=True)
    lmp = new_lammps()
    try:
        with pytest.raises(Exception, match="compiled for LAMMPS 1 Jan 2000 but this is LAMMPS"):
            lmp.command(f'plugin load "{target}"')
    finally:
        lmp.close()


@pytest.mark.parametrize("dim,method", [(2, "exact"), (2, "quadratic"), (3, "exact")])
def test_compiled_fire_balances_forces_and_torques(dim, method):
    p = sample(dim, 1.6 if dim == 2 else 0.6, "bi:1.4:0.5" if method == "exact" else "mono", method, n=40,
               seed=2, phi=0.92 if dim == 2 else 0.72)
    start = energy_forces_pressure(p)
    with CompiledEngine(p) as eng:
        r = minimize(eng, MinimizerSettings(force_tol=1e-12))
        end = eng.packing()
    ref = energy_forces_pressure(end)
    assert r.reason == "force" and 0 < ref.energy < start.energy
    assert np.abs(ref.forces).max() < 1e-11 and np.abs(ref.torques).max() < 1e-11


HALF_TURN_Z = [np.sqrt(0.5), 0.0, 0.0, np.sqrt(0.5)]  # quaternion: the director (body x) along world y


@pytest.mark.parametrize("alpha,orientation", [(None, None), (0.6, [1.0, 0, 0, 0]), (0.4, [1.0, 0, 0, 0]),
                                               (1.5, HALF_TURN_Z), (3.0, HALF_TURN_Z)])
def test_fire_steps_in_units_of_the_stiffest_contact(alpha, orientation):
    """Two unit-mass particles at their smallest contact distance l, 5 % overlapped (oblate spheroids
    face to face, prolate ones side by side, spheres): the stiffest mode of V = (1 - r/l)^2 / 2 is the
    relative coordinate's, lambda_max = 2 / l^2 (closed form). FIRE's time unit is l (``time_unit``), so
    lambda_max x time_unit^2 = 2 for every shape: its largest step dt0 tmax is equally far from the
    stability limit 2 / sqrt(lambda_max). (Before, the unit was 1: an oblate 0.6 ran at 1/0.6 of the
    spheres' stability number, at the edge of stability: docs/notes/ellipses.md, "FIRE's time unit and the oblate creep".)"""
    from jamflow.engines.compiled.fire import time_unit
    from jamflow.mechanics.hessian import hessian

    shape = SPHERE if alpha is None else Ellipsoid(alpha)
    unit = time_unit(shape)
    assert unit == pytest.approx(1.0 if alpha is None else min(alpha, 1.0), rel=1e-15)
    r = 0.95 * unit
    p = Packing([[5.0, 5.0, 5.0], [5.0 + r, 5.0, 5.0]], [1.0, 1.0], Box.cube(12.0, 3), Spring(), shape=shape,
                orientations=None if alpha is None else [orientation, orientation])
    lam_max = np.linalg.eigvalsh(hessian(p).toarray()).max()
    assert lam_max == pytest.approx(2.0 / unit**2, rel=1e-12)


def test_oblate_spheroids_relax_at_the_prolate_rate():
    """Three random starts of 24 oblate spheroids (0.6) at phi = 0.68, just below onset, minimised to
    V/N < 1e-12: 2 313 FIRE iterations in all (483, 450, 1 380); with the time step in units of the
    sphere diameter (as before the measurement in docs/notes/ellipses.md) 7 684 (3 285, 1 005, 3 394), FIRE resetting on P < 0
    every few steps. Counts, not times (deterministic on one machine)."""
    total = 0
    for seed in range(3):
        p = initial_packing(24, 3, "mono", "spring", seed, 0.68, "spheroid:0.6")
        with CompiledEngine(p) as eng:
            r = minimize(eng, MinimizerSettings(v_min=1e-12, force_tol=1e-10))
        assert r.reason == "energy-below-vmin"
        total += r.iterations
    assert total < 4000


@pytest.mark.parametrize("dim", [2, 3])
def test_lammps_damped_dynamics_balances_forces_and_torques(dim):
    """fix nve/asphere + fix langevin at T = 0 with angmom, stopped by the minimiser's rules on the
    conservative forces and torques: from a minimum of the compiled FIRE compressed by 0.2 %."""
    p = sample(dim, 1.6 if dim == 2 else 0.6, "bi:1.4:0.5", "exact", n=40, seed=2, phi=0.9 if dim == 2 else 0.8)
    with CompiledEngine(p) as eng:
        assert minimize(eng, MinimizerSettings(force_tol=1e-12)).reason == "force"  # jammed
        p = eng.packing().scaled_to_phi(p.phi * 1.002)
    with LammpsEngine(p) as eng:
        r = minimize(eng, MinimizerSettings(method="md", force_tol=1e-12))
        end = eng.packing()
        g = eng.generalized_torques()
        state = eng.state()
    ref = energy_forces_pressure(end)
    assert r.reason == "force" and r.max_torque == pytest.approx(np.abs(g).max())
    assert r.max_force == pytest.approx(np.abs(ref.forces).max(), rel=1e-6)  # conservative forces, no drag
    assert np.abs(state.torques - ref.torques).max() < 1e-15
    assert np.abs(ref.forces).max() < 1e-12 and np.abs(ref.torques).max() < 1e-11
    assert np.abs(end.orientations - p.orientations).max() > 1e-6  # they turned


def test_engine_choice_for_ellipses():
    p = sample(2, 1.6, "bi:1.4:0.5", "exact")
    assert engine_name(p, "fire") == "numba"
    assert engine_name(p, "md") == "lammps"
    for method in ("fire", "cg"):
        with pytest.raises(ValueError, match="no LAMMPS minimiser moves orientations"):
            engine_name(p, method, "lammps")
    with pytest.raises(ValueError, match="no engine runs this scene"):
        engine_name(p, "cg")


def test_alpha_one_runs_the_disk_path():
    disk = jam(n=16, seed=2, shape="disk")
    one = jam(n=16, seed=2, shape="ellipse:1")
    assert one.packing.shape.kind == "sphere" and one.packing.orientations is None
    assert repr(one.phi_j) == repr(disk.phi_j) and one.iterations == disk.iterations


def test_jammed_ellipses_pass_the_independent_check():
    """A small packing at onset: in the energy window and force/torque balanced by the brute-force
    contact distance, which agrees with the exact solver to round-off."""
    r = jam(n=24, dim=2, sizes="bi:1.4:0.6667", shape="ellipse:1.6", seed=4)
    check = independent_check(r.packing)
    assert 1e-16 < check.energy_per_particle < 2e-16
    assert check.energy_per_particle == pytest.approx(r.energy_per_particle, rel=1e-6)
    assert check.max_force() < 1e-12 and check.max_generalized_torque() < 1e-12
    with CompiledEngine(r.packing) as eng:
        state = eng.evaluate()
    assert np.max(np.abs(check.forces - state.forces)) < 1e-14  # brute sigma to ~1e-15, overlaps ~1e-8
    assert np.max(np.abs(check.torques - state.torques)) < 1e-14


def test_brute_force_contact_distance_agrees_with_the_exact_solver():
    rng = np.random.default_rng(4)
    for dim in (2, 3):
        n = 300
        unit = lambda: (lambda v: v / np.linalg.norm(v, axis=1)[:, None])(rng.normal(size=(n, dim)))  # noqa: E731
        b_i, b_j = rng.choice([1.0, 1.4], n), rng.choice([1.0, 1.4], n)
        alpha = rng.uniform(1.01, 3, n) if dim == 2 else np.exp(rng.uniform(-1.5, 1.5, n))
        args = (alpha * b_i, b_i, alpha * b_j, b_j, unit(), unit(), unit())
        assert np.max(np.abs(brute_contact_distance(*args) / contact_distance(*args) - 1)) < 3e-15


def test_truncation_fallbacks_are_counted_and_warned():
    with pytest.warns(UserWarning, match=r"fell back to 1/2 in \d+ of \d+ contact evaluations"):
        r = jam(n=20, dim=2, sizes="mono", shape="ellipse:3.2", contact="linear", seed=1)
    assert 0 < r.counters["fallbacks"] <= r.counters["approximate"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert jam(n=12, dim=2, sizes="mono", shape="ellipse:1.5", contact="quadratic", seed=1).counters["fallbacks"] == 0


@pytest.mark.parametrize("args,message", [
    (["--shape", "ellipse:0"], "ALPHA must be a finite number > 0"),
    (["--shape", "ellipse:-1.5"], "ALPHA must be a finite number > 0"),
    (["--shape", "ellipse:nan"], "ALPHA must be a finite number > 0"),
    (["--shape", "ellipse:inf"], "ALPHA must be a finite number > 0"),
    (["--shape", "ellipse:abc"], "must be a number"),
    (["--shape", "ellipse:0.5"], "turned by 90 degrees"),
    (["--shape", "ellipse:1.5", "--dim", "3"], "'ellipse' is 2D"),
    (["--shape", "spheroid:1.5"], "'spheroid' is 3D"),
    (["--shape", "ellipse:1.5", "--contact", "gaussian", "--sizes", "bi:1.4:0.5"], "identical particles"),
    (["--shape", "spheroid:1.5", "--dim", "3", "--contact", "linear"], "--contact linear cannot make a checked packing"),
    (["--shape", "ellipse:1.5", "--minimizer", "cg"], "no LAMMPS minimiser moves orientations"),
    (["--shape", "ellipse:1.5", "--engine", "lammps"], "no LAMMPS minimiser moves orientations"),
])
def test_bad_shape_input_gives_clear_error_before_work(tmp_path, capsys, monkeypatch, args, message):
    import jamflow.protocols.compression as compression

    monkeypatch.setattr(compression, "open_engine", lambda *a, **k: pytest.fail("work started"))
    out = tmp_path / "x.h5"
    assert main(["jam", "--quiet", "--n", "16", "--out", str(out), *args]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_start_too_dense_for_the_contact_distance_is_refused_before_work(monkeypatch):
    import jamflow.protocols.compression as compression

    p = sample(2, 1.6, "bi:1.4:0.5", "exact", n=20)
    x = p.positions.copy()
    x[1] = x[0] + 1e-9
    monkeypatch.setattr(compression, "open_engine", lambda *a, **k: pytest.fail("work started"))
    with pytest.raises(ValueError, match="too dense for the contact distance: particles 0 and 1"):
        compress(p.with_positions(x), fast_protocol())


def test_checked_in_ellipse_deck_is_the_generated_one():
    from jamflow.decks.ellipsoids import deck_text, default_deck_path

    assert default_deck_path().read_text() == deck_text()


def test_cli_emits_the_ellipse_deck(tmp_path, capsys):
    from jamflow.decks.ellipsoids import read_ellipsoid_data
    from jamflow.engines.lammps.plugin_build import plugin_library

    deck = tmp_path / "deck.lmp"
    assert main(["jam", "--n", "12", "--shape", "ellipse:1.3", "--contact", "cleaver", "--seed", "3",
                 "--emit-deck", str(deck), "--out", str(tmp_path / "jammed.h5")]) == 0
    assert "deck.start.data" in capsys.readouterr().out
    text = deck.read_text()
    for line in ("variable alpha     index 1.3", "variable contact   index cleaver", f"index {plugin_library()}"):
        assert line in text
    start = read_ellipsoid_data(tmp_path / "deck.start.data", contact="cleaver")
    expected = initial_packing(12, 2, "bi:1.4:0.5", "spring", 3, 0.8, "ellipse:1.3", contact="cleaver")
    assert np.abs(start.positions - expected.positions).max() < 1e-13
    assert np.abs(np.cos(start.orientations - expected.orientations) - 1).max() < 1e-13


def test_ellipse_deck_jams_in_lmp_alone(tmp_path):
    """lmp runs the deck with the plugin and damped dynamics, from a start just above onset (the
    compiled engine's packing compressed by 2e-5); the packing it writes is at onset by the
    independent brute-force check."""
    from jamflow.decks.jam import run_deck
    from jamflow.decks.ellipsoids import emit_deck, read_ellipsoid_data
    from jamflow.protocols.settings import chapter_protocol

    near = jam(n=12, sizes="bi:1.4:0.6667", shape="ellipse:1.3", seed=3)
    start = near.packing.scaled_to_phi(near.phi_j + 2e-5)
    deck, _ = emit_deck(tmp_path / "deck.lmp", start, chapter_protocol(dphi0=1e-5))
    res = run_deck(tmp_path, {}, deck=deck, reader=read_ellipsoid_data, timeout=1200)
    assert 1e-16 < res.energy_per_particle < 2e-16 and res.packing.n == 12
    assert res.packing.shape == Ellipsoid(1.3) and res.history["reason"][-1] == "force"
    check = independent_check(res.packing)
    assert check.energy_per_particle == pytest.approx(res.energy_per_particle, rel=1e-6)
    worst = max(check.max_force(), check.max_generalized_torque())
    assert worst < 1e-12 and worst == pytest.approx(res.max_force, rel=1e-3)  # the deck's max(F, tau/d_k)


def test_ellipse_deck_refuses_what_it_cannot_run():
    from jamflow.decks.ellipsoids import deck_variables

    with pytest.raises(ValueError, match="identical particles"):
        deck_variables(contact="gaussian")
    with pytest.raises(ValueError, match="turned by 90 degrees"):
        deck_variables(alpha=0.5)
    with pytest.raises(ValueError, match="linear spring"):
        deck_variables(potential="hertz")


def test_plugin_refuses_triaxial_ellipsoids():
    p = sample(3, 1.8, "mono", "exact", n=60)
    with LammpsEngine(p) as eng:
        eng.command("set atom 1 shape 1.8 1.0 1.2")
        with pytest.raises(Exception, match="handles spheroids: every atom needs shape a b b"):
            eng.evaluate()
