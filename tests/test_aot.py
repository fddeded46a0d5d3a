"""The disk/sphere kernels compiled ahead of time (``jamflow.engines.compiled.aot``) against numba's.

The AOT module is numba's own compilation of the same functions, so every result must be
bit-identical to the numba path (``JAMFLOW_AOT=0``): whole jams (phi_J, iterations, positions) over
the scenes it serves (2D/3D, harmonic and Hertzian springs, smooth and rough walls, gravity,
constant pressure), force evaluations of overlapping states, and the cell-list pair search against
scipy's cKDTree. A disk jam process then imports neither numba nor scipy.spatial; a failed or
damaged build falls back to numba with one warning.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from scipy.spatial import cKDTree

from jamflow.engines.compiled import aot
from jamflow.engines.compiled.engine import CompiledEngine
from jamflow.protocols.compression import initial_packing, jam
from jamflow.protocols.pressure import PressureSettings, jam_at_pressure


@pytest.fixture(scope="module")
def built():
    """The AOT module of this installation (built on first use: ~20 s on a fresh cache)."""
    found = aot.module()
    failed = aot.module_path().parent / "failed"
    assert found is not None, f"the AOT module was not built: {failed.read_text() if failed.exists() else '?'}"
    return found


def _spy(monkeypatch):
    """Count the calls of the AOT kernels."""
    calls = []
    for name in ("fire", "forces"):
        original = getattr(aot.AotKernels, name)
        monkeypatch.setattr(aot.AotKernels, name, lambda self, *a, _f=original: calls.append(1) or _f(self, *a))
    return calls


def _both(monkeypatch, run):
    """``run()`` with numba's kernels (JAMFLOW_AOT=0), then with the AOT ones (which must be called)."""
    monkeypatch.setenv("JAMFLOW_AOT", "0")
    reference = run()
    monkeypatch.setenv("JAMFLOW_AOT", "1")
    calls = _spy(monkeypatch)
    result = run()
    assert calls, "the AOT kernels were not used"
    return reference, result


SCENES = {
    "2D harmonic": dict(n=32, seed=3),
    "2D hertz": dict(n=32, seed=4, potential="hertz"),
    "3D harmonic": dict(n=32, seed=5, dim=3, sizes="mono"),
    "2D smooth walls": dict(n=32, seed=6, walls="y"),
    "2D rough walls": dict(n=32, seed=7, walls="x,y", wall_type="rough"),
    "2D gravity": dict(n=32, seed=8, walls="y", gravity=1e-3),
}


@pytest.mark.parametrize("scene", SCENES)
def test_jams_are_bit_identical_to_numba(built, monkeypatch, scene):
    ref, res = _both(monkeypatch, lambda: jam(**SCENES[scene]))
    assert res.iterations == ref.iterations and res.minimizations == ref.minimizations
    assert res.phi_j == ref.phi_j or (np.isnan(res.phi_j) and np.isnan(ref.phi_j))
    assert res.packing.positions.tobytes() == ref.packing.positions.tobytes()


def test_constant_pressure_is_bit_identical_to_numba(built, monkeypatch):
    start = initial_packing(32, 2, "bi:1.4:0.5", "spring", 2, 0.8)
    ref, res = _both(monkeypatch, lambda: jam_at_pressure(start, PressureSettings((1e-4, 1e-5), "tri")))
    assert res.packing.positions.tobytes() == ref.packing.positions.tobytes()
    assert np.array_equal(res.packing.box.h, ref.packing.box.h) and res.packing.box.is_triclinic


@pytest.mark.parametrize("dim,potential", [(2, "spring"), (3, "hertz")])
def test_forces_of_overlapping_states_are_bit_identical(built, monkeypatch, dim, potential):
    start = initial_packing(300, dim, "bi:1.4:0.5", potential, 1, 0.5)
    start = start.scaled_to_phi(1.1)  # deep overlaps everywhere

    def evaluate():
        state = CompiledEngine(start).evaluate()
        return state.energy, state.forces.tobytes(), state.pressure_tensor.tobytes()

    ref, res = _both(monkeypatch, evaluate)
    assert res == ref and ref[0] > 0


CASES = [  # (dim, lengths, periodic, n, rmax): 1-30 cells per axis, walls, dense and sparse
    (2, (6.0, 6.0), (True, True), 80, 2.9), (2, (6.0, 40.0), (True, True), 150, 1.3),
    (2, (9.0, 9.0), (True, False), 120, 1.4), (3, (5.0, 7.0, 12.0), (True, True, True), 150, 1.6),
    (3, (8.0, 8.0, 8.0), (False, True, False), 150, 1.5), (3, (100.0, 100.0, 100.0), (True, True, True), 1500, 3.0),
]


@pytest.mark.parametrize("case", CASES)
def test_the_cell_list_finds_the_pairs_of_ckdtree(built, case):
    """The same pair set, pairs at exactly rmax included, positions beyond walls too."""
    dim, lengths, periodic, n, rmax = case
    rng = np.random.default_rng(n + dim)
    L, per = np.array(lengths), np.array(periodic)
    x = rng.uniform(0, 1, (n, dim)) * L
    x[:, ~per] = rng.uniform(-0.3, 1.3, (n, int((~per).sum()))) * L[~per]
    x[1] = x[0] + np.eye(dim)[0] * rmax
    x[3] = x[2] + np.eye(dim)[-1] * rmax
    x[:, per] = np.mod(x[:, per], L[per])
    x[:, per] = np.where(x[:, per] >= L[per], 0.0, x[:, per])
    i, j = built.cell_pairs(np.ascontiguousarray(x), L, per.astype(np.int64), rmax)
    ref = cKDTree(x, boxsize=np.where(per, L, 0.0)).query_pairs(rmax, output_type="ndarray")
    assert np.all(i < j) and len(ref) > 0
    assert sorted(zip(i.tolist(), j.tolist())) == sorted(map(tuple, ref.tolist()))


def test_a_disk_jam_imports_neither_numba_nor_scipy_spatial(built, tmp_path):
    code = ("import sys\nfrom jamflow.cli.app import main\n"
            f"code = main(['jam', '--n', '16', '--seed', '2', '--quiet', '--out', {str(tmp_path / 'p.h5')!r}])\n"
            "print(code, 'numba' in sys.modules, 'scipy.spatial' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out[-3:] == ["0", "False", "False"]  # after the CLI's result line


def test_numba_starts_on_first_use_and_swaps_the_deferred_kernels():
    code = ("import sys, numpy as np\n"
            "from jamflow.engines.compiled import Deferred, cells, spheres\n"
            "before = isinstance(spheres.forces, Deferred), 'numba' in sys.modules\n"
            "i, j = cells.cell_pairs(np.array([[0.5, 0.5], [1.0, 0.5]]), np.array([4.0, 4.0]), np.ones(2, np.int64), 1.0)\n"
            "print(*before, 'numba' in sys.modules, type(spheres.forces).__name__, type(cells.cell_pairs).__name__, "
            "i.tolist(), j.tolist())")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["True", "False", "True", "CPUDispatcher", "CPUDispatcher", "[0]", "[1]"]


@pytest.fixture()
def fresh_cache(tmp_path, monkeypatch):
    """A cache with no AOT module; this process forgets the loaded one."""
    monkeypatch.setenv("JAMFLOW_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(aot, "_module", None)
    monkeypatch.setattr(aot, "_warned", False)
    aot.module_path.cache_clear()
    yield tmp_path / "cache"
    aot.module_path.cache_clear()


def test_a_failed_build_warns_once_and_runs_numba(built, fresh_cache, monkeypatch):
    builds = []
    monkeypatch.setattr(aot, "build_command", lambda out: builds.append(out) or [
        sys.executable, "-c", "import sys; sys.exit('ModuleNotFoundError: No module named numba.pycc')"])
    with pytest.warns(RuntimeWarning, match="could not be built .*numba.pycc.*Delete .*failed to retry"):
        res = jam(n=16, seed=1)
    assert len(builds) == 1 and (aot.module_path().parent / "failed").exists() and aot.loaded() is None
    assert aot.module() is None and len(builds) == 1  # the marker: no second build
    monkeypatch.setenv("JAMFLOW_AOT", "0")
    ref = jam(n=16, seed=1)
    assert res.phi_j == ref.phi_j and res.iterations == ref.iterations


def test_a_damaged_module_is_rebuilt(built, fresh_cache, monkeypatch):
    """... and an interrupted build's directory is removed."""
    good = built.__file__
    path = aot.module_path()
    (path.parent / "tmpinterrupted").mkdir(parents=True)
    path.write_bytes(b"\x7fELF garbage")
    assert aot.loaded() is None
    monkeypatch.setattr(aot, "build_command", lambda out: [sys.executable, "-c",
                                                           f"import shutil; shutil.copy({good!r}, {out!r})"])
    assert aot.module() is not None and aot.module().__file__ == str(path)
    assert not (path.parent / "tmpinterrupted").exists()



def test_an_unwritable_cache_warns_and_runs_numba(built, fresh_cache, monkeypatch):
    """The cache path is a file (as root, a read-only directory would still be writable): no traceback."""
    fresh_cache.write_text("not a directory")
    with pytest.warns(RuntimeWarning, match="could not be built in .*JAMFLOW_CACHE_DIR"):
        res = jam(n=16, seed=1)
    monkeypatch.setenv("JAMFLOW_AOT", "0")
    ref = jam(n=16, seed=1)
    assert res.phi_j == ref.phi_j and res.iterations == ref.iterations


def test_no_c_compiler_warns_without_a_build_or_a_marker(built, fresh_cache, monkeypatch):
    monkeypatch.setenv("CC", "/nonexistent/cc")
    monkeypatch.setattr(aot, "build_command", lambda out: pytest.fail("no build without a compiler"))
    with pytest.warns(RuntimeWarning, match="no C compiler found .*apt-get install gcc"):
        res = jam(n=16, seed=1)
    assert not (aot.module_path().parent / "failed").exists()  # retried once a compiler exists
    monkeypatch.setenv("JAMFLOW_AOT", "0")
    assert jam(n=16, seed=1).phi_j == res.phi_j


def test_a_bad_jamflow_aot_value_is_refused_before_work(tmp_path, monkeypatch, capsys):
    from jamflow.cli.app import main

    monkeypatch.setenv("JAMFLOW_AOT", "maybe")
    code = main(["jam", "--n", "16", "--quiet", "--out", str(tmp_path / "p.h5")])
    err = capsys.readouterr().err
    assert code != 0 and "JAMFLOW_AOT='maybe' is neither on nor off" in err and "Traceback" not in err
    assert not (tmp_path / "p.h5").exists()
    monkeypatch.setenv("JAMFLOW_AOT", "Off")
    assert not aot.enabled()
