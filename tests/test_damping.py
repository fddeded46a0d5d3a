"""Pairwise damping of damped MD (chapter eq. 2.3), ``fix jamflow/damping`` in jamflow's plugin.

Checked against (1) the closed form for two particles: a head-on relative velocity gives
-b v_rel along rhat, a tangential one nothing, a pair beyond contact nothing, and the
relative normal velocity of an isolated contact decays by (1 - 2 b dt / m) per step;
(2) the numpy reference ``jamflow.mechanics.reference.pair_damping_forces`` for random
polydisperse configurations with random velocities (orthogonal and tilted, 2D and 3D,
newton on and off, 2 MPI ranks); (3) momentum conservation and undamped free flight.
LAMMPS systems are built by hand with ``pair_style zero``, so the forces are the damping alone.
"""

from __future__ import annotations

import decimal
import subprocess
import sys
from decimal import Decimal
from pathlib import Path

import numpy as np
import pytest

from jamflow.model.box import Box
from jamflow.engines.lammps.library import lammps_env, lmp_executable, new_lammps
from jamflow.engines.lammps.plugin_build import find_compiler, load_plugin, plugin_library
from jamflow.mechanics.reference import pair_damping_forces
from jamflow.minimize.settings import PAIRWISE_BDT_LIMIT, MinimizerSettings
from jamflow.model.packing import Packing

from test_plugin import assert_lammps_rejects, random_config, rel

pytestmark = pytest.mark.skipif(find_compiler() is None, reason="no C++ compiler to build the plugin")
B = 0.7


def commands(packing: Packing, velocities, *, damping=B, newton=True, pair="zero", extra=()):
    """LAMMPS input lines: the packing with ``velocities``, pair_style zero and the fix."""
    b = {k: float(v) for k, v in packing.box.to_lammps().items()}
    lines = ["units lj", f"dimension {packing.dim}", "boundary p p p", "atom_style sphere",
             "atom_modify map yes", f"newton {'on' if newton else 'off'}", "comm_modify vel yes",
             f"region cell prism {b['xlo']!r} {b['xhi']!r} {b['ylo']!r} {b['yhi']!r} {b['zlo']!r} "
             f"{b['zhi']!r} {b['xy']!r} {b['xz']!r} {b['yz']!r} units box", "create_box 1 cell"]
    for x in packing.positions:
        xyz = [*map(float, x), 0.0][:3]
        lines.append(f"create_atoms 1 single {xyz[0]!r} {xyz[1]!r} {xyz[2]!r} units box remap yes")
    for k, (a, v) in enumerate(zip(packing.diameters, velocities)):
        vxyz = [*map(float, v), 0.0][:3]
        lines.append(f"set atom {k + 1} diameter {float(a)!r} vx {vxyz[0]!r} vy {vxyz[1]!r} vz {vxyz[2]!r}")
    lines += ["set group all mass 1.0", f"pair_style {pair} {float(packing.diameters.max())!r}",
              "pair_coeff * *", f"fix damp all jamflow/damping {damping!r}", *extra]
    return lines


def run_lammps(lines, dim, steps=0):
    """Forces and velocities (atom-ID order) after ``run steps``."""
    lmp = new_lammps()
    try:
        assert load_plugin(lmp)
        for line in lines:
            lmp.command(line)
        lmp.command(f"run {steps}")
        nlocal = lmp.extract_setting("nlocal")
        order = np.argsort(lmp.numpy.extract_atom("id")[:nlocal])
        f = np.array(lmp.numpy.extract_atom("f")[:nlocal][order, :dim])
        v = np.array(lmp.numpy.extract_atom("v")[:nlocal][order, :dim])
    finally:
        lmp.close()
    return f, v


def pair_at(distance, dim, direction=(0.6, -0.48, 0.64), across_boundary=False):
    """Diameters 1 and 1.4 (sigma 1.2) at ``distance`` along ``direction``, on a 2^-20 grid."""
    side = 6.0
    direction = np.array(direction[:dim], float)
    direction /= np.linalg.norm(direction)
    first = np.full(dim, 0.3 if across_boundary else 2.5)
    second = (first - distance * direction) % side
    first, second = (np.round(x * 2.0**20) / 2.0**20 for x in (first, second))
    return Packing(np.array([first, second]), np.array([1.0, 1.4]), Box.cube(side, dim))


def exact_damping(packing, velocities, damping=B):
    """-b (v_ij . rhat) rhat on particle 0 of a pair, in 40-digit decimal arithmetic."""
    dr = packing.box.minimum_image(packing.positions[0] - packing.positions[1])
    with decimal.localcontext() as ctx:
        ctx.prec = 40
        d = [Decimal(float(c)) for c in dr]
        v = [Decimal(float(a)) - Decimal(float(b)) for a, b in zip(*velocities)]
        rsq = sum(c * c for c in d)
        scale = -Decimal(damping) * sum(a * c for a, c in zip(v, d)) / rsq
        return np.array([float(scale * c) for c in d])


# two particles: closed form ---------------------------------------------------------------------
@pytest.mark.parametrize("across_boundary", [False, True], ids=["inside", "periodic"])
@pytest.mark.parametrize("newton", [True, False], ids=["newton-on", "newton-off"])
@pytest.mark.parametrize("dim", [2, 3])
def test_head_on_pair_gets_minus_b_times_relative_velocity(dim, newton, across_boundary):
    p = pair_at(0.93, dim, across_boundary=across_boundary)
    rhat = p.box.minimum_image(p.positions[0] - p.positions[1])
    rhat /= np.linalg.norm(rhat)
    vel = np.array([-0.3 * rhat, 0.2 * rhat])  # approaching head on: v_rel = -0.5 rhat
    f, _ = run_lammps(commands(p, vel, newton=newton), dim)
    assert rel(f[0], B * 0.5 * rhat) < 1e-14  # -b v_rel
    assert rel(f[0], exact_damping(p, vel)) < 1e-14
    assert rel(f[1], -f[0]) < 1e-15  # exact inside the cell; periodic images round by an ulp


@pytest.mark.parametrize("dim", [2, 3])
def test_generic_relative_velocity_keeps_only_its_normal_part(dim):
    p = pair_at(1.1, dim, across_boundary=True)
    vel = np.array([[0.37, -0.91, 0.23][:dim], [-0.12, 0.45, 0.81][:dim]])
    f, _ = run_lammps(commands(p, vel), dim)
    assert rel(f[0], exact_damping(p, vel)) < 1e-14 and rel(f[1], -f[0]) < 1e-15


@pytest.mark.parametrize("dim", [2, 3])
def test_tangential_relative_velocity_is_not_damped(dim):
    p = pair_at(0.93, dim, direction=(1.0, 0.0, 0.0))  # rhat = x exactly
    vel = np.zeros((2, dim))
    vel[0, 1], vel[1, dim - 1] = 0.8, -0.5  # relative velocity perpendicular to x
    f, _ = run_lammps(commands(p, vel), dim)
    assert np.all(f == 0.0)
    # and a generic direction: zero to round-off
    p = pair_at(0.93, dim)
    rhat = p.box.minimum_image(p.positions[0] - p.positions[1])
    rhat /= np.linalg.norm(rhat)
    tangent = np.roll(rhat, 1) - np.dot(np.roll(rhat, 1), rhat) * rhat
    f, _ = run_lammps(commands(p, np.array([tangent, -tangent])), dim)
    assert np.abs(f).max() < 1e-15 * B


@pytest.mark.parametrize("dim", [2, 3])
def test_only_pairs_in_contact_are_damped(dim):
    """Just beyond sigma = 1.2: nothing; just inside: the closed form (LAMMPS's own test
    rsq < (r_i + r_j)^2 on the float64 separation decides)."""
    vel = np.array([[0.3, -0.1, 0.2][:dim], [-0.4, 0.2, 0.1][:dim]])
    sigma_sq = (0.5 + 0.7) ** 2
    for distance, touching in ((1.2 * (1 + 1e-9), False), (1.2 * (1 - 1e-9), True)):
        first = np.full(dim, 2.5)
        p = Packing(np.array([first, first - distance * np.eye(dim)[0]]), np.array([1.0, 1.4]), Box.cube(6.0, dim))
        dr = p.box.minimum_image(p.positions[0] - p.positions[1])
        assert (np.dot(dr, dr) < sigma_sq) == touching
        f, _ = run_lammps(commands(p, vel), dim)
        if touching:
            assert rel(f[0], exact_damping(p, vel)) < 1e-14 and f[0, 0] != 0.0
        else:
            assert np.all(f == 0.0)


def test_isolated_contact_decays_at_rate_2b_over_m():
    """One contact, no potential: velocity Verlet with the damping in post_force multiplies
    the relative normal velocity by (1 - b dt)^2 (1 - 2 b dt)^(n - 1) in n steps (m = 1):
    the rate is 2 b / m, so an isolated contact is stable for b dt < 1 (docs/notes/damped-md.md)."""
    p = pair_at(0.93, 2)
    rhat = p.box.minimum_image(p.positions[0] - p.positions[1])
    rhat /= np.linalg.norm(rhat)
    dt, steps = 0.1, 60
    for bdt in (0.2, 0.9, 1.1):
        b = bdt / dt
        vel = np.array([-1e-4 * rhat, 1e-4 * rhat])
        _, v = run_lammps(commands(p, vel, damping=b, extra=["fix nve all nve", f"timestep {dt!r}"]), 2, steps)
        expected = (1 - b * dt) ** 2 * (1 - 2 * b * dt) ** (steps - 1) * (-2e-4)
        vrel = np.dot(v[0] - v[1], rhat)
        assert vrel == pytest.approx(expected, rel=1e-12)
        assert np.allclose(v[0] + v[1], 0.0, atol=1e-19)  # momentum conserved
        assert (abs(vrel) > 2e-4) == (bdt > 1)  # b dt > 1: the contact's velocity grows, the step diverges


# random configurations against the numpy reference ------------------------------------------------------
def random_case(dim, tilted, seed=3):
    p = random_config(dim, None, tilted, seed)
    v = np.random.default_rng(seed).normal(size=(p.n, dim))
    return p, v


@pytest.mark.parametrize("tilted", [False, True], ids=["orthogonal", "tilted"])
@pytest.mark.parametrize("dim", [2, 3])
def test_random_configuration_matches_numpy_reference(dim, tilted):
    p, v = random_case(dim, tilted)
    ref = pair_damping_forces(p, v, B)
    assert np.count_nonzero(np.abs(ref).sum(axis=1)) > 0.9 * p.n  # most particles touch something
    for newton in (True, False):
        f, _ = run_lammps(commands(p, v, newton=newton), dim)
        assert rel(f, ref) < 1e-12
        assert np.abs(f.sum(axis=0)).max() < 1e-13 * np.abs(f).max()  # momentum: round-off


def test_two_mpi_ranks_match_numpy_reference(tmp_path):
    """The same configuration on 2 MPI ranks (lmp under mpirun): ghosts carry velocities."""
    p, v = random_case(3, True)
    deck = tmp_path / "damp.lmp"
    deck.write_text("\n".join([f'plugin load "{plugin_library()}"', *commands(p, v), "run 0",
                               "write_dump all custom forces.txt id fx fy fz modify sort id format float %.17g"]))
    mpirun = Path(sys.prefix) / "bin" / "mpirun"
    out = subprocess.run([str(mpirun), "-np", "2", lmp_executable(), "-in", str(deck), "-log", "none", "-nocite"],
                         cwd=tmp_path, env=lammps_env(), capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-2000:]
    assert "2 by 1 by 1" in out.stdout or "1 by 2 by 1" in out.stdout or "1 by 1 by 2" in out.stdout
    f = np.loadtxt(tmp_path / "forces.txt", skiprows=9)[:, 1:]
    assert rel(f, pair_damping_forces(p, v, B)) < 1e-12


# momentum and free flight over a run ---------------------------------------------------------------------
SPRING = "pair_style jamflow/spring 2.0 {cut!r}\npair_coeff * * 1.0"


def md_run(packing, v, damping_fix, steps=2000, dt=0.02):
    """Spring contacts (jamflow/spring) + fix nve + ``damping_fix`` for ``steps`` steps."""
    lines = commands(packing, v, extra=["fix nve all nve", f"timestep {dt!r}"])
    lines = [ln for ln in lines if not ln.startswith(("pair_", "fix damp"))]
    lines += [*SPRING.format(cut=float(packing.diameters.max())).splitlines(), damping_fix]
    return run_lammps(lines, packing.dim, steps)


def test_momentum_is_conserved():
    """Random overlapping disks with random velocities and net momentum: after 2000 steps
    the pairwise damping has left the total momentum as it was (to round-off) while
    dissipating; fix viscous damps it as (1 - b dt)^n."""
    p, v = random_case(2, False)
    v += np.array([0.05, -0.02]) - v.mean(axis=0)
    _, v_pair = md_run(p, v, f"fix damp all jamflow/damping {B!r}")
    assert np.abs(v_pair.sum(axis=0) - v.sum(axis=0)).max() < 1e-12 * np.abs(v).sum()
    assert (v_pair**2).sum() < 0.5 * (v**2).sum()  # it does dissipate
    _, v_visc = md_run(p, v, f"fix damp all viscous {B!r}")
    assert np.abs(v_visc.sum(axis=0)).max() < 1e-6 * np.abs(v.sum(axis=0)).max()


def test_free_particle_flies_undamped():
    """A particle that touches nothing keeps its velocity exactly (eq. 2.3 damps contacts
    only); fix viscous slows it."""
    p = Packing(np.array([[1.0, 1.0], [2.1, 1.0], [5.0, 5.0]]), np.array([1.0, 1.4, 1.0]), Box.cube(9.0, 2))
    v = np.array([[0.01, 0.0], [-0.01, 0.0], [0.003, 0.001]])
    _, v_pair = md_run(p, v, f"fix damp all jamflow/damping {B!r}", steps=500)
    _, v_free = md_run(p, v, "fix damp all jamflow/damping 0.0", steps=500)  # b = 0: no damping at all
    assert np.array_equal(v_pair[2], v[2])
    assert (v_pair[:2] ** 2).sum() < 0.5 * (v_free[:2] ** 2).sum()  # the colliding pair lost energy
    _, v_visc = md_run(p, v, f"fix damp all viscous {B!r}", steps=500)
    assert np.linalg.norm(v_visc[2]) < 0.01 * np.linalg.norm(v[2])


# setup errors and settings ------------------------------------------------------------------------------
BOX = ["units lj", "dimension 2", "atom_style sphere", "region b block 0 9 0 9 -0.5 0.5", "create_box 1 b",
       "create_atoms 1 single 1 1 0", "set atom 1 diameter 1.4"]


@pytest.mark.parametrize("lines, message", [
    ([*BOX, "comm_modify vel yes", "fix d all jamflow/damping -1"], "B must be a finite number >= 0"),
    ([*BOX, "comm_modify vel yes", "fix d all jamflow/damping"], "expected fix ID group jamflow/damping B"),
    ([*BOX, "pair_style zero 1.4", "pair_coeff * *", "fix d all jamflow/damping 1", "run 0"], "comm_modify vel yes"),
    ([*BOX, "comm_modify vel yes", "pair_style zero 1.2", "pair_coeff * *", "fix d all jamflow/damping 1", "run 0"],
     "pair cutoff 1.2.* below the largest diameter 1.4"),
    ([*BOX, "comm_modify vel yes", "fix d all jamflow/damping 1", "run 0"], "needs a pair style"),
    (["units lj", "dimension 2", "atom_style atomic", "region b block 0 9 0 9 -0.5 0.5", "create_box 1 b",
      "mass 1 1", "comm_modify vel yes", "pair_style zero 1", "pair_coeff * *", "fix d all jamflow/damping 1",
      "run 0"], "requires atom_style sphere"),
], ids=["negative", "missing", "ghost-velocities", "cutoff", "no-pair", "no-radius"])
def test_fix_rejects_bad_setup(lines, message):
    assert_lammps_rejects(lines, message)


def test_settings_check_the_pairwise_limit():
    assert PAIRWISE_BDT_LIMIT == pytest.approx(1 / 12)
    MinimizerSettings(method="md", md_damping="pairwise", damping=0.8, md_timestep=0.1)  # b dt = 0.08
    with pytest.raises(ValueError, match="pairwise damping.*z_i \\+ z_j"):
        MinimizerSettings(method="md", md_damping="pairwise", damping=0.9, md_timestep=0.1)
    MinimizerSettings(method="md", md_damping="viscous", damping=0.9, md_timestep=0.1)  # viscous: b dt < 2
    with pytest.raises(ValueError, match="unknown md_damping"):
        MinimizerSettings(method="md", md_damping="langevin")
    with pytest.raises(ValueError, match="2 energy samples"):
        MinimizerSettings(method="md", window=15)
