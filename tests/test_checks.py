"""jamflow.mechanics.checks: window, force balance, contact count, and what float64 resolves."""

import math

import numpy as np
import pytest

from jamflow.mechanics.contacts import Contacts
from jamflow.model.box import Box
from jamflow.mechanics.checks import (BALANCE_RTOL, MIN_FORCE_RATIO, MIN_OVERLAP_RATIO, PackingChecks, check_packing,
                                      resolution)
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.io.packing_file import read_checks, save_packing
from jamflow.model.packing import Packing
from jamflow.model.potentials import RepulsiveLJ, Spring
from jamflow.protocols.compression import jam


def square_lattice(k=6, overlap=1e-6, potential=None):
    """k x k equal disks on a square lattice, each touching 4 neighbours with ``overlap``."""
    a = 1.0 - overlap
    pos = np.array([(i * a, j * a) for i in range(k) for j in range(k)], float) + 0.25
    return Packing(pos, np.ones(k * k), Box.cube(k * a, 2), potential or Spring())


@pytest.fixture(scope="module")
def jammed():
    return jam(n=32, dim=2, seed=3)


def test_square_lattice_closed_form():
    """4 contacts per disk, net force zero by symmetry, contact force eps/sigma * delta."""
    p = square_lattice(6, 1e-6)
    c = check_packing(p, v_tol=6e-13)
    assert c.n_contacts == 2 * 36 and c.isostatic_count == 2 * 36 - 1 and c.jammed
    assert c.mean_contact_force == pytest.approx(1e-6, rel=1e-9)
    assert c.energy_per_particle == pytest.approx(2 * 0.5 * 1e-12, rel=1e-8)  # 2 contacts per disk
    assert c.max_force < 1e-8 * c.mean_contact_force and c.force_balanced  # round-off of positions only
    assert c.in_window and c.passed and c.problems() == []


def test_energies_and_forces_match_the_all_pairs_reference(jammed):
    c = check_packing(jammed.packing)
    ref = energy_forces_pressure(jammed.packing)
    assert c.energy_per_particle == pytest.approx(ref.energy / jammed.packing.n, rel=1e-12)
    assert c.max_force == pytest.approx(np.abs(ref.forces).max(), rel=1e-6, abs=1e-17)
    contacts = Contacts().compute(jammed.packing)
    assert (c.n_contacts, c.n_floaters, c.isostatic_count) == (contacts.n_contacts, contacts.n_floaters,
                                                               contacts.isostatic_count)
    assert c.passed and c.force_ratio < 1e-4  # jammed packings: net forces ~1e-6 of contact forces


def test_a_compressed_packing_is_not_force_balanced(jammed):
    squeezed = jammed.packing.scaled_to_phi(jammed.phi_j / 0.95**2)
    c = check_packing(squeezed, v_tol=1e-16)
    assert not c.force_balanced and c.force_ratio > BALANCE_RTOL and not c.in_window
    assert any("not at an energy minimum" in text for text in c.problems())


def test_a_dilute_packing_is_not_jammed():
    p = square_lattice(6, -0.5)  # spacing 1.5: no contacts, no forces
    c = check_packing(p)
    assert not c.jammed and c.in_window is None and not c.passed
    assert c.problems() == ["not jammed: every particle is a floater (no contact network)"]


def test_checks_are_stored_in_the_packing_file(jammed, tmp_path):
    c = check_packing(jammed.packing, jammed.energy_per_particle, None, 1e-16, 1e-14)
    path = save_packing(tmp_path / "p.h5", jammed.packing, checks=c)
    assert read_checks(path) == c
    assert read_checks(save_packing(tmp_path / "q.h5", jammed.packing)) is None
    no_window = check_packing(jammed.packing)
    assert PackingChecks.from_attrs(no_window.as_attrs()) == no_window


@pytest.mark.parametrize("pot", [Spring(2.0), Spring(2.5), RepulsiveLJ()], ids=lambda p: p.spec)
def test_resolution_closed_forms(pot):
    p = square_lattice(6, 1e-3, pot)
    res = resolution(p, 1e-16, 1e-14)
    delta = res.window_overlap
    # d contacts per particle hold V_tol: d V(delta) = V_tol, V(delta) the one-contact energy
    one = pot.energy(np.array([1 - delta]), 1.0)[0]
    assert 2 * one == pytest.approx(1e-16, rel=1e-9)
    if isinstance(pot, Spring) and pot.alpha == 2.0:
        assert delta == pytest.approx(math.sqrt(1e-16), rel=1e-9) and res.window_force == pytest.approx(delta, rel=1e-9)
    assert res.overlap_roundoff == np.spacing(p.box.lengths.max())
    at_limit = resolution(p, 1.01 * res.smallest_v_tol, 1e-14)  # r = sigma (1 - delta) rounds delta to ~1e-4 here
    assert at_limit.problem() is None
    assert min(at_limit.overlap_ratio / MIN_OVERLAP_RATIO, at_limit.force_ratio / MIN_FORCE_RATIO) == pytest.approx(1, rel=1e-2)
    assert resolution(p, 0.9 * res.smallest_v_tol, 1e-14).problem() is not None


def test_checks_cover_particles_that_turn():
    """A jammed packing of dimers passes (forces and generalized torques balanced, at least the
    translational contact count); turning one dimer breaks its torque balance and the check sees it."""
    from jamflow.model.shapes import RigidBody

    res = jam(n=32, seed=2, shape=RigidBody([[0.0, 0.0], [0.5, 0.0]], [1.0, 1.0], "dimer:1.5"))
    ok = check_packing(res.packing, res.energy_per_particle, None, 1e-16)
    assert ok.passed, ok.problems()
    o = res.packing.orientations.copy()
    kept = np.flatnonzero(~Contacts(count="sites").compute(res.packing).floater)
    o[kept[0]] += 1e-4
    bad = check_packing(res.packing.with_positions(res.packing.positions, orientations=o))
    assert not bad.force_balanced
