"""Walls and gravity (chapter section 2.3; docs/notes/walls-gravity-pressure.md): the walled box, closed forms (one disk pressed
on a wall, a column of disks under gravity), the three implementations (numpy reference, compiled,
LAMMPS) against each other and against finite differences, jammed packings with smooth and
rough walls, the contact count, files, and bad input."""

from dataclasses import replace

import h5py
import numpy as np
import pytest

from jamflow import jam
from jamflow.mechanics.contacts import Contacts
from jamflow.analysis.profile import PressureProfile
from jamflow.model.box import Box
from jamflow.cli.app import main
from jamflow.engines.compiled.engine import CompiledEngine
from jamflow.engines.lammps.engine import LammpsEngine
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.io.packing_file import load_packing, read_attrs, save_packing
from jamflow.minimize.settings import MinimizerSettings
from jamflow.minimize.rules import minimize
from jamflow.model.packing import Packing, random_packing
from jamflow.model.potentials import RepulsiveLJ, Spring
from jamflow.model.shapes import Ellipsoid
from jamflow.model.sizes import parse_sizes
from jamflow.model.walls import face_pressures, parse_walls, wall_loads, with_walls

ENGINES = {"numba": CompiledEngine, "lammps": LammpsEngine}
TIGHT = MinimizerSettings(force_tol=1e-15)


def floor_box(width=3.0, height=8.0, dim=2):
    return Box(np.diag([width] * (dim - 1) + [height]), periodic=(True,) * (dim - 1) + (False,))


# --- the walled box -----------------------------------------------------------------------------
def test_walled_axis_has_no_images_and_is_not_wrapped():
    box = floor_box(4.0, 5.0)
    dr = box.minimum_image(np.array([[3.5, 4.5]]))
    assert np.allclose(dr, [[-0.5, 4.5]])  # x wraps, y is direct
    assert np.allclose(box.wrap(np.array([[4.5, -0.25]])), [[0.5, -0.25]])
    assert box.walls == (1,) and box.wall_spec == "y"
    assert box.scaled(0.5).periodic == (True, False)


@pytest.mark.parametrize("walls", [(True, False), (False, True)], ids=["walls-y", "walls-x"])
def test_walls_on_a_sheared_axis_are_refused(walls):
    with pytest.raises(ValueError, match="sheared box"):
        Box([[4.0, 0.5], [0.0, 4.0]], periodic=walls)


def test_parse_walls():
    assert parse_walls("y", 2) == (1,) and parse_walls("x,y", 2) == (0, 1) and parse_walls("z,x", 3) == (0, 2)
    assert parse_walls(None, 2) == () and parse_walls("none", 3) == ()
    for bad in ("z", "y,y", "x;y"):
        with pytest.raises(ValueError, match="--walls"):
            parse_walls(bad, 2)


# --- closed form: one disk pressed on a wall --------------------------------------------------------
@pytest.mark.parametrize("potential", [Spring(2.0), Spring(2.5), RepulsiveLJ()], ids=["spring", "hertz", "rlj"])
def test_disk_at_a_wall_feels_the_particle_law_at_half_its_diameter(potential):
    """V = V(s), s = h / (a/2): energy and force of a disk of diameter 1.4 at h = 0.6 (floor) and
    0.65 from the ceiling, against the law itself."""
    a, box = 1.4, floor_box(4.0, 6.0)
    p = Packing([[1.0, 0.6], [3.0, 6.0 - 0.65]], [a, a], box, potential)
    law = potential.energy_force
    (v1, d1), (v2, d2) = law(0.6 / 0.7, potential.params), law(0.65 / 0.7, potential.params)
    ref = energy_forces_pressure(p)
    assert ref.energy == pytest.approx(v1 + v2, rel=1e-14)
    assert ref.forces == pytest.approx(np.array([[0.0, -d1 / 0.7], [0.0, d2 / 0.7]]), rel=1e-14)
    assert ref.pressure_tensor[1, 1] == pytest.approx((0.6 * -d1 / 0.7 + 0.65 * -d2 / 0.7) / box.volume, rel=1e-14)
    assert ref.wall_forces[1, 0, 1] == pytest.approx(d1 / 0.7) and ref.wall_forces[1, 1, 1] == pytest.approx(-d2 / 0.7)
    with CompiledEngine(p) as eng:
        got = eng.evaluate()
    assert got.energy == pytest.approx(ref.energy, rel=1e-14) and np.allclose(got.forces, ref.forces, rtol=1e-14)


@pytest.mark.parametrize("engine", list(ENGINES))
def test_one_disk_pressed_on_the_floor_by_gravity(engine):
    """Linear spring, a = 1, weight g: force balance at h = a/2 (1 - g a / (2 eps)); the floor
    carries g, its pressure is g / L_x."""
    g, box = 1e-3, floor_box(3.0, 5.0)
    p = Packing([[1.0, 0.7]], [1.0], box, Spring(), gravity=g)
    with ENGINES[engine](p) as eng:
        res = minimize(eng, TIGHT if engine == "numba" else MinimizerSettings(force_tol=1e-14))
        q = eng.packing()
    assert res.converged
    assert q.positions[0, 1] == pytest.approx(0.5 * (1 - g * 0.5), abs=1e-14)
    loads = wall_loads(q)
    assert loads[1, 0, 1] == pytest.approx(-g, rel=1e-10)
    assert face_pressures(q.box, loads)[0, 0] == pytest.approx(g / 3.0, rel=1e-10)


# --- closed form: a column of disks under gravity ---------------------------------------------------
def column(k=6, g=1e-3, diameters=None):
    d = np.asarray(diameters if diameters is not None else np.ones(k), float)
    y = np.cumsum(d) - 0.5 * d + 0.05 * np.arange(k)  # a little apart: they settle
    return Packing(np.column_stack([np.full(k, 1.5), y]), d, floor_box(3.0, float(y[-1] + 3)), Spring(), gravity=g)


def column_heights(d, g):
    """Each contact carries the weight above it: spring overlap 1 - r/sigma = load sigma / eps."""
    k = len(d)
    heights = [0.5 * d[0] * (1 - k * g * 0.5 * d[0])]
    for m in range(1, k):
        sigma = 0.5 * (d[m - 1] + d[m])
        heights.append(heights[-1] + sigma * (1 - (k - m) * g * sigma))
    return np.array(heights)


@pytest.mark.parametrize("engine", list(ENGINES))
def test_column_of_disks_under_gravity(engine):
    d, g = np.array([1.0, 1.4, 1.0, 1.4, 1.4, 1.0]), 1e-3
    with ENGINES[engine](column(diameters=d, g=g)) as eng:
        res = minimize(eng, TIGHT if engine == "numba" else MinimizerSettings(force_tol=1e-14))
        q = eng.packing()
    assert res.converged
    # heights to 1e-12: a force residual below 1e-14 on each of six contacts of stiffness ~0.5-1
    assert np.allclose(q.positions[:, 1], column_heights(d, g), rtol=0, atol=1e-12)
    assert np.all(q.positions[:, 0] == 1.5)  # vertical forces only: x never moves
    loads = wall_loads(q)
    assert loads[1, 0, 1] == pytest.approx(-len(d) * g, rel=1e-12)  # the floor carries the total weight
    assert loads[1, 1, 1] == 0.0  # the ceiling carries nothing
    prof = PressureProfile(bins=12).compute(q)
    assert np.allclose(prof.sigma_zz, prof.weight_above, rtol=1e-10, atol=1e-16)
    assert prof.sigma_zz[0] == pytest.approx(len(d) * g / 3.0, rel=1e-12)


# --- second implementations ------------------------------------------------------------------------
def scene(dim, axes, kind, g, n=None, seed=3):
    n = n or (40 if dim == 2 else 100)
    p = random_packing(n, dim, parse_sizes("bi:1.4:0.5"), 0.8 if dim == 2 else 0.55, seed)
    return replace(with_walls(p, axes, kind), gravity=g)


SCENES = {"smooth-floor": (lambda d: (d - 1,), "smooth", 0.0), "rough-box": (lambda d: (0, d - 1), "rough", 0.0),
          "gravity": (lambda d: (d - 1,), "smooth", 1e-3), "rough-gravity": (lambda d: (d - 1,), "rough", 1e-2),
          "closed": (lambda d: tuple(range(d)), "smooth", 0.0)}


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("name", list(SCENES))
@pytest.mark.parametrize("engine", list(ENGINES))
def test_engines_match_the_reference_with_walls(engine, name, dim):
    axes, kind, g = SCENES[name]
    p = scene(dim, axes(dim), kind, g)
    ref = energy_forces_pressure(p)
    with ENGINES[engine](p) as eng:
        got = eng.evaluate()
    assert got.energy == pytest.approx(ref.energy, rel=1e-13)
    assert np.max(np.abs(got.forces - ref.forces)) < 1e-13 * np.max(np.abs(ref.forces))
    assert np.max(np.abs(got.pressure_tensor - ref.pressure_tensor)) < 1e-13 * np.max(np.abs(ref.pressure_tensor))
    if p.fixed is not None:
        assert np.all(got.forces[p.fixed] == 0.0)


@pytest.mark.parametrize("engine", list(ENGINES))
def test_walls_follow_the_box(engine):
    """After a box change the walls are at the new faces (a LAMMPS EDGE wall would stay behind)."""
    p = scene(2, (0, 1), "rough", 0.0)
    box = p.box.scaled(0.97)
    with ENGINES[engine](p) as eng:
        eng.set_box(box)
        got = eng.evaluate()
    ref = energy_forces_pressure(p.with_positions(p.positions * 0.97, box=box))
    assert got.energy == pytest.approx(ref.energy, rel=1e-13)
    assert np.max(np.abs(got.forces - ref.forces)) < 1e-13 * np.max(np.abs(ref.forces))


def test_random_starts_keep_clear_of_the_walls():
    p = scene(3, (0, 1, 2), "smooth", 0.0)
    gap = np.minimum(p.positions, p.box.lengths - p.positions) - 0.5 * p.diameters[:, None]
    assert gap.min() >= -1e-12


@pytest.mark.parametrize("name", ["rough-gravity", "closed"])
def test_reference_forces_and_wall_virial_are_energy_derivatives(name):
    """Forces = -grad U and the virial W_aa = -dU/de_aa (affine strain of box, walls and all
    particles), by central finite differences. Gravity is a body force and enters no virial:
    its share of -dU/de_yy, -g sum y, is added to the expectation."""
    axes, kind, g = SCENES[name]
    p = scene(2, axes(2), kind, g, n=24)
    ref = energy_forces_pressure(p)
    step, mobile = 1e-6, np.flatnonzero(p.mobile)
    for i in mobile[:6]:
        for a in range(2):
            x = np.array(p.positions)
            x[i, a] += step
            up = energy_forces_pressure(p.with_positions(x)).energy
            x[i, a] -= 2 * step
            down = energy_forces_pressure(p.with_positions(x)).energy
            assert -(up - down) / (2 * step) == pytest.approx(ref.forces[i, a], rel=1e-6, abs=1e-9)
    for a in range(2):
        def strained(e):
            m = np.eye(2)
            m[a, a] += e
            return energy_forces_pressure(p.with_positions(p.positions @ m.T, box=p.box.with_h(m @ p.box.h))).energy
        w = -(strained(step) - strained(-step)) / (2 * step)
        weight = -p.gravity * p.positions[p.mobile, 1].sum() if a == 1 else 0.0
        assert w == pytest.approx(ref.pressure_tensor[a, a] * p.box.volume + weight, rel=1e-6)


# --- jammed packings with walls -------------------------------------------------------------------
@pytest.fixture(scope="module")
def jammed_walls():
    return {kind: jam(n=64, seed=2, walls="y", wall_type=kind) for kind in ("smooth", "rough")}


@pytest.mark.parametrize("kind", ["smooth", "rough"])
def test_jammed_with_walls(jammed_walls, kind):
    res = jammed_walls[kind]
    p = res.packing
    assert 1e-16 < res.energy_per_particle < 2e-16 and p.box.walls == (1,)
    ref = energy_forces_pressure(p)
    c = Contacts().compute(p)
    assert np.max(np.abs(ref.forces[c.kept])) < 1e-13  # force balance including the wall forces
    walls = res.wall_pressures[0]
    assert walls == pytest.approx(face_pressures(p.box, ref.wall_forces)[0], rel=1e-12)
    assert walls == pytest.approx([ref.pressure_tensor[1, 1]] * 2, rel=1e-5)  # virial = wall pressure at balance
    assert p.phi == pytest.approx(res.phi_j, rel=1e-12) and 0.7 < res.phi_j < 0.87
    if kind == "rough":
        fixed = p.fixed
        assert fixed.sum() > 0 and p.n_mobile == 64
        start = with_walls(random_packing(64, 2, parse_sizes("bi:1.4:0.5"), 0.8, 2), (1,), "rough")
        scale = p.box.lengths / start.box.lengths  # fixed particles moved only with the box
        assert np.allclose(p.positions[fixed], start.positions[fixed] * scale, rtol=0, atol=1e-12)
        d = p.box.minimum_image(p.positions[fixed][:, None] - p.positions[fixed][None])
        dist = np.linalg.norm(d, axis=-1) + np.eye(fixed.sum()) * 10
        assert dist.min() >= 1.0  # wall particles never overlap each other: phi counts half of each exactly
        assert c.n_wall_contacts == 0 and c.trivial == 0  # the smooth backing is out of reach behind the rows
    else:
        assert c.n_wall_contacts > 0 and c.trivial == 1


def test_jammed_walled_packings_are_isostatic(jammed_walls):
    """N_c,iso = N' d - d_trivial + 1, wall contacts counted: smooth walls on y leave the x
    translation (d_trivial = 1), rough walls pin both (0). Both packings come out exactly
    isostatic (seed 2, N = 64; docs/notes/walls-gravity-pressure.md has 20 seeds)."""
    smooth, rough = (Contacts().compute(jammed_walls[k].packing) for k in ("smooth", "rough"))
    assert smooth.isostatic_count == 2 * smooth.n_kept - 1 + 1 and rough.isostatic_count == 2 * rough.n_kept + 1
    assert smooth.n_contacts == smooth.isostatic_count and rough.n_contacts == rough.isostatic_count
    assert smooth.mean_z == pytest.approx(smooth.z[smooth.kept].sum() / smooth.n_kept)


def test_weight_counts_as_a_contact_in_the_floater_test():
    """A disk resting in the groove of two floor disks under gravity is stable (2 contacts + its
    weight); without gravity it is a floater (fewer than 3 contacts)."""
    box = floor_box(6.0, 6.0)
    groove = [[1.0, 0.5], [2.0, 0.5], [1.5, 0.5 + np.sqrt(3) / 2 - 1e-6]]
    for g, floaters in ((1e-3, 0), (0.0, 1)):
        p = Packing(groove, [1.0, 1.0, 1.0], box, Spring(), gravity=g, fixed=np.array([True, True, False]))
        c = Contacts().compute(p)
        assert c.n_floaters == floaters and c.n_kept == 1 - floaters


def test_gravity_settles_to_force_balance_with_the_weight_on_the_floor():
    g = 1e-4
    res = jam(n=48, seed=1, walls="y", gravity=g)
    p = res.packing
    ref = energy_forces_pressure(p)
    assert np.max(np.abs(ref.forces)) < 1e-13  # every particle, weight included
    assert ref.wall_forces[1, 0, 1] == pytest.approx(-48 * g, rel=1e-9) and ref.wall_forces[1, 1, 1] == 0.0
    prof = PressureProfile(bins=20).compute(p)
    assert np.allclose(prof.sigma_zz, prof.weight_above, rtol=1e-8, atol=1e-15)
    assert np.all(np.diff(prof.sigma_zz) <= 1e-15)  # pressure grows with depth
    c = Contacts().compute(p)  # under gravity the weight is a load: no +1
    assert c.loaded and c.isostatic_count == 2 * c.n_kept - 1


# --- files and bad input ---------------------------------------------------------------------------
def test_walled_packing_file_round_trip(tmp_path, jammed_walls):
    res = jammed_walls["rough"]
    path = save_packing(tmp_path / "w.h5", res.packing, pressure_tensor=res.pressure_tensor,
                        wall_forces=res.wall_forces)
    q = load_packing(path)
    assert q.box.periodic == (True, False) and np.array_equal(q.fixed, res.packing.fixed)
    assert q.phi == pytest.approx(res.packing.phi, rel=1e-15)
    attrs = read_attrs(path)
    assert attrs["walls"] == "y" and attrs["wall_type"] == "rough" and attrs["gravity"] == 0.0
    with h5py.File(path) as f:
        assert f["wall_forces"].shape == (1, 2, 2) and np.allclose(f["wall_pressure"][...], res.wall_pressures)


def test_bad_boundaries_are_refused_before_work():
    p = random_packing(20, 2, parse_sizes("mono"), 0.5, 0)
    with pytest.raises(ValueError, match="gravity without a floor"):
        replace(p, gravity=1e-3)
    for g in (-1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="gravity must be a finite number >= 0"):
            replace(with_walls(p, (1,)), gravity=g)
    e = random_packing(20, 2, parse_sizes("mono"), 0.5, 0, shape=Ellipsoid(1.5))
    with pytest.raises(ValueError, match="cannot run walls with ellipse"):
        CompiledEngine(with_walls(e, (1,)))
    with pytest.raises(ValueError, match="fix wall/harmonic"):
        LammpsEngine(with_walls(replace(p, potential=Spring(2.5)), (1,)))
    with pytest.raises(ValueError, match="rough walls"):
        with_walls(e, (1,), "rough")
    from jamflow.mechanics.hessian import hessian

    with pytest.raises(ValueError, match="no wall, gravity or fixed-particle terms"):
        hessian(with_walls(p, (1,)))


@pytest.mark.parametrize("argv, message", [
    (["--gravity", "1e-3"], "gravity without a floor"),
    (["--gravity", "-1", "--walls", "y"], "--gravity must be a finite number"),
    (["--walls", "y", "--pressure", "1e-4"], "does not combine"),
    (["--walls", "x,y,z"], "--walls"),
])
def test_cli_refuses_bad_boundaries(tmp_path, capsys, argv, message):
    assert main(["jam", "--n", "16", "--out", str(tmp_path / "x.h5"), *argv]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "x.h5").exists()


def test_cli_jams_with_walls_and_under_gravity(tmp_path, capsys):
    out = tmp_path / "w.h5"
    assert main(["jam", "--n", "32", "--walls", "x,y", "--quiet", "--out", str(out)]) == 0
    assert "P_wall x" in capsys.readouterr().out and read_attrs(out)["walls"] == "x,y"
    assert main(["jam", "--n", "32", "--walls", "y", "--gravity", "1e-4", "--quiet", "--out", str(out)]) == 0
    assert read_attrs(out)["gravity"] == 1e-4 and load_packing(out).gravity == 1e-4


def test_walls_in_a_tilted_cell_pair_search_and_engines():
    """Walls on z with an xy shear (x, y periodic): pairs match the brute-force minimum image
    (no image across the walls) and both engines match the reference."""
    from jamflow.model.pairs import candidate_pairs

    p = random_packing(120, 3, parse_sizes("bi:1.4:0.5"), 0.55, 4)
    h = p.box.h.copy()
    h[0, 1] = 0.8 * h[1, 1]  # beyond lx/2: the reduced cell folds it
    box = Box(h, periodic=(True, True, False))
    q = with_walls(p.with_positions(box.to_cartesian(p.box.to_fractional(p.positions)), box=box), (2,))
    i, j = candidate_pairs(q, 1.4)
    found = set(zip(i.tolist(), j.tolist()))
    a, b = np.triu_indices(q.n, 1)
    images = np.array([[u, v, 0] for u in (-2, -1, 0, 1, 2) for v in (-1, 0, 1)], float) @ q.box.h.T
    dr = (q.positions[a] - q.positions[b])[:, None, :] + images[None]
    close = np.linalg.norm(dr, axis=2).min(axis=1) < 1.4
    brute = set(zip(a[close].tolist(), b[close].tolist()))
    assert brute <= found
    ref = energy_forces_pressure(q)
    for engine in ENGINES.values():
        with engine(q) as eng:
            got = eng.evaluate()
        assert got.energy == pytest.approx(ref.energy, rel=1e-13)
        assert np.max(np.abs(got.forces - ref.forces)) < 1e-13 * np.max(np.abs(ref.forces))
