"""Particle-shape annealing (chapter section 2.3.3): the step sequence, the growth
step (phi kept, random directors only from a round start), `jamflow anneal` end to end (every
step recorded, the last packing checked, by the independent brute-force energy too), bad input
refused before any work."""

import numpy as np
import pytest

from jamflow.mechanics.contacts import Contacts
from jamflow.analysis.independent import independent_check
from jamflow.cli.app import main
from jamflow.io.packing_file import load_packing, read_protocol, read_table
from jamflow.protocols.anneal import STEP_COLUMNS, _grown, anneal_alphas, check_anneal
from jamflow.model.shapes import Ellipsoid


@pytest.fixture(scope="module")
def disks(tmp_path_factory):
    path = tmp_path_factory.mktemp("anneal") / "disks.h5"
    assert main(["jam", "--quiet", "--n", "16", "--sizes", "bi:1.4:0.6667", "--seed", "2", "--out", str(path)]) == 0
    return path


@pytest.mark.parametrize("alpha0,target,dalpha,expected", [
    (1.0, 1.2, 0.05, [1.05, 1.1, 1.15, 1.2]),
    (1.0, 1.12, 0.05, [1.05, 1.1, 1.12]),  # a shorter last step ends exactly at the target
    (1.0, 0.9, 0.05, [0.95, 0.9]),  # oblate spheroids: down from 1
    (1.6, 2.0, 0.2, [1.8, 2.0]),  # continuing from ellipses
])
def test_anneal_alphas(alpha0, target, dalpha, expected):
    assert anneal_alphas(alpha0, target, dalpha).tolist() == expected


def test_growth_keeps_phi_and_draws_directors_only_from_round_particles(disks):
    start = load_packing(disks)
    rng = np.random.default_rng(0)
    grown = _grown(start, 1.05, "exact", rng)
    assert grown.shape == Ellipsoid(1.05) and grown.phi == pytest.approx(start.phi, rel=1e-14)
    # area grows by 1.05 at fixed b, so the box side grows by sqrt(1.05), positions with it
    np.testing.assert_allclose(grown.positions, start.positions * np.sqrt(1.05), rtol=1e-14)
    assert np.ptp(grown.orientations) > 1.0  # directions drawn at random, not one for all
    again = _grown(grown, 1.1, "exact", rng)
    np.testing.assert_array_equal(again.orientations, grown.orientations)  # later steps keep them


def test_an_aligned_first_step_turns_every_director_along_x(disks, tmp_path, capsys):
    """--orientations aligned (Figure 2.23(c)): the first step's directors all along x
    (P2 = 1), recorded in the file; an input that already has directions is refused."""
    start = load_packing(disks)
    grown = _grown(start, 1.05, "exact", np.random.default_rng(0), "aligned")
    np.testing.assert_array_equal(grown.orientations, np.zeros(start.n))
    assert grown.metadata["orientations"] == "aligned"
    out = tmp_path / "aligned.h5"
    assert main(["anneal", str(disks), "--to", "1.1", "--dalpha", "0.05", "--orientations", "aligned", "--quiet",
                 "--out", str(out)]) == 0
    assert read_table(out, "anneal")["checks_passed"].all() and read_protocol(out)["anneal_orientations"] == "aligned"
    assert load_packing(out).metadata["orientations"] == "aligned"
    assert main(["anneal", str(out), "--to", "1.2", "--dalpha", "0.05", "--orientations", "aligned", "--quiet",
                 "--out", str(tmp_path / "again.h5")]) == 2
    assert "keep their own: leave --orientations out" in capsys.readouterr().err
    with pytest.raises(ValueError, match="--orientations 'sideways' is not one of random, aligned"):
        check_anneal(start, 1.5, 0.05, None, "sideways")


def test_a_nematic_first_step_draws_directors_in_a_cone_about_x(disks, tmp_path, capsys, monkeypatch):
    """--orientations nematic:S: the first step's directors uniform in [-D, D] about x
    with sin(2D) / (2D) = S (rotations.cone_half_angle), recorded; nematic:1 is aligned; a bad S
    is refused before work with one line."""
    import jamflow.protocols.anneal as anneal
    from jamflow.model.shapes.rotations import cone_half_angle

    start = load_packing(disks)
    grown = _grown(start, 1.05, "exact", np.random.default_rng(0), "nematic:0.5")
    half = cone_half_angle(0.5)
    assert np.sin(2 * half) / (2 * half) == pytest.approx(0.5, abs=1e-14)
    assert np.all(np.abs(grown.orientations) <= half) and np.ptp(grown.orientations) > 0.5 * half
    assert grown.metadata["orientations"] == "nematic:0.5"
    one = _grown(start, 1.05, "exact", np.random.default_rng(0), "nematic:1")
    np.testing.assert_array_equal(one.orientations, np.zeros(start.n))
    monkeypatch.setattr(anneal, "jam", lambda *a, **k: pytest.fail("work started"))
    assert main(["anneal", str(disks), "--to", "1.1", "--dalpha", "0.05", "--orientations", "nematic:2", "--quiet",
                 "--out", str(tmp_path / "x.h5")]) == 2
    err = capsys.readouterr().err
    assert "--orientations 'nematic:2' is not one of random, aligned, nematic:S" in err and len(err.splitlines()) == 1


def test_cli_anneal_records_every_step_and_writes_a_checked_packing(disks, tmp_path, capsys):
    out = tmp_path / "annealed.h5"
    assert main(["anneal", str(disks), "--to", "1.1", "--dalpha", "0.05", "--seed", "4", "--quiet",
                 "--out", str(out)]) == 0
    assert "annealed 1 -> 1.1 in 2 steps" in capsys.readouterr().out
    steps = read_table(out, "anneal")
    assert sorted(steps) == sorted(STEP_COLUMNS)
    np.testing.assert_array_equal(steps["alpha"], [1.0, 1.05, 1.1])
    assert steps["phi_j"][0] == load_packing(disks).phi and steps["minimizations"][0] == 0
    assert np.all(steps["checks_passed"]) and np.all(steps["minimizations"][1:] > 0)
    assert np.all(1e-16 < steps["energy_per_particle"][1:]) and np.all(steps["energy_per_particle"][1:] < 2e-16)
    final = load_packing(out)
    assert final.shape == Ellipsoid(1.1) and final.phi == steps["phi_j"][-1]
    c = Contacts().compute(final)  # the table's <z> is the final packing's
    assert steps["mean_z"][-1] == pytest.approx(c.mean_z) and steps["n_floaters"][-1] == c.n_floaters
    check = independent_check(final)  # brute-force contact distance: forces and torques balanced
    assert check.max_force() < 1e-12 and check.max_generalized_torque() < 1e-12
    assert 1e-16 < check.energy_per_particle < 2e-16
    protocol = read_protocol(out)
    assert (protocol["anneal_to"], protocol["anneal_dalpha"], protocol["anneal_seed"]) == (1.1, 0.05, 4)


@pytest.mark.parametrize("args,message", [
    (["--to", "nan", "--dalpha", "0.05"], "--to must be a finite number > 0"),
    (["--to", "0", "--dalpha", "0.05"], "--to must be a finite number > 0"),
    (["--to", "1.5", "--dalpha", "-0.1"], "--dalpha must be a finite number > 0"),
    (["--to", "1.5", "--dalpha", "inf"], "--dalpha must be a finite number > 0"),
    (["--to", "1.1", "--dalpha", "0.5"], "larger than the whole change"),
    (["--to", "1", "--dalpha", "0.05"], "already at aspect ratio 1"),
    (["--to", "0.8", "--dalpha", "0.05"], "an ellipse with ALPHA = 0.8 < 1"),
    (["--to", "1.5", "--dalpha", "0.05", "--contact", "gaussian"], "gaussian"),
    (["--to", "1.5", "--dalpha", "0.05", "--vtol", "-1"], "--vtol must be a positive number"),
    (["--to", "1.5", "--dalpha", "0.05", "--seed", "-3"], "--seed must be a non-negative integer"),
])
def test_bad_anneal_input_gives_clear_error_before_work(disks, tmp_path, capsys, monkeypatch, args, message):
    import jamflow.protocols.anneal as anneal

    monkeypatch.setattr(anneal, "jam", lambda *a, **k: pytest.fail("work started"))
    out = tmp_path / "x.h5"
    assert main(["anneal", str(disks), "--quiet", "--out", str(out), *args]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_anneal_refuses_a_missing_input_and_a_walled_packing(tmp_path, capsys):
    out = tmp_path / "x.h5"
    assert main(["anneal", str(tmp_path / "none.h5"), "--to", "1.5", "--dalpha", "0.1", "--out", str(out)]) == 2
    assert "none.h5" in capsys.readouterr().err
    walled = tmp_path / "walled.h5"
    assert main(["jam", "--quiet", "--n", "16", "--walls", "y", "--out", str(walled)]) == 0
    assert main(["anneal", str(walled), "--to", "1.5", "--dalpha", "0.1", "--out", str(out)]) == 2
    assert "periodic box" in capsys.readouterr().err and not out.exists()


def test_cli_anneals_spheres_into_oblate_spheroids(tmp_path):
    spheres, out = tmp_path / "spheres.h5", tmp_path / "oblate.h5"
    assert main(["jam", "--quiet", "--dim", "3", "--n", "16", "--sizes", "mono", "--seed", "1", "--out", str(spheres)]) == 0
    assert main(["anneal", str(spheres), "--to", "0.9", "--dalpha", "0.05", "--quiet", "--out", str(out)]) == 0
    steps = read_table(out, "anneal")
    np.testing.assert_array_equal(steps["alpha"], [1.0, 0.95, 0.9])
    assert np.all(steps["checks_passed"]) and load_packing(out).shape == Ellipsoid(0.9)
    check = independent_check(load_packing(out))
    assert check.max_force() < 1e-12 and check.max_generalized_torque() < 1e-12
