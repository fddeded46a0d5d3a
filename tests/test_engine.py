"""LAMMPS engine against the all-pairs numpy reference (a second implementation)."""

import numpy as np
import pytest

from jamflow.model.box import Box
from jamflow.engines.lammps.engine import LammpsEngine, LammpsError
from jamflow.engines.lammps.pair_styles import uses_harmonic_cut
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.model.potentials import RepulsiveLJ, Spring


def assert_matches_reference(packing, rtol=1e-12):
    ref = energy_forces_pressure(packing)
    with LammpsEngine(packing) as eng:
        got = eng.evaluate()
    assert got.energy == pytest.approx(ref.energy, rel=rtol)
    assert np.max(np.abs(got.forces - ref.forces)) <= rtol * np.max(np.abs(ref.forces))
    assert np.max(np.abs(got.pressure_tensor - ref.pressure_tensor)) <= rtol * np.max(np.abs(ref.pressure_tensor))


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("tilt", [0.0, 0.3])
def test_harmonic_cut_bidisperse_matches_reference(config, dim, tilt):
    d = np.where(np.arange(120) % 2 == 0, 1.0, 1.4)
    p = config(120, dim, 0.9 if dim == 2 else 0.7, seed=dim, diameters=d, tilt=tilt)
    assert uses_harmonic_cut(p)
    assert_matches_reference(p)


@pytest.mark.parametrize("pot", [Spring(2.0), Spring(2.5), Spring(1.5), Spring(3.0), RepulsiveLJ()],
                         ids=lambda p: p.spec)
@pytest.mark.parametrize("dim,tilt", [(2, 0.0), (2, 0.25), (3, 0.2)])
def test_every_potential_polydisperse_matches_reference(config, pot, dim, tilt):
    # RLJ diverges at r -> 0: keep overlaps moderate so the comparison is well conditioned
    phi = (0.86 if dim == 2 else 0.66) if isinstance(pot, Spring) else (0.7 if dim == 2 else 0.5)
    p = config(100, dim, phi, seed=7, tilt=tilt, potential=pot)
    assert not uses_harmonic_cut(p)
    assert_matches_reference(p)


def test_positions_round_trip_in_packing_order(config):
    p = config(50, 2, 0.5, seed=3)
    with LammpsEngine(p) as eng:
        back = eng.packing()
    diff = p.box.minimum_image(back.positions - p.positions)
    assert np.max(np.abs(diff)) < 1e-12


def test_lammps_error_names_the_command(config):
    p = config(10, 2, 0.3, seed=5)
    with LammpsEngine(p) as eng, pytest.raises(LammpsError, match="bogus_command"):
        eng.command("bogus_command 1 2")


# Lees-Edwards cells: accumulated strain, reduced cell, flips ------------------------------------
def affine(positions, old, new):
    """x -> h' h^-1 x: the deformation set_box applies (x -> x + dgamma y for a shear step)."""
    return positions @ (new.h @ np.linalg.inv(old.h)).T


def assert_state_matches(state, packing, rtol=1e-12):
    ref = energy_forces_pressure(packing)
    assert ref.energy > 0 and state.energy == pytest.approx(ref.energy, rel=rtol)
    assert np.max(np.abs(state.forces - ref.forces)) <= rtol * np.max(np.abs(ref.forces))
    assert np.max(np.abs(state.pressure_tensor - ref.pressure_tensor)) <= rtol * np.max(np.abs(ref.pressure_tensor))


@pytest.mark.parametrize("dim", [2, 3])
def test_shear_steps_through_a_flip_follow_the_reference(config, dim):
    """gamma 0.4 -> 0.6 in steps of 0.02: the reduced tilt flips from +lx/2 to -lx/2 at 0.5;
    every step agrees with the numpy reference on positions moved x -> x + dgamma y here."""
    p = config(90, dim, 0.9 if dim == 2 else 0.7, seed=50 + dim, tilt=0.4)
    x, box = p.positions, p.box
    with LammpsEngine(p) as eng:
        for gamma in np.linspace(0.42, 0.6, 10):
            new = box.with_shear_strain(gamma)
            x, box = affine(x, box, new), new
            eng.set_box(new)
            assert_state_matches(eng.evaluate(), p.with_positions(x, box))
            assert eng.box is new and eng.packing().box.shear_strain == pytest.approx(gamma, rel=1e-15)
        assert eng.box.reduced().tilts[0] == pytest.approx(-0.4 * eng.box.lengths[1], rel=1e-12)
        assert any("xy final -" in c for c in eng.commands)  # LAMMPS holds the flipped cell


@pytest.mark.parametrize("dim", [2, 3])
def test_flip_changes_nothing_physical(config, dim):
    """A strain of 0.5 (tilt +lx/2) and one ulp above it (tilt folded to -lx/2): the cell
    flips; energy, forces and pressure tensor stay the same to 1e-12."""
    p = config(90, dim, 0.9 if dim == 2 else 0.7, seed=60 + dim, tilt=0.45)
    with LammpsEngine(p) as eng:
        eng.set_box(p.box.with_shear_strain(0.5 - 1e-16))
        before = eng.evaluate()
        after_box = p.box.with_shear_strain(np.nextafter(0.5, 1.0))
        assert not np.array_equal(after_box.reduction()[1], eng._fold)  # this step flips
        eng.set_box(after_box)
        after = eng.evaluate()
    assert after.energy == pytest.approx(before.energy, rel=1e-12)
    assert np.max(np.abs(after.forces - before.forces)) <= 1e-12 * np.max(np.abs(before.forces))
    assert np.max(np.abs(after.pressure_tensor - before.pressure_tensor)) <= 1e-12 * np.max(np.abs(before.pressure_tensor))


@pytest.mark.parametrize("dim", [2, 3])
def test_flip_keeps_unwrapped_coordinates(config, dim):
    """Image flags are relabelled on a flip: x + (reduced h) n follows the affine map."""
    p = config(60, dim, 0.5, seed=70 + dim, tilt=0.3)
    with LammpsEngine(p) as eng:
        eng.command(f"displace_atoms all random 12 12 {12 if dim == 3 else 0} 7 units box")  # images != 0

        def unwrapped():
            n = np.ctypeslib.as_array(eng.lmp.gather_atoms("image", 0, 3)).reshape(-1, 3)[:, :dim]
            return eng.positions() + n @ eng.box.reduced().h.T, n

        start, n0 = unwrapped()
        assert np.count_nonzero(n0[:, 1]) > 10
        new = p.box.with_shear_strain(1.7)  # folds twice
        eng.set_box(new)
        end, _ = unwrapped()
    assert np.max(np.abs(end - affine(start, p.box, new))) < 1e-12 * np.abs(start).max()


def test_engine_takes_any_accumulated_tilt_and_the_unit_period(config):
    """A packing at gamma = 2.6 starts in the reduced cell; gamma and gamma + 1 give one energy;
    one step of 2.5 strain units and a 3D step folding yz and xz match the reference."""
    p = config(90, 2, 0.9, seed=80, tilt=2.6)
    with LammpsEngine(p) as eng:
        assert_state_matches(eng.evaluate(), p)
        same = p.with_positions(p.positions, p.box.with_shear_strain(1.6))
        with LammpsEngine(same) as other:
            assert other.evaluate().energy == pytest.approx(eng.evaluate().energy, rel=1e-12)
        new = p.box.with_shear_strain(0.1)
        eng.set_box(new)
        assert_state_matches(eng.evaluate(), p.with_positions(affine(p.positions, p.box, new), new))
    q = config(90, 3, 0.7, seed=81, tilt=0.2)
    h = q.box.h.copy()
    h[0, 2], h[1, 2] = 0.45 * h[0, 0], 0.4 * h[1, 1]
    start = q.with_positions(affine(q.positions, q.box, Box(h)), Box(h))
    h[0, 2], h[1, 2] = 0.7 * h[0, 0], 1.3 * h[1, 1]
    new = Box(h)
    assert new.reduction()[1][1, 2] == -1  # yz folds (shifting xz by xy), then xz
    with LammpsEngine(start) as eng:
        eng.set_box(new)
        assert_state_matches(eng.evaluate(), start.with_positions(affine(start.positions, start.box, new), new))
