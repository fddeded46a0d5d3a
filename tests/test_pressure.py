"""Constant stress (docs/notes/walls-gravity-pressure.md): the box as FIRE coordinates and LAMMPS fix box/relax. Closed forms
(ideal lattices at fixed pressure), box forces against finite differences of the enthalpy, jamming
at a target pressure from random starts, phi_J extrapolation, and bad input."""

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.optimize import brentq

from jamflow.model.box import Box
from jamflow.cli.app import main
from jamflow.engines.compiled.engine import CompiledEngine
from jamflow.engines.compiled.field import box_forces, make_field
from jamflow.engines.lammps.engine import LammpsEngine
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.io.packing_file import read_attrs
from jamflow.minimize.settings import MinimizerSettings
from jamflow.minimize.rules import minimize
from jamflow.model.packing import Packing
from jamflow.model.potentials import Spring
from jamflow.protocols.settings import BODY_PHI0
from jamflow.protocols.compression import initial_packing
from jamflow.protocols.pressure import (PressureSettings, extrapolate_phi_j, jam_at_pressure, pressure_floor,
                                        pressure_sequence)
from jamflow.model.shapes import RigidBody
from jamflow.model.walls import with_walls


def triangular(n=6, m=6, spacing=1.0):
    pts = np.array([[i + 0.5 * (j % 2), j * math.sqrt(3) / 2] for j in range(m) for i in range(n)]) * spacing
    return pts, Box(np.diag([n * spacing, m * spacing * math.sqrt(3) / 2]))


def fcc(k=3):
    base = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    cells = np.array([[i, j, l] for i in range(k) for j in range(k) for l in range(k)], float)
    a = math.sqrt(2)  # cube side for nearest-neighbour distance 1
    return ((cells[:, None, :] + base[None]) * a).reshape(-1, 3), Box(np.eye(3) * k * a)


def lattice_spacing(pressure, potential, dim):
    """Nearest-neighbour distance r of the triangular (2D) / FCC (3D) lattice of unit disks/spheres
    at pressure P = (1/(d V)) sum r f: P = sqrt(3) f(r) / r (2D), 2 sqrt(2) f(r) / r^2 (3D),
    f = -dV/dr."""
    coeff, power = (math.sqrt(3), 1) if dim == 2 else (2 * math.sqrt(2), 2)
    f = lambda r: -float(potential.dv_dr(np.array([r]), 1.0)[0])  # noqa: E731
    return brentq(lambda r: coeff * f(r) / r**power - pressure, 0.5, 1.0 - 1e-15, xtol=1e-16, rtol=1e-15)


@pytest.mark.parametrize("stress", ["iso", "aniso", "tri"])
@pytest.mark.parametrize("dim, potential", [(2, Spring()), (2, Spring(2.5)), (3, Spring())], ids=["2d", "2d-hertz", "3d"])
def test_ideal_lattice_at_fixed_pressure(dim, potential, stress):
    """A lattice started at contact (P = 0) and displaced a little relaxes to the closed-form
    spacing at the target pressure, box and all."""
    pts, box = triangular() if dim == 2 else fcc()
    rng = np.random.default_rng(1)
    p = Packing(pts + 0.01 * rng.standard_normal(pts.shape), np.ones(len(pts)), box, potential)
    target = 1e-4
    with CompiledEngine(p) as eng:
        res = minimize(eng, MinimizerSettings(force_tol=1e-14, pressure=target, stress=stress))
        state, q = eng.state(), eng.packing()
    r = lattice_spacing(target, potential, dim)
    assert res.converged
    assert np.allclose(q.box.lengths / box.lengths, r, rtol=1e-9)  # the start has spacing 1
    assert state.pressure == pytest.approx(target, rel=1e-9)
    assert np.allclose(state.pressure_tensor, target * np.eye(dim), rtol=0, atol=1e-9 * target)


def test_lammps_box_relax_reaches_the_lattice_spacing():
    pts, box = triangular()
    target = 1e-3
    with LammpsEngine(Packing(pts + 0.01, np.ones(len(pts)), box, Spring())) as eng:
        res = minimize(eng, MinimizerSettings(method="cg", force_tol=1e-13, pressure=target))  # CG floor ~1e-14
        state = eng.state()
        lengths = eng.box.lengths
    assert res.converged
    assert lengths[0] / 6 == pytest.approx(lattice_spacing(target, Spring(), 2), rel=1e-12)
    assert state.pressure == pytest.approx(target, rel=1e-10)
    assert any("box/relax iso" in c for c in eng.commands)


@pytest.mark.parametrize("stress", ["iso", "aniso", "tri"])
def test_box_forces_are_enthalpy_derivatives(stress):
    """g_k = -dH/dq_k, H = U + P V, q_k = L e_k: against central differences of the reference energy."""
    p = initial_packing(24, 2, "bi:1.4:0.5", "spring", 3, 0.86)
    target = 1e-3
    field = make_field(p, target, stress)
    ref = energy_forces_pressure(p)
    gb = np.zeros(len(field.basis))
    box_forces(field, ref.pressure_tensor * p.box.volume, gb)
    step = 1e-6
    for k, basis in enumerate(field.basis):
        def enthalpy(dq):
            m = np.eye(2) + dq * basis / field.length
            q = p.with_positions(p.positions @ m.T, box=p.box.with_h(m @ p.box.h))
            return energy_forces_pressure(q).energy + target * q.box.volume
        numeric = -(enthalpy(step) - enthalpy(-step)) / (2 * step)
        assert gb[k] == pytest.approx(numeric, rel=1e-6, abs=1e-10)


@pytest.fixture(scope="module")
def at_pressure():
    start = initial_packing(64, 2, "bi:1.4:0.5", "spring", 1, 0.8)
    return start, {mode: jam_at_pressure(start, PressureSettings((1e-4, 1e-5, 1e-6), mode)) for mode in ("iso", "tri")}


@pytest.mark.parametrize("mode", ["iso", "tri"])
def test_jam_at_pressure_from_a_random_start(at_pressure, mode):
    res = at_pressure[1][mode]
    ref = energy_forces_pressure(res.packing)
    assert np.all(res.history["converged"])
    assert abs(ref.pressure / 1e-6 - 1) < 1e-6  # measured (independently) within 1e-6 of the target
    assert np.max(np.abs(ref.forces)) < 1e-13
    assert 0.78 < res.phi < 0.87 and np.all(np.diff(res.history["phi"]) < 0)  # decompressing toward phi_J
    if mode == "tri":  # shear stress relaxed: only round-off left
        assert np.max(np.abs(ref.pressure_tensor - np.diag(np.diag(ref.pressure_tensor)))) < 1e-9 * 1e-6
        assert res.packing.box.is_triclinic
    else:
        assert not res.packing.box.is_triclinic


def test_lammps_jams_at_pressure(at_pressure):
    """LAMMPS CG with fix box/relax from the same start (a different minimiser: another minimum)."""
    with pytest.warns(UserWarning, match="stopped by 'linesearch'"):  # CG's floor, ~1e-13 (not converged by force)
        res = jam_at_pressure(at_pressure[0], PressureSettings((1e-4, 1e-5, 1e-6), "iso", MinimizerSettings(method="cg")),
                              engine="lammps")
    ref = energy_forces_pressure(res.packing)
    assert abs(ref.pressure / 1e-6 - 1) < 1e-6
    assert np.max(np.abs(ref.forces)) < 1e-12  # CG's line search stops near 1e-13 (docs/notes/failure-modes.md)
    assert 0.78 < res.phi < 0.87


def test_rigid_bodies_at_constant_pressure():
    dimer = RigidBody([[0.0, 0.0], [0.6, 0.0]], [1.0, 1.0], "dimer")
    start = initial_packing(32, 2, "bi:1.4:0.5", "spring", 2, BODY_PHI0[2], shape=dimer)  # bodies start without overlaps
    res = jam_at_pressure(start, PressureSettings((1e-3, 1e-4)))
    ref = energy_forces_pressure(res.packing)
    assert abs(ref.pressure / 1e-4 - 1) < 1e-6 and np.max(np.abs(ref.forces)) < 1e-12


def test_extrapolation_to_zero_pressure():
    p = np.array([1e-4, 1e-5, 1e-6])
    assert extrapolate_phi_j(p, 0.84 + 0.3 * p, 2.0) == pytest.approx(0.84, abs=1e-15)
    assert extrapolate_phi_j(p, 0.84 + 0.3 * p ** (2 / 3), 2.5) == pytest.approx(0.84, abs=1e-15)


def test_pressure_sequence_and_settings():
    assert pressure_sequence(1e-6) == pytest.approx((1e-4, 1e-5, 1e-6))
    assert pressure_sequence(1e-2) == (1e-2,)
    with pytest.raises(ValueError, match="decrease"):
        PressureSettings((1e-6, 1e-4))
    for bad in (-1e-4, 0.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="finite positive"):
            PressureSettings((bad,))
        with pytest.raises(ValueError, match="finite positive"):
            MinimizerSettings(pressure=bad)


def test_pressures_float64_cannot_resolve_are_refused_before_work():
    start = initial_packing(256, 2, "bi:1.4:0.5", "spring", 0, 0.8)
    floor = pressure_floor(start, MinimizerSettings())
    assert floor == pytest.approx(1000 * 1e-14 / np.mean(start.diameters))  # L < 20: ftol 1e-14
    with pytest.raises(ValueError, match="below what float64 resolves at N = 256"):
        jam_at_pressure(start, PressureSettings((1e-4, floor / 2)))
    with pytest.raises(ValueError, match="periodic box"):
        jam_at_pressure(with_walls(start, (1,)), PressureSettings((1e-4,)))
    with pytest.raises(ValueError, match="minimizer cg only"):
        with LammpsEngine(start) as eng:
            minimize(eng, MinimizerSettings(pressure=1e-4))
    with pytest.raises(ValueError, match="a target pressure with minimizer fire"):
        jam_at_pressure(start, PressureSettings((1e-4,)), engine="lammps")


def test_ellipse_pressure_floor_is_that_of_the_ellipse_force_tolerance():
    """The floor is FLOOR_MARGIN times the tolerance the minimiser runs with, which for ellipses
    starts from their base 5e-13 (docs/notes/ellipses.md), not the disks' 1e-14: a target between
    the two floors is refused before work (it was accepted, with contact forces only 20x above
    the tolerance instead of 1000x)."""
    start = initial_packing(16, 2, "bi:1.4:0.6667", "spring", 0, 0.8, shape="ellipse:1.6")
    floor = pressure_floor(start, MinimizerSettings())
    assert floor == pytest.approx(1000 * 5e-13 / np.mean(start.diameters))  # L < 20
    with pytest.raises(ValueError, match=r"round-off floor 5\.0e-13"):
        jam_at_pressure(start, PressureSettings((1e-4, floor / 2)))


def test_cli_pressure(tmp_path, capsys):
    out = tmp_path / "p.h5"
    assert main(["jam", "--n", "32", "--pressure", "1e-5", "--stress", "aniso", "--quiet", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "P_target = 1.000e-05" in text
    attrs = read_attrs(out)
    assert attrs["target_pressure"] == 1e-5 and attrs["stress"] == "aniso"
    assert attrs["pressure"] == pytest.approx(1e-5, rel=1e-6)
    for argv, message in ((["--pressure", "-1"], "--pressure must be"), (["--pressure", "1e-14"], "float64 resolves")):
        assert main(["jam", "--n", "32", "--out", str(tmp_path / "x.h5"), *argv]) == 2
        assert message in capsys.readouterr().err


def test_lattice_closed_form_is_not_trivially_satisfied():
    """The closed form has teeth: at another pressure the spacing differs by far more than the tolerance."""
    assert abs(lattice_spacing(1e-4, Spring(), 2) - lattice_spacing(2e-4, Spring(), 2)) > 1e-5
    pts, box = triangular()
    p = Packing(pts, np.ones(len(pts)), box, Spring())
    assert energy_forces_pressure(replace(p)).pressure < 1e-15  # the start is at contact (round-off overlaps only)
