"""The compiled engine's option ``threads`` (``jamflow.engines.compiled.threads``): FIRE and the
disk/sphere forces on several numba threads.

- The work is cut into fixed chunks and their partial sums are added in a fixed order, so a
  minimisation gives the same bits on 1 and on 2 threads (numba.set_num_threads).
- Against the serial kernels only the order of the sums differs: forces, energy and virial agree to
  round-off, and a minimisation from the same start reaches the same minimum (same contacts, energy
  to round-off); a jam with threads passes the packing checks.
- threads = 1 is the serial path; bad values are refused before any work; a scene the threaded
  kernels do not run (ellipses, walls, gravity, a target pressure, ...) runs serial with one warning.
"""

from __future__ import annotations

import warnings

import numba
import numpy as np
import pytest

from jamflow.engines.choose import open_engine
from jamflow.engines.compiled.engine import CompiledEngine
from jamflow.mechanics.checks import check_packing
from jamflow.minimize.settings import MinimizerSettings
from jamflow.protocols.compression import at_shear_strain, initial_packing, jam

two_threads = pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="numba runs one thread here")


def _start(n=256, dim=2, seed=1, potential="spring", gamma=None):
    """A random start just above the onset (2D bidisperse 0.845, 3D monodisperse 0.645)."""
    sizes, phi = ("bi:1.4:0.5", 0.845) if dim == 2 else ("mono", 0.645)
    start = initial_packing(n, dim, sizes, potential, seed, phi)
    return at_shear_strain(start, gamma) if gamma is not None else start


def _minimise(packing, threads, steps=20_000, ftol=1e-13):
    """(positions, state, iterations) after FIRE from ``packing``."""
    with CompiledEngine(packing, threads=threads) as eng:
        with eng.minimizer_session(MinimizerSettings(), ftol) as window:
            done = window(steps)
        return eng.positions(), eng.state(), done.iterations


def _contacts(packing, positions):
    """The set of pairs (i, j) that overlap at ``positions``."""
    from jamflow.model.pairs import candidate_pairs

    d = packing.diameters
    i, j = candidate_pairs(packing, float(d.max()))
    dr = packing.box.minimum_image(positions[i] - positions[j])
    inside = np.einsum("ij,ij->i", dr, dr) < (0.5 * (d[i] + d[j])) ** 2
    return set(zip(i[inside].tolist(), j[inside].tolist()))


@two_threads
@pytest.mark.filterwarnings("ignore:jamflow. threads=2, but numba runs at most 1")  # on purpose: 1 thread
@pytest.mark.parametrize("dim, potential", [(2, "spring"), (3, "spring"), (2, "hertz")])
def test_a_minimisation_gives_the_same_bits_on_one_and_on_two_threads(dim, potential):
    start = _start(n=256 if dim == 2 else 128, dim=dim, potential=potential)
    before = numba.get_num_threads()
    runs = []
    try:
        for count in (1, 2, 1):
            numba.set_num_threads(count)
            runs.append(_minimise(start, threads=2, steps=3000))
    finally:
        numba.set_num_threads(before)
    (x1, s1, it1), (x2, s2, it2), (x3, _, _) = runs
    assert it1 == it2 > 100 and not np.array_equal(x1, start.positions)  # the runs did work
    assert np.array_equal(x1, x2) and np.array_equal(x1, x3)
    assert s1.energy == s2.energy and np.array_equal(s1.forces, s2.forces)
    assert np.array_equal(s1.pressure_tensor, s2.pressure_tensor)


# N = 8192: a Morton-numbered start (jamflow.model.ordering), most pairs within one range of particles
@pytest.mark.parametrize("n, dim, potential, gamma", [(300, 2, "spring", None), (300, 3, "spring", None),
                                                      (300, 2, "hertz", None), (300, 2, "spring", 0.1),
                                                      (8192, 2, "spring", None)])
def test_forces_energy_and_virial_agree_with_the_serial_kernels_to_round_off(n, dim, potential, gamma):
    start = _start(n=n, dim=dim, potential=potential, gamma=gamma)
    with CompiledEngine(start) as serial, CompiledEngine(start, threads=2) as threaded:
        a, b = serial.evaluate(), threaded.evaluate()
    assert threaded.kernels == "numba, 2 threads" and serial.kernels != threaded.kernels
    assert a.energy > 0 and b.energy == pytest.approx(a.energy, rel=1e-13)
    scale = np.abs(a.forces).max()
    assert np.abs(a.forces - b.forces).max() < 1e-13 * scale
    assert np.abs(a.pressure_tensor - b.pressure_tensor).max() < 1e-13 * np.abs(a.pressure_tensor).max()


@pytest.mark.parametrize("dim", [2, 3])
def test_a_minimisation_reaches_the_serial_minimum(dim):
    start = _start(n=256 if dim == 2 else 128, dim=dim, seed=2)
    xs, ss, _ = _minimise(start, threads=1)
    xt, st, _ = _minimise(start, threads=2)
    assert ss.max_force < 1e-13 and st.max_force < 1e-13
    assert ss.energy > 1e-6 * start.n  # above the onset: a contact network, not a relaxed gas
    assert st.energy == pytest.approx(ss.energy, rel=1e-9)
    assert _contacts(start, xt) == _contacts(start, xs)


def test_a_jam_on_two_threads_passes_the_packing_checks():
    serial = jam(n=128, seed=3)
    threaded = jam(n=128, seed=3, engine_options={"threads": 2})
    assert threaded.kernels == "numba, 2 threads"
    packing = threaded.packing
    checks = check_packing(packing, threaded.energy_per_particle, None, threaded.settings.v_tol)
    assert checks.passed, checks.problems()
    assert threaded.phi_j == pytest.approx(serial.phi_j, abs=1e-3)


def test_one_thread_is_the_serial_path():
    start = _start(n=64)
    with CompiledEngine(start) as default, open_engine(start, engine="numba", threads=1) as one:
        assert one.threads == 1 and one.kernels == default.kernels and type(one._kernels) is type(default._kernels)
        a, b = default.evaluate(), one.evaluate()
    assert a.energy == b.energy and np.array_equal(a.forces, b.forces)


@pytest.mark.parametrize("bad", [0, -2, 1.5, 2.0, "2", True, None])
def test_a_bad_thread_count_is_refused_before_any_work(bad):
    start = _start(n=64)
    with pytest.raises(ValueError, match="threads must be an integer >= 1"):
        open_engine(start, engine="numba", threads=bad)
    with pytest.raises(ValueError, match="threads must be an integer >= 1"):
        jam(n=64, engine_options={"threads": bad})


def test_the_lammps_engine_takes_no_threads():
    with pytest.raises(ValueError, match="engine lammps takes no option threads"):
        open_engine(_start(n=64), engine="lammps", threads=2)


def _one_warning(make, about="threads=2"):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        value = make()
    lines = [str(w.message) for w in caught if about in str(w.message)]
    assert len(lines) == 1, lines
    return value, lines[0]


@pytest.mark.parametrize("scene, why", [
    (dict(shape="ellipse:1.5"), "not ellipse particles"),
    (dict(walls="y"), "not walls"),
    (dict(potential="rlj"), "not the potential rlj"),
])
def test_a_scene_the_threaded_kernels_do_not_run_runs_serial_with_one_warning(scene, why):
    start = initial_packing(64, 2, "bi:1.4:0.5", scene.get("potential", "spring"), 0, 0.7,
                            scene.get("shape", "disk"), scene.get("walls"))
    engine, line = _one_warning(lambda: CompiledEngine(start, threads=2))
    assert why in line and "the serial kernels run this scene" in line
    assert engine.threads == 1 and "threads" not in engine.kernels


def test_a_target_pressure_runs_serial_with_one_warning():
    from jamflow.protocols.pressure import PressureSettings, jam_at_pressure

    start = initial_packing(64, 2, "bi:1.4:0.5", "spring", 0, 0.8)
    result, line = _one_warning(lambda: jam_at_pressure(start, PressureSettings((1e-3,)),
                                                        engine_options={"threads": 2}))
    assert "not a target pressure" in line and result.packing.n == 64
    assert "threads" not in result.kernels  # the summary names the kernels that ran


def test_jam_threads_runs_and_writes_a_checked_packing(tmp_path, capsys):
    from jamflow.cli.app import main
    from jamflow.io.packing_file import load_packing, read_protocol

    out = tmp_path / "p.h5"
    assert main(["jam", "--quiet", "--n", "64", "--seed", "2", "--threads", "2", "--out", str(out)]) == 0
    assert "numba, 2 threads" in capsys.readouterr().out
    assert load_packing(out).n == 64 and read_protocol(out)["threads"] == 2
    serial = tmp_path / "s.h5"
    assert main(["jam", "--quiet", "--n", "64", "--seed", "2", "--out", str(serial)]) == 0
    assert "threads" not in read_protocol(serial)  # the serial file as before


@pytest.mark.parametrize("args, message", [
    (["--threads", "0"], "--threads must be an integer >= 1"),
    (["--threads", "2", "--engine", "lammps"], "--threads runs the compiled engine's FIRE; this jam runs in LAMMPS"),
    (["--threads", "2", "--emit-deck", "x.lmp"], "--emit-deck writes a LAMMPS deck"),
])
def test_jam_refuses_a_bad_threads_option_before_any_work(tmp_path, capsys, args, message):
    from jamflow.cli.app import main

    out = tmp_path / "x.h5"
    assert main(["jam", "--quiet", "--n", "64", *args, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not out.exists()


def test_jam_refuses_a_threads_option_that_is_not_an_integer(capsys):
    from jamflow.cli.app import main

    with pytest.raises(SystemExit) as stop:
        main(["jam", "--quiet", "--n", "64", "--threads", "two"])
    assert stop.value.code == 2 and "--threads: invalid int value" in capsys.readouterr().err


def test_more_threads_than_numba_runs_are_capped_with_one_warning():
    start = _start(n=64)
    ask = numba.config.NUMBA_NUM_THREADS + 1
    engine, line = _one_warning(lambda: CompiledEngine(start, threads=ask), f"threads={ask}")
    assert f"numba runs at most {numba.get_num_threads()}" in line
    assert engine.threads == numba.get_num_threads() and engine.kernels.startswith("numba, ")
