"""Contacts, floaters and the isostatic count (chapter section 4.1)."""

import numpy as np
import pytest

from jamflow.mechanics.contacts import Contacts, angular_gap_spanning, positively_spanning, remove_floaters
from jamflow.model.box import Box
from jamflow.model.packing import Packing


def triangular_lattice(nx, ny, spacing, tilt_cells=0):
    """Monodisperse triangular lattice (ny even); the cell may be tilted by whole spacings."""
    rows = np.arange(ny)
    x = (np.arange(nx)[None, :] + 0.5 * (rows[:, None] % 2)) * spacing
    y = np.repeat(rows * spacing * np.sqrt(3) / 2, nx)
    box = Box([[nx * spacing, tilt_cells * spacing], [0.0, ny * spacing * np.sqrt(3) / 2]])
    return Packing(np.column_stack([x.ravel(), y]), np.ones(nx * ny), box)


def disk_in_vacancy(offset_deg, shift, diameter):
    """Triangular lattice (spacing 0.98, rigid, z = 6) with site 14 replaced by a disk of the
    given diameter, moved by ``shift`` towards ``offset_deg``; its six lattice neighbours sit
    at 0, 60, ..., 300 degrees."""
    lattice = triangular_lattice(6, 6, 0.98)
    pos, dia = lattice.positions.copy(), lattice.diameters.copy()
    pos[14] += shift * np.array([np.cos(np.radians(offset_deg)), np.sin(np.radians(offset_deg))])
    dia[14] = diameter
    return Packing(pos, dia, lattice.box)


@pytest.mark.parametrize("offset,shift,diameter,z,floater", [
    (0, 0.0, 1.0, 6, False),     # centred: six contacts all round
    (60, 0.3, 0.8, 3, True),     # contacts at 0, 60, 120 deg: all on one side (chapter Fig. 2.19 text)
    (60, 0.3, 1.4, 5, False),    # adds 180 and 300 deg: spans the plane
    (0, 0.195, 0.6, 1, True),    # one contact: fewer than d + 1 = 3
])
def test_disk_in_vacancy_floater_rule(offset, shift, diameter, z, floater):
    p = disk_in_vacancy(offset, shift, diameter)
    c = Contacts().compute(p)
    raw = Contacts(min_contacts=0, half_space=False).compute(p)
    assert raw.z[14] == z
    assert c.floater[14] == floater and c.n_floaters == int(floater)
    assert c.z[14] == (0 if floater else z)
    assert c.n_contacts == 3 * 36 - 6 * floater + (0 if floater else z - 6)


def test_positive_span_lp_agrees_with_angular_gap():
    rng = np.random.default_rng(1)
    for trial in range(300):
        k = rng.integers(3, 7)
        angles = rng.uniform(0, 2 * np.pi, k) if trial % 2 else rng.uniform(0, 0.9 * np.pi, k)
        vectors = np.column_stack([np.cos(angles), np.sin(angles)])
        gap = angular_gap_spanning(1, np.zeros(k, int), vectors)[0]
        assert positively_spanning(vectors) == gap


def positively_spanning_lp(vectors) -> bool:
    """The LP form (jamflow's test until session 6): rank d and sum_k l_k v_k = 0 feasible with l_k >= 1."""
    from scipy.optimize import linprog

    k, d = vectors.shape
    if k <= d or np.linalg.matrix_rank(vectors) < d:
        return False
    res = linprog(np.zeros(k), A_eq=vectors.T, b_eq=np.zeros(d), bounds=[(1.0, None)] * k, method="highs")
    return res.status == 0


def _unit(v):
    return v / np.linalg.norm(v, axis=1)[:, None]


def test_positive_span_3d_agrees_with_the_lp():
    """Random sets (half of them squeezed towards a hemisphere, so both answers occur often) and
    lattice sets with exactly coplanar contacts, plain and with 1e-13 noise."""
    rng = np.random.default_rng(2)
    answers = []
    for trial in range(1500):
        k = int(rng.integers(3, 13))
        v = rng.normal(size=(k, 3))
        if trial % 2:
            v[:, 2] = np.abs(v[:, 2]) - rng.uniform(0, 0.6)  # mostly z > 0
        v = _unit(v)
        answers.append(positively_spanning(v))
        assert answers[-1] == positively_spanning_lp(v), v
    assert 0.2 < np.mean(answers) < 0.8  # both answers well represented
    octa = np.vstack([np.eye(3), -np.eye(3)])
    fcc = _unit(np.array([[a, b, 0] for a in (1, -1) for b in (1, -1)] + [[a, 0, b] for a in (1, -1) for b in (1, -1)]
                         + [[0, a, b] for a in (1, -1) for b in (1, -1)], float))
    half_fcc = fcc[fcc[:, 2] >= 0]  # the z >= 0 half: 8 contacts, 4 of them in the plane z = 0
    for lattice, spans in ((octa, True), (octa[:5], False), (fcc, True), (half_fcc, False)):
        for noise in (0.0, 1e-13):
            v = _unit(lattice + noise * rng.normal(size=lattice.shape))
            assert positively_spanning(v) == positively_spanning_lp(v) == spans


@pytest.mark.parametrize("dim", [2, 3])
def test_positive_span_of_many_sets_at_once_is_the_single_answer(dim):
    """``spanning_stack`` answers each set as ``positively_spanning`` does, degenerate sets included
    (coplanar, antiparallel, a contact on the boundary plane)."""
    from jamflow.mechanics.contacts import spanning_stack

    rng = np.random.default_rng(4)
    for k in range(1, 13):
        v = rng.normal(size=(60, k, dim))
        v[1::4, :, -1] = np.abs(v[1::4, :, -1])  # half-spaces
        v[2::4, :, -1] = 0.0 if dim == 3 else v[2::4, :, -1]  # coplanar
        if k > 1:
            v[3::4, 1] = -2.5 * v[3::4, 0]  # antiparallel pairs
        v[1::8, 0, -1] = 0.0  # on the boundary plane of the half-space
        assert spanning_stack(v).tolist() == [positively_spanning(s) for s in v]


def test_the_floater_search_tests_a_contact_set_again_only_after_it_changed(monkeypatch):
    """A 3D onset with floaters: each particle's directions are tested once, and again only
    after a partner became a floater (the search used to test every candidate each round)."""
    import jamflow.mechanics.contacts as contacts
    from jamflow import jam

    packing = jam(n=64, dim=3, seed=1).packing
    tested = []
    real = contacts.spanning_mask

    def recording(n, i, j, unit, which):
        z = np.bincount(i, minlength=n) + np.bincount(j, minlength=n)
        tested.append((which.copy(), z))
        return real(n, i, j, unit, which)

    monkeypatch.setattr(contacts, "spanning_mask", recording)
    result = Contacts().compute(packing)
    assert result.n_floaters > 0 and tested  # floaters: the search takes more than one round
    for later, (which, z) in enumerate(tested):
        for before, z_before in ((w, zb) for w, zb in tested[:later]):
            again = which & before
            assert np.all(z[again] < z_before[again]), np.flatnonzero(again & (z == z_before))


def test_positive_span_3d_cases():
    tetra = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]]) / np.sqrt(3)
    assert positively_spanning(tetra)
    assert not positively_spanning(tetra[:3])  # three vectors cannot span R^3 positively
    assert not positively_spanning(np.vstack([tetra[:3], [[0, 0, 1]]]) * [1, 1, 1] - [0, 0, 2])  # all z < 0
    octa = np.vstack([np.eye(3), -np.eye(3)])
    assert positively_spanning(octa)
    assert not positively_spanning(octa[[0, 1, 2, 3, 4]])  # no -z: contacts in the half-space z >= 0


def test_triangular_lattice_is_hyperstatic_with_z_six():
    c = Contacts().compute(triangular_lattice(6, 6, 0.98, tilt_cells=1))
    assert c.n_floaters == 0
    assert c.n_contacts == 3 * 36 and np.all(c.z == 6) and c.mean_z == 6.0
    assert c.isostatic_count == 36 * 2 - 2 + 1
    assert c.excess_contacts == 3 * 36 - 71 and not c.is_isostatic
    values, frac = c.z_distribution()
    assert frac[6] == 1.0 and values[6] == 6


def test_contact_is_strict_and_near_contacts_are_counted():
    lattice = triangular_lattice(6, 6, 1.0)  # every neighbour exactly at r = sigma (up to round-off)
    c = Contacts().compute(lattice)
    p = lattice.with_positions(lattice.positions * (1 - 1e-9), lattice.box.scaled(1 - 1e-9))
    assert Contacts().compute(p).n_contacts == 3 * 36
    assert c.n_near_contact == 3 * 36  # diagnostic: |r/sigma - 1| < 1e-12 on either side
    assert c.n_contacts < 3 * 36  # no tolerance: pairs at r >= sigma are not contacts


def test_remove_floaters_keeps_the_network():
    p = disk_in_vacancy(0, 0.195, 0.6)
    c = Contacts().compute(p)
    kept = remove_floaters(p, c)
    assert kept.n == 35 and kept.metadata["floaters_removed"] == 1
    assert np.array_equal(c.kept, np.delete(np.arange(36), 14))
    assert Contacts().compute(kept).n_contacts == c.n_contacts


def test_cascade_removes_floaters_created_by_removal():
    # a chain of three overlapping disks: the ends have one contact, the middle two;
    # all are floaters, and the middle one only because of its own count
    pos = np.array([[2.0, 2.0], [2.9, 2.0], [3.8, 2.0]])
    c = Contacts().compute(Packing(pos, np.ones(3), Box.cube(8.0, 2)))
    assert c.n_floaters == 3 and c.n_contacts == 0 and c.n_overlapping == 2


def test_random_overlapping_configuration_has_no_stable_network(config):
    # random positions are not force balanced: particles with all contacts on one side
    # exist, and removing them cascades through the whole configuration
    p = config(80, 2, 0.9, seed=2)
    c = Contacts().compute(p)
    without_half_space = Contacts(half_space=False).compute(p)
    assert c.n_overlapping == without_half_space.n_overlapping > 100
    assert without_half_space.n_kept > 0 and c.n_kept == 0


@pytest.mark.parametrize("kwargs,match", [
    (dict(min_contacts=-1), "min_contacts"),
    (dict(min_contacts=2.5), "min_contacts"),
    (dict(near_tol=-1.0), "near_tol"),
])
def test_bad_parameters_raise(kwargs, match):
    with pytest.raises(ValueError, match=match):
        Contacts(**kwargs)


def test_no_network_raises_clear_error(config):
    p = config(20, 2, 0.1, seed=0)
    c = Contacts().compute(p)
    assert c.n_kept == 0 and np.isnan(c.mean_z) and not c.is_isostatic
    with pytest.raises(ValueError, match="not jammed"):
        remove_floaters(p, c)
