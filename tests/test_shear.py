"""Jamming at fixed shear strain and quasistatic shear at zero pressure (chapter section 2.2):
unit period and mirror symmetry on real jammed packings, continuous families and breaks,
reversibility, the two engines, files, the command line and bad input."""

import math
import re

import numpy as np
import pytest

from jamflow.mechanics.contacts import Contacts
from jamflow.cli.app import main
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.io.packing_file import load_packing, read_attrs
from jamflow.protocols.compression import at_shear_strain, compress, initial_packing, jam
from jamflow.protocols.settings import chapter_protocol
from jamflow.protocols.shear import Network, shear, shear_strains
from jamflow.io.shear_file import ShearFile, save_shear_path


def start_at(gamma, seed=1, n=10, mirror=False):
    """One random start placed in the cell at ``gamma`` (mirrored x -> -x if asked)."""
    start = initial_packing(n, 2, "bi:1.4:0.5", "spring", seed, 0.8)
    if mirror:
        start = start.with_positions(start.positions * [-1.0, 1.0])
    return at_shear_strain(start, gamma)


def displacement_without_translation(a, b, keep):
    """Largest |r_i(b) - r_i(a)| over ``keep`` after removing the mean (a global translation
    is a zero mode of a periodic packing, free in every minimisation)."""
    d = a.box.minimum_image(b.positions - a.positions)[keep]
    return float(np.abs(d - d.mean(axis=0)).max())


def rigid(packing):
    return ~Contacts().compute(packing).floater


# --- jamming at fixed strain: unit period, mirror ------------------------------------------------------
@pytest.mark.parametrize("engine", ["numba", "lammps"])
def test_strains_one_period_apart_jam_to_the_same_packing_bit_for_bit(engine):
    """0.25 and 1.25 are exactly one apart as doubles: the protocol runs in the reduced cell,
    so both jams execute the same operations (positions, phi_J, V and history identical)."""
    a = compress(start_at(0.25), chapter_protocol(), engine=engine)
    b = compress(start_at(1.25), chapter_protocol(), engine=engine)
    assert np.array_equal(a.packing.positions, b.packing.positions)
    assert a.phi_j == b.phi_j and a.energy_per_particle == b.energy_per_particle
    assert all(np.array_equal(a.history[k], b.history[k]) for k in a.history)


def test_gamma_and_gamma_plus_one_same_packing():
    """gamma = 0.2 and 1.2 from the same start (the default protocol): the same packing. As
    doubles 1.2 - 1 = 0.19999999999999996, a cell 5.6e-17 in strain away from 0.2's; V at onset
    carries ~1e-16 / overlap ~ 1e-8 relative round-off (overlaps ~1e-8), so energies agree to
    that, positions and phi_J to 1e-12."""
    a, b = jam(n=10, seed=1, gamma=0.2), jam(n=10, seed=1, gamma=1.2)
    assert b.packing.box.shear_strain == 1.2 and a.packing.box.shear_strain == 0.2
    assert b.packing.box.is_same_lattice(a.packing.box, tol=1e-12)
    keep = rigid(a.packing)
    assert displacement_without_translation(a.packing, b.packing, keep) < 1e-12
    assert abs(a.phi_j - b.phi_j) < 1e-12
    assert Network.of(a.packing).pairs() == Network.of(b.packing).pairs()
    assert b.energy_per_particle == pytest.approx(a.energy_per_particle, rel=1e-6)


def test_gamma_and_one_minus_gamma_are_related_by_the_inversion():
    """Figure 2.4(c): a start mirrored x -> -x jams at 1 - gamma to the mirror image of the
    packing jammed at gamma (chapter protocol: identical decisions). Exact strains (0.25, 0.75 ->
    reduced -0.25) make the two cells exact mirror images."""
    a = compress(start_at(0.25), chapter_protocol())
    m = compress(start_at(0.75, mirror=True), chapter_protocol())
    assert np.array_equal(a.history["phi"], m.history["phi"]) and a.phi_j == m.phi_j
    back = m.packing.with_positions(m.packing.positions * [-1.0, 1.0], box=a.packing.box)
    assert displacement_without_translation(a.packing, back, rigid(a.packing)) < 1e-12
    assert Network.of(a.packing).pairs() == Network.of(back).pairs()
    assert m.energy_per_particle == pytest.approx(a.energy_per_particle, rel=1e-6)
    assert m.pressure_tensor[0, 1] == pytest.approx(-a.pressure_tensor[0, 1], rel=1e-6)


def test_mirror_image_of_a_jammed_packing_is_static_at_one_minus_gamma():
    """The inversion as an exact operation on a real packing: same energy (bit for bit), F_x and
    P_xy change sign, and the mirrored cell is the lattice of 1 - gamma."""
    a = jam(n=10, seed=1, gamma=0.2)
    cell = a.packing.box.reduced()
    h = cell.h.copy()
    h[0, 1] = -h[0, 1]
    mirror_box = type(cell)(h)
    mirror = a.packing.with_positions(a.packing.positions * [-1.0, 1.0], box=mirror_box)
    ra, rm = energy_forces_pressure(a.packing), energy_forces_pressure(mirror)
    assert rm.energy == pytest.approx(ra.energy, rel=1e-12)
    assert np.allclose(rm.forces * [-1.0, 1.0], ra.forces, rtol=0, atol=1e-20)
    assert np.max(np.abs(rm.forces)) < 1e-13
    assert rm.pressure_tensor[0, 1] == pytest.approx(-ra.pressure_tensor[0, 1], rel=1e-9)
    assert mirror_box.is_same_lattice(a.packing.box.with_shear_strain(0.8), tol=1e-12)


def test_jam_gamma_file_stores_the_accumulated_strain(tmp_path):
    out = tmp_path / "p.h5"
    assert main(["jam", "--n", "10", "--seed", "1", "--gamma", "1.2", "--out", str(out), "--quiet"]) == 0
    attrs, p = read_attrs(out), load_packing(out)
    assert attrs["gamma"] == 1.2 and p.box.shear_strain == 1.2 and p.box.h[0, 1] == 1.2 * p.box.h[1, 1]
    ref = energy_forces_pressure(p)
    assert 1e-16 < ref.energy / p.n < 2e-16 and np.max(np.abs(ref.forces)) < 1e-13


@pytest.mark.parametrize("kwargs,message", [
    (dict(gamma=math.nan), "finite"), (dict(gamma=math.inf), "finite"), (dict(gamma="0.2"), "finite"),
])
def test_jam_refuses_a_strain_that_is_not_finite(kwargs, message):
    with pytest.raises(ValueError, match=message):
        jam(n=10, **kwargs)


# --- quasistatic shear ------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def path_seed1():
    """N = 10, seed 1: one family from gamma 0.2 to 0.226, a rearrangement at 0.228."""
    start = jam(n=10, seed=1, gamma=0.2)
    return start, shear(start.packing, 0.002, 0.23)


def test_along_a_family_the_network_is_identical_and_phi_j_smooth(path_seed1):
    start, path = path_seed1
    steps = path.steps
    assert np.allclose(path.gamma, 0.2 + 0.002 * np.arange(16), rtol=0, atol=1e-15)
    assert steps[0].phi_j == pytest.approx(start.phi_j, abs=1e-12)  # the start was already in the window
    family = [s for s in steps if s.gamma < 0.2269]
    assert len(family) == 14 and not any(s.changed for s in family)
    assert all(s.network.pairs() == family[0].network.pairs() for s in family)
    g, phi = path.gamma[:14] - 0.213, path.phi_j[:14]
    fit = np.polyval(np.polyfit(g, phi, 5), g)
    assert np.abs(np.diff(phi)).min() > 1e-4  # phi_J moves by ~3e-4 a step ...
    assert np.abs(phi - fit).max() < 1e-10  # ... on a smooth curve: a quintic fits to the window's precision
    for s in steps:
        assert 1e-16 < s.jam.energy_per_particle < 2e-16
        ref = energy_forces_pressure(s.packing)
        assert np.max(np.abs(ref.forces)) < 1e-13
        assert -ref.pressure_tensor[0, 1] == pytest.approx(s.shear_stress, rel=1e-6)


def test_a_break_lists_the_contacts_removed_and_added(path_seed1):
    _, path = path_seed1
    assert path.n_changes == 1
    k = int(np.flatnonzero(path.changed)[0])
    before, after = path.steps[k - 1], path.steps[k]
    assert after.gamma == pytest.approx(0.228)
    assert after.removed and after.added
    assert set(after.removed) == before.network.pairs() - after.network.pairs()
    assert set(after.added) == after.network.pairs() - before.network.pairs()
    assert abs(after.phi_j - before.phi_j) > 1e-3  # phi_J jumps at the rearrangement (Figure 2.6(b))


def test_a_family_is_reversible(path_seed1):
    """Shearing back along the same family returns the start's packing."""
    start, path = path_seed1
    back = shear(path.steps[13].packing, -0.002, 0.2)
    assert back.n_changes == 0
    assert back.steps[-1].network.pairs() == Network.of(start.packing).pairs()
    assert back.steps[-1].phi_j == pytest.approx(start.phi_j, abs=1e-9)


def test_both_engines_follow_the_same_family():
    start = jam(n=10, seed=1, gamma=0.2).packing
    a = shear(start, 0.002, 0.21, engine="numba")
    b = shear(start, 0.002, 0.21, engine="lammps")
    assert b.engine == "lammps" and a.engine == "numba"
    assert [s.network.pairs() for s in a.steps] == [s.network.pairs() for s in b.steps]
    assert np.abs(a.phi_j - b.phi_j).max() < 1e-9


@pytest.mark.parametrize("engine", ["numba", "lammps"])
def test_shear_across_the_flip_and_past_one_period(engine):
    """Strain 0.49 -> 0.51 (the reduced cell flips at 1/2) and 1.49 -> 1.51: one path."""
    a = shear(jam(n=10, seed=4, gamma=0.49).packing, 0.005, 0.51, engine=engine)
    b = shear(jam(n=10, seed=4, gamma=1.49).packing, 0.005, 1.51, engine=engine)
    assert np.abs(a.phi_j - b.phi_j).max() < 1e-9
    assert [s.network.pairs() for s in a.steps] == [s.network.pairs() for s in b.steps]
    # gamma = xy / ly with xy = gamma ly: exact only to one ulp ((g l) / l need not be g in float64;
    # a fresh install of 2026-12-02 gave 1.5100000000000002 on the LAMMPS path)
    assert b.steps[-1].packing.box.shear_strain == pytest.approx(1.51, rel=4e-16)


def test_shear_path_file_round_trip(path_seed1, tmp_path):
    _, path = path_seed1
    out = save_shear_path(tmp_path / "s.shear.h5", path, source="x.h5")
    f = ShearFile(out)
    assert len(f) == 16 and f.attrs["n_changes"] == 1 and f.attrs["steps"] == 15
    text = repr(f)
    assert "\n" not in text and len(text) < 200, text
    assert text.startswith(f"ShearFile({str(out)!r}, dim=2, N=") and "steps=15, changes=1)" in text
    assert np.array_equal(f.columns["phi_j"], path.phi_j) and np.array_equal(f.columns["changed"], path.changed)
    k = int(np.flatnonzero(path.changed)[0])
    assert {tuple(r[1:]) for r in f.removed if r[0] == k} == set(path.steps[k].removed)
    assert {tuple(r[1:]) for r in f.added if r[0] == k} == set(path.steps[k].added)
    assert {tuple(c) for c in f.contacts(3)} == path.steps[3].network.pairs()
    again = f.packing(5)
    assert np.allclose(again.box.minimum_image(again.positions - path.steps[5].packing.positions), 0, atol=1e-13)
    assert energy_forces_pressure(again).energy / again.n == pytest.approx(path.steps[5].jam.energy_per_particle,
                                                                              rel=1e-6)


@pytest.mark.parametrize("dgamma,to,message", [
    (0.0, 0.3, "must not be zero"), (math.nan, 0.3, "finite"), (0.01, math.inf, "finite"),
    (-0.01, 0.3, "moves away"), (0.01, 0.1, "moves away"), (0.01, 0.2, "nothing to shear"),
    (1e-9, 0.3, "more than"),
])
def test_bad_shear_strains_are_refused_before_work(dgamma, to, message):
    with pytest.raises(ValueError, match=message):
        shear_strains(0.2, dgamma, to)


def test_a_walled_packing_is_not_sheared():
    walled = jam(n=16, seed=1, walls="y").packing
    with pytest.raises(ValueError, match="takes part in no shear"):
        shear(walled, 0.01, 0.1)


def test_a_step_that_rearranges_everything_is_warned_with_the_count():
    start = jam(n=10, seed=1, gamma=0.2).packing
    with pytest.warns(UserWarning, match=r"rearranged the packing: \d+ of \d+ contacts removed and \d+ added"):
        shear(start, 0.4, 0.6)


def test_shear_command_writes_the_path_and_the_figure(tmp_path, capsys):
    packing = tmp_path / "p.h5"
    assert main(["jam", "--n", "10", "--seed", "1", "--gamma", "0.2", "--out", str(packing), "--quiet"]) == 0
    out = tmp_path / "run"
    assert main(["shear", str(packing), "--dgamma", "-0.002", "--to", "0.19", "--out", str(out), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "in 5 steps" in text and "p.shear.h5" in text
    f = ShearFile(out / "p.shear.h5")
    assert f.columns["gamma"][-1] == 0.19 and f.attrs["dgamma"] == -0.002
    assert f.columns["checks_passed"].all() and len(f.columns["checks_passed"]) == 6
    assert (out / "p.shear.png").stat().st_size > 10_000


def parse_change_line(line):
    """(step, gamma text, removed pairs, added pairs, floaters text) of a --list-changes line."""
    m = re.fullmatch(r"step (\d+)  gamma=(\S+)  removed (.+?)  added (.+?)(?:  floaters (\d+ -> \d+))?", line)
    assert m, line
    pairs = [set() if t == "-" else {tuple(map(int, p.split("-"))) for p in t.split()} for t in m.group(3, 4)]
    return int(m.group(1)), m.group(2), *pairs, m.group(5)


def test_shear_list_changes_prints_each_changed_step_as_the_networks_differ(tmp_path, capsys):
    packing = tmp_path / "p.h5"
    assert main(["jam", "--n", "10", "--seed", "1", "--out", str(packing), "--quiet"]) == 0
    out = tmp_path / "run"
    assert main(["shear", str(packing), "--dgamma", "0.002", "--to", "0.05", "--out", str(out), "--quiet",
                 "--no-figure", "--list-changes"]) == 0
    lines = [line for line in capsys.readouterr().out.splitlines() if line.startswith("step ")]
    f = ShearFile(out / "p.shear.h5")
    assert [parse_change_line(line)[0] for line in lines] == np.flatnonzero(f.columns["changed"]).tolist()
    assert lines, "this start rearranges on the way to 0.05 (a floater appears at step 17)"
    for line in lines:
        k, gamma, removed, added, floaters = parse_change_line(line)
        before, after = ({tuple(c) for c in f.contacts(s).tolist()} for s in (k - 1, k))
        jumped = removed & added  # a pair that moved to another image is both
        assert removed == (before - after) | jumped and added == (after - before) | jumped
        assert gamma == f"{0.002 * k:.6g}"  # 0.006, not 0.006000000000000001
        n_floaters = f.columns["n_floaters"]
        assert floaters == (f"{n_floaters[k - 1]} -> {n_floaters[k]}" if n_floaters[k] != n_floaters[k - 1] else None)
    assert any(line.endswith("floaters 0 -> 1") for line in lines)


@pytest.mark.parametrize("args,message", [
    (["--dgamma", "0", "--to", "0.3"], "must not be zero"),
    (["--dgamma", "nan", "--to", "0.3"], "finite"),
    (["--dgamma", "-0.01", "--to", "0.3"], "moves away"),
    (["--dgamma", "0.01", "--to", "inf"], "finite"),
])
def test_shear_command_bad_input_one_line_error(tmp_path, capsys, args, message):
    packing = tmp_path / "p.h5"
    assert main(["jam", "--n", "10", "--seed", "1", "--gamma", "0.2", "--out", str(packing), "--quiet"]) == 0
    capsys.readouterr()
    out = tmp_path / "run"
    assert main(["shear", str(packing), *args, "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


@pytest.mark.parametrize("args,message", [
    (["--gamma", "nan"], "finite"), (["--gamma", "inf"], "finite"),
    (["--gamma", "0.2", "--walls", "y"], "takes part in no shear"),
    (["--gamma", "0.2", "--pressure", "1e-4"], "use one of them"),
])
def test_jam_command_gamma_bad_input_one_line_error(tmp_path, capsys, args, message):
    out = tmp_path / "x.h5"
    assert main(["jam", "--n", "10", "--quiet", "--out", str(out), *args]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_shear_step_checks_record_the_tolerance_the_minimiser_ran_with(monkeypatch):
    """``jamflow shear`` checks every step with the tolerance the shear's minimisations used:
    the shape's (ellipses: base 5e-13), not the disks' 1e-14."""
    from pathlib import Path
    from types import SimpleNamespace

    import jamflow.mechanics.checks as checks
    from jamflow.cli.commands.shear import step_checks
    from jamflow.protocols.settings import CompressionSettings

    p = load_packing(Path(__file__).parent / "data" / "ellipse1.5_n16_s0.h5")
    seen = []
    monkeypatch.setattr(checks, "check_packing", lambda packing, v, f, v_tol, ftol: seen.append(ftol)
                        or SimpleNamespace(passed=True))
    settings = CompressionSettings()
    step = SimpleNamespace(packing=p, jam=SimpleNamespace(energy_per_particle=1.5e-16, max_force=1e-13))
    assert step_checks(SimpleNamespace(steps=[step]), settings).tolist() == [True]
    assert seen == [settings.minimizer.force_tol_for(p)] and seen[0] >= 5e-13
