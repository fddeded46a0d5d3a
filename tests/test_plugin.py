"""jamflow's LAMMPS plugin pair styles (jamflow/spring, jamflow/rlj) and the lepton/sphere
fallback, checked against (1) the closed forms of chapter eqs. 2.1 and 2.2 evaluated in 40-digit
decimal arithmetic for two particles, and (2) the independent all-pairs numpy reference
``jamflow.mechanics.reference`` for random polydisperse packings, in orthogonal and tilted
boxes, 2D and 3D, newton on and off. LAMMPS systems are built by hand here so that the
test does not depend on ``LammpsEngine``.
"""

from __future__ import annotations

import decimal
import os
import shutil
import subprocess
import sys
from decimal import Decimal
from pathlib import Path

import numpy as np
import pytest
from lammps import LMP_STYLE_GLOBAL, LMP_STYLE_LOCAL, LMP_TYPE_ARRAY, LMP_TYPE_VECTOR

from jamflow.model.box import Box
from jamflow.engines.lammps import plugin_build
from jamflow.engines.lammps.library import new_lammps
from jamflow.engines.lammps.plugin_build import find_compiler, load_plugin, pair_style_commands, plugin_library
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.model.packing import Packing, random_packing
from jamflow.model.potentials import RepulsiveLJ, Spring
from jamflow.model.sizes import parse_sizes

needs_compiler = pytest.mark.skipif(find_compiler() is None, reason="no C++ compiler to build the plugin")

POTENTIALS = [Spring(2.0), Spring(2.5), Spring(3.0), Spring(1.5, epsilon=0.7), RepulsiveLJ(epsilon=2.0)]
IDS = ["spring2", "hertz", "spring3", "spring1.5", "rlj"]


# building and measuring a LAMMPS system ---------------------------------------------------
def build_lammps(packing: Packing, *, lepton=False, newton=True, extra=()):
    """LAMMPS instance holding ``packing`` with the plugin (or lepton) pair style, after run 0."""
    lmp = new_lammps()
    if not lepton:
        assert load_plugin(lmp)
    b = {k: float(v) for k, v in packing.box.to_lammps().items()}
    cmds = ["units lj", f"dimension {packing.dim}", "boundary p p p", "atom_style sphere",
            "atom_modify map yes", f"newton {'on' if newton else 'off'}",
            f"region cell prism {b['xlo']!r} {b['xhi']!r} {b['ylo']!r} {b['yhi']!r} {b['zlo']!r} "
            f"{b['zhi']!r} {b['xy']!r} {b['xz']!r} {b['yz']!r} units box",
            "create_box 1 cell"]
    for x in packing.positions:
        xyz = [*map(float, x), 0.0][:3]
        cmds.append(f"create_atoms 1 single {xyz[0]!r} {xyz[1]!r} {xyz[2]!r} units box remap yes")
    for k, a in enumerate(packing.diameters):
        cmds.append(f"set atom {k + 1} diameter {float(a)!r}")
    cmds += ["set group all mass 1.0",
             *pair_style_commands(packing.potential, packing.diameters.max(), plugin=not lepton),
             "compute p all pressure NULL virial", "thermo_style custom step pe c_p[*]",
             "thermo_modify norm no", *extra, "run 0"]  # thermo_style resets thermo_modify
    for c in cmds:
        lmp.command(c)
    assert lmp.get_natoms() == packing.n
    return lmp


def measure(lmp, dim):
    """(total energy, forces in atom-ID order (N, d), virial pressure tensor (d, d))."""
    nlocal = lmp.extract_setting("nlocal")
    order = np.argsort(lmp.numpy.extract_atom("id")[:nlocal])
    forces = np.array(lmp.numpy.extract_atom("f")[:nlocal][order, :dim])
    p = lmp.numpy.extract_compute("p", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR)
    tensor = np.array([[p[0], p[3], p[4]], [p[3], p[1], p[5]], [p[4], p[5], p[2]]])[:dim, :dim]
    return float(lmp.get_thermo("pe")), forces, tensor


def rel(a, b):
    """max |a - b| / max |b|."""
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / np.max(np.abs(b)))


# closed form in 40-digit decimal arithmetic -----------------------------------------------------
def exact_pair(potential, dr, sigma):
    """(V, -dV/dr) of chapter eq. 2.1 / 2.2 for the float64 separation ``dr``, 40 digits."""
    with decimal.localcontext() as ctx:
        ctx.prec = 40
        r = sum(Decimal(float(c)) ** 2 for c in dr).sqrt()
        s, eps = Decimal(float(sigma)), Decimal(float(potential.epsilon))
        if potential.name == "spring":
            a = Decimal(float(potential.alpha))
            x = 1 - r / s
            xa1 = (x.ln() * (a - 1)).exp()
            return float(eps / a * xa1 * x), float(eps / s * xa1), r
        q6 = (s / r) ** 6
        return float(eps * (q6 * q6 - 2 * q6 + 1)), float(12 * eps / r * (q6 * q6 - q6)), r


def two_particles(dim, potential, across_boundary):
    """Diameters 1 and 1.4 (sigma 1.2) at r ~ 0.93 along a generic direction. Coordinates
    lie on a 2^-20 grid, so periodic images and differences are exact in float64 and the
    closed form is evaluated for exactly the separation LAMMPS sees."""
    side = 6.0
    direction = np.array([0.6, -0.48, 0.64])[:dim]
    direction /= np.linalg.norm(direction)
    first = np.full(dim, 0.3 if across_boundary else 2.5)
    second = (first - 0.93 * direction) % side
    first, second = (np.round(x * 2.0**20) / 2.0**20 for x in (first, second))
    return Packing(np.array([first, second]), np.array([1.0, 1.4]), Box.cube(side, dim), potential)


@needs_compiler
@pytest.mark.parametrize("across_boundary", [False, True], ids=["inside", "periodic"])
@pytest.mark.parametrize("newton", [True, False], ids=["newton-on", "newton-off"])
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("potential", POTENTIALS, ids=IDS)
def test_two_particles_match_closed_form(potential, dim, newton, across_boundary):
    packing = two_particles(dim, potential, across_boundary)
    lmp = build_lammps(packing, newton=newton, extra=["compute pl all pair/local dist eng force"])
    try:
        energy, forces, tensor = measure(lmp, dim)
        local = np.array(lmp.numpy.extract_compute("pl", LMP_STYLE_LOCAL, LMP_TYPE_ARRAY)).reshape(-1, 3)
    finally:
        lmp.close()
    dr = packing.box.minimum_image(packing.positions[0] - packing.positions[1])
    v, minus_dv, r = exact_pair(potential, dr, 1.2)
    f0 = minus_dv * dr / float(r)  # force on particle 0
    assert energy == pytest.approx(v, rel=1e-14, abs=0)
    assert rel(forces, np.array([f0, -f0])) < 1e-14
    assert rel(tensor, np.outer(dr, f0) / packing.box.volume) < 1e-14
    # single(), via compute pair/local: one pair, its distance, energy and force magnitude
    assert local.shape == (1, 3)
    assert local[0, 1] == pytest.approx(v, rel=1e-14, abs=0)
    assert abs(local[0, 2]) == pytest.approx(minus_dv, rel=1e-14, abs=0)


# random polydisperse packings against the numpy reference -----------------------------------------
def random_config(dim, potential, tilted, seed=3):
    """~100 polydisperse particles (diameters 1..1.4) at phi 0.95 (2D) / 0.75 (3D)."""
    n = 100 if dim == 2 else 90
    base = random_packing(n, dim, parse_sizes("poly-uniform:0.4"), 0.95 if dim == 2 else 0.75, seed, potential)
    if not tilted:
        return base
    h = base.box.h.copy()
    h[0, 1] = 0.31 * h[1, 1]
    if dim == 3:
        h[0, 2], h[1, 2] = -0.17 * h[2, 2], 0.23 * h[2, 2]
    box = Box(h)
    return Packing(box.wrap(box.to_cartesian(base.box.to_fractional(base.positions))), base.diameters, box, potential)


def compare_with_reference(packing, **build):
    ref = energy_forces_pressure(packing)
    lmp = build_lammps(packing, **build)
    try:
        energy, forces, tensor = measure(lmp, packing.dim)
    finally:
        lmp.close()
    assert ref.energy > 0 and np.count_nonzero(ref.forces) > packing.n  # many contacts
    return abs(energy - ref.energy) / ref.energy, rel(forces, ref.forces), rel(tensor, ref.pressure_tensor)


@needs_compiler
@pytest.mark.parametrize("tilted", [False, True], ids=["orthogonal", "tilted"])
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("potential", POTENTIALS, ids=IDS)
def test_random_packings_match_reference(potential, dim, tilted):
    packing = random_config(dim, potential, tilted)
    for newton in (True, False):
        errors = compare_with_reference(packing, newton=newton)
        assert max(errors) < 1e-12, errors


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("potential", POTENTIALS, ids=IDS)
def test_lepton_fallback_matches_reference(potential, dim):
    packing = random_config(dim, potential, tilted=True)
    errors = compare_with_reference(packing, lepton=True)
    assert max(errors) < 1e-12, errors


@pytest.mark.parametrize("lepton", [pytest.param(False, marks=needs_compiler), True], ids=["plugin", "lepton"])
@pytest.mark.parametrize("potential", [Spring(2.5), Spring(1.5), Spring(3.0)], ids=["hertz", "spring1.5", "spring3"])
def test_fire_from_random_start_stays_finite(potential, lepton):
    """FIRE from uniformly random positions (pairs well beyond contact inside the cutoff,
    where a step() form of the expression gives NaN) lowers the energy and stays finite.
    (Not RLJ: from such a start its forces reach 1e13 and LAMMPS's FIRE loses atoms in
    the first step with either pair style; the protocol must start RLJ less dense.)"""
    packing = random_config(2, potential, tilted=False, seed=11)
    start = energy_forces_pressure(packing).energy
    lmp = build_lammps(packing, lepton=lepton, extra=["min_style fire"])
    try:
        lmp.command("minimize 0.0 1e-10 300 3000")
        energy, forces, _ = measure(lmp, 2)
    finally:
        lmp.close()
    assert np.isfinite(energy) and np.all(np.isfinite(forces))
    assert energy < 0.5 * start


# guards --------------------------------------------------------------------------------------------
BOX_2D = ["units lj", "dimension 2", "region b block 0 9 0 9 -0.5 0.5", "create_box 1 b",
          "create_atoms 1 single 1 1 0"]


@needs_compiler
@pytest.mark.parametrize("commands, message", [
    (["atom_style sphere", *BOX_2D, "set atom 1 diameter 1.4", "pair_style jamflow/spring 2.5 1.2",
      "pair_coeff * * 1", "run 0"], "CUTOFF 1.2.* below the largest diameter 1.4"),
    (["atom_style atomic", *BOX_2D, "mass 1 1.0", "pair_style jamflow/rlj 1.4", "pair_coeff * * 1", "run 0"],
     "requires atom_style sphere"),
    (["atom_style sphere", *BOX_2D, "pair_style jamflow/spring 1.0 1.4"], "ALPHA must be a finite number > 1"),
    (["atom_style sphere", *BOX_2D, "pair_style jamflow/rlj -1"], "CUTOFF must be a positive number"),
    (["atom_style sphere", *BOX_2D, "pair_style jamflow/rlj"], "expected CUTOFF"),
    (["atom_style sphere", *BOX_2D, "pair_style jamflow/rlj 1.4", "pair_coeff * * 0"], "EPSILON must be a positive"),
], ids=["cutoff-too-small", "no-radius", "alpha", "negative-cutoff", "missing-cutoff", "epsilon"])
def test_lammps_rejects_bad_setup(commands, message):
    assert_lammps_rejects(commands, message)


def assert_lammps_rejects(commands, message):
    """With the plugin loaded, one of ``commands`` fails with an error matching ``message``."""
    lmp = new_lammps()
    try:
        assert load_plugin(lmp)
        with pytest.raises(Exception, match=message):
            for c in commands:
                lmp.command(c)
    finally:
        lmp.close()


def test_python_helpers_reject_bad_input():
    with pytest.raises(ValueError, match="largest diameter"):
        pair_style_commands(Spring(), 0.0)
    with pytest.raises(ValueError, match="Spring"):
        pair_style_commands(object(), 1.4)
    with pytest.raises(ValueError, match="Spring"):
        pair_style_commands("hertz", 1.4, plugin=False)


# build and cache -------------------------------------------------------------------------------------
@needs_compiler
def test_cache_is_reused(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("JAMFLOW_CACHE_DIR", str(tmp_path))
    first = plugin_library()
    said = capsys.readouterr().err  # the build says so before it starts, the reuse says nothing
    assert said.startswith("jamflow: compiling the LAMMPS plugin pair styles once (~5 s) into ") and said.count("\n") == 1
    assert first.is_file() and first.is_relative_to(tmp_path / "plugins")
    assert first.parent.name == plugin_build.source_digest()
    stamp = first.stat().st_mtime_ns

    def must_not_compile(*args, **kwargs):
        raise AssertionError("recompiled although the cached library exists")

    monkeypatch.setattr(plugin_build, "compile_plugin", must_not_compile)
    assert plugin_library() == first
    assert first.stat().st_mtime_ns == stamp
    assert [p.name for p in first.parent.iterdir()] == ["jamflow_pairs.so"]  # no temporaries left
    assert capsys.readouterr().err == ""


def test_no_compiler_warns_and_returns_none(tmp_path, monkeypatch):
    monkeypatch.setenv("JAMFLOW_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("PATH", str(tmp_path))
    monkeypatch.delenv("CXX", raising=False)
    with pytest.warns(RuntimeWarning, match=r"no C\+\+ compiler.*lepton/sphere.*apt-get install g\+\+"):
        assert plugin_library() is None

def test_a_cxx_that_names_no_executable_is_an_error(tmp_path, monkeypatch):
    """Was: 'no C++ compiler found' although g++ is installed, then lepton/sphere, 12x slower."""
    monkeypatch.setenv("JAMFLOW_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("CXX", "/nonexistent/g++")
    hint = "unset CXX to use" if shutil.which("g++") or shutil.which("c++") else "install one"
    with pytest.raises(plugin_build.PluginBuildError, match=f"CXX=/nonexistent/g\\+\\+ does not name an executable.*{hint}"):
        plugin_library()


@needs_compiler
def test_a_damaged_cached_plugin_is_rebuilt(tmp_path, monkeypatch):
    """Was: LAMMPS 'Unrecognized pair style' without naming the cache file."""
    monkeypatch.setenv("JAMFLOW_CACHE_DIR", str(tmp_path))
    library = plugin_library()
    good = library.read_bytes()
    for damage in (b"garbage\n", good[:5000], b""):
        library.write_bytes(damage)
        with pytest.warns(RuntimeWarning, match=f"cached LAMMPS plugin {library} is damaged.*rebuilding"):
            assert plugin_library() == library
        assert library.read_bytes()[:4] == b"\x7fELF" and library.stat().st_size == len(good)


@needs_compiler
def test_compile_error_raises_with_compiler_message(tmp_path):
    broken = tmp_path / "broken.cpp"
    broken.write_text("int main( { return 0; }\n")
    target = tmp_path / "out" / "jamflow_pairs.so"
    with pytest.raises(RuntimeError, match="compiling the jamflow LAMMPS plugin failed(.|\n)*error"):
        plugin_build.compile_plugin(find_compiler(), target, source=broken)
    assert list(target.parent.iterdir()) == []


@needs_compiler
def test_concurrent_builds_leave_one_complete_library(tmp_path):
    """Two processes building into an empty cache at once: both get the same, complete file."""
    env = {**os.environ, "JAMFLOW_CACHE_DIR": str(tmp_path)}
    code = "from jamflow.engines.lammps.plugin_build import plugin_library; print(plugin_library())"
    procs = [subprocess.Popen([sys.executable, "-c", code], env=env, stdout=subprocess.PIPE, text=True)
             for _ in range(2)]
    paths = {p.communicate(timeout=300)[0].strip() for p in procs}
    assert all(p.returncode == 0 for p in procs)
    assert len(paths) == 1
    library = Path(paths.pop())
    assert library.read_bytes()[:4] == b"\x7fELF"
    assert [p.name for p in library.parent.iterdir()] == ["jamflow_pairs.so"]


@needs_compiler
def test_load_plugin_issues_plugin_load_at_most_once():
    lmp = new_lammps()
    sent = []

    class Recorder:
        def __getattr__(self, name):
            return getattr(lmp, name)

        def command(self, text):
            sent.append(text)
            lmp.command(text)

    try:
        assert load_plugin(Recorder()) and load_plugin(Recorder())
        assert sum(c.startswith("plugin load") for c in sent) <= 1
        assert lmp.has_style("pair", "jamflow/spring") and lmp.has_style("pair", "jamflow/rlj")
    finally:
        lmp.close()
