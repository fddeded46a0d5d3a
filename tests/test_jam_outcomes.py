"""What a jam run ends in (docs/hardening.md has the catalogue): a packing that passed its checks,
stored with them in the file (repulsive LJ from the command line too, at fixed volume and at a
target pressure), or an exit code of its own with the cause and the remedy: 3 jamming failed or the
packing failed its checks (nothing written), 4 LAMMPS failed, 5 the LAMMPS plugin could not be
built. ``jam --help`` says the engines reach different minima."""

import pytest
from conftest import no_traceback, run_jam

import jamflow
from jamflow.cli.app import EXIT_JAMMING, EXIT_LAMMPS, EXIT_PLUGIN, main
from jamflow.io.packing_file import load_packing, read_attrs, read_checks


def test_jam_stores_its_checks(packing_file):
    checks = read_checks(packing_file)
    assert checks.passed and checks.in_window and checks.force_ratio < 1e-4 and checks.excess_contacts >= 0
    assert checks.v_tol == 1e-16 and checks.energy_per_particle == read_attrs(packing_file)["energy_per_particle"]


@pytest.mark.parametrize("dim", [2, 3])
def test_jam_repulsive_lj_from_the_command_line(tmp_path, capsys, dim):
    """Was: never worked (the CLI's start skipped the overlap removal)."""
    out = tmp_path / "rlj.h5"
    code, err = run_jam(tmp_path, capsys, "--potential", "rlj", "--dim", str(dim), "--n", "32" if dim == 2 else "16",
                        "--out", str(out))
    assert code == 0, err
    p = load_packing(out)
    assert p.potential.spec == "rlj" and read_checks(out).passed


def test_jam_repulsive_lj_at_a_target_pressure(tmp_path, capsys):
    """Was: exit 2 'array is too big; arr.size * arr.dtype.itemsize is larger than the maximum
    possible size' (numpy's ValueError shown as bad input): the random start's deep overlaps gave
    RLJ forces that blew the box up. The start is now relaxed first, as at fixed volume."""
    out = tmp_path / "rlj.h5"
    code, err = run_jam(tmp_path, capsys, "--pressure", "1e-3", "--potential", "rlj", "--n", "32", "--out", str(out))
    assert code == 0, err
    assert load_packing(out).potential.spec == "rlj" and read_checks(out).passed
    assert abs(read_attrs(out)["pressure"] / 1e-3 - 1) < 1e-6


def test_a_packing_that_fails_its_checks_is_not_written(tmp_path, capsys, monkeypatch, packing_file):
    """Was: written silently (spring:1.5: net forces 0.4 of the contact forces; vtol 1e-30)."""
    good = jamflow.jam(n=32, seed=3)
    squeezed = good.packing.scaled_to_phi(good.phi_j / 0.95**2)
    fake = type(good)(**{**good.__dict__, "packing": squeezed})
    monkeypatch.setattr("jamflow.protocols.spec.jam", lambda *a, **k: fake)
    out = tmp_path / "p.h5"
    out.write_bytes(packing_file.read_bytes())
    code, err = run_jam(tmp_path, capsys, "--n", "32", "--seed", "3", "--out", str(out))
    assert code == EXIT_JAMMING and no_traceback(err)
    assert "failed its checks: not at an energy minimum" in err and "not at an energy minimum" in err and "Nothing was written" in err
    assert out.read_bytes() == packing_file.read_bytes()


def test_jamming_failed_exits_3_with_its_remedy(tmp_path, capsys):
    """Was: exit 1 with a traceback."""
    code, err = run_jam(tmp_path, capsys, "--potential", "rlj", "--n", "16", "--phi0", "0.88",
                        "--out", str(tmp_path / "x.h5"))
    assert code == EXIT_JAMMING and no_traceback(err) and "phi0 is above jamming; use a lower phi0" in err


def test_lammps_failure_exits_4(tmp_path, capsys, monkeypatch):
    """Was: exit 1 with a traceback."""
    from jamflow.engines.lammps.engine import LammpsError

    def fail(*a, **k):
        raise LammpsError("run 0", "ERROR: Lost atoms: original 16 current 4")

    monkeypatch.setattr("jamflow.protocols.spec.jam", fail)
    code, err = run_jam(tmp_path, capsys, "--n", "16", "--out", str(tmp_path / "x.h5"))
    assert code == EXIT_LAMMPS and no_traceback(err) and "Lost atoms" in err and "diverged" in err


@pytest.mark.parametrize("cxx,message", [("/nonexistent/g++", "CXX=/nonexistent/g++ does not name an executable"),
                                         ("false", "compiling the jamflow LAMMPS plugin failed")])
def test_a_bad_cxx_exits_5_naming_it(tmp_path, capsys, monkeypatch, cxx, message):
    """Was: 'no C++ compiler found' although g++ is installed, then 12x slower on lepton;
    a compiler error was a RuntimeError traceback with exit 1."""
    monkeypatch.setenv("JAMFLOW_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("CXX", cxx)
    code, err = run_jam(tmp_path, capsys, "--n", "16", "--potential", "hertz", "--engine", "lammps",
                        "--out", str(tmp_path / "x.h5"))
    assert code == EXIT_PLUGIN and message in err and "Traceback" not in err


def test_help_says_the_engines_differ(capsys):
    """Was: README and --help implied the engines reach the same minima."""
    with pytest.raises(SystemExit):
        main(["jam", "--help"])
    assert "different" in " ".join(capsys.readouterr().out.split())
