"""File names LAMMPS reads and writes (docs/hardening.md has the catalogue): a $TMPDIR with a space
or a non-ASCII character, names quoted in LAMMPS commands or refused, an emitted deck with a space
in its name, and an --out whose name an emitted deck cannot write."""

import os
import subprocess

import pytest
from conftest import JAMFLOW

from jamflow.cli.app import main
from jamflow.io.packing_file import read_checks


@pytest.mark.parametrize("tmpdir", ["a b", "a b/é"])
def test_lammps_with_a_tmpdir_holding_a_space_or_non_ascii(tmp_path, tmpdir):
    """Was: exit 4 'LAMMPS rejected read_data /tmp/a b/é/...' and advice to reinstall LAMMPS: the
    path was unquoted (a space) and LAMMPS's parser drops bytes of non-ASCII characters."""
    scratch = tmp_path / tmpdir
    scratch.mkdir(parents=True)
    out = tmp_path / "p.h5"
    done = subprocess.run([*JAMFLOW, "jam", "--engine", "lammps", "--n", "16", "--quiet", "--out", str(out)],
                          env={**os.environ, "TMPDIR": str(scratch)}, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert read_checks(out).passed and list(scratch.iterdir()) == []


def test_lammps_file_names_are_quoted_or_refused():
    from jamflow.engines.lammps.library import lammps_quote

    assert lammps_quote("/tmp/a b/x.data") == '"/tmp/a b/x.data"'
    assert lammps_quote('/tmp/"q"/x') == "'/tmp/\"q\"/x'"
    with pytest.raises(ValueError, match="non-ASCII"):
        lammps_quote("/tmp/é/x.data")


def test_an_emitted_deck_with_a_space_in_its_name_runs(tmp_path, capsys):
    """Was: `variable data index jam deck.start.data` (an index variable of two values): lmp read
    the file 'jam' and failed."""
    from jamflow.decks.jam import run_deck

    deck = tmp_path / "dir" / "jam deck.lmp"
    deck.parent.mkdir()
    assert main(["jam", "--n", "16", "--protocol", "chapter", "--emit-deck", str(deck),
                 "--out", str(tmp_path / "jammed.h5")]) == 0
    assert "run: cd " in capsys.readouterr().out
    result = run_deck(deck.parent, deck=deck, timeout=300)
    assert result.packing.n == 16 and (deck.parent / "jammed.data").exists()


def test_an_emitted_deck_refuses_an_out_that_lammps_cannot_write(tmp_path, capsys):
    code = main(["jam", "--n", "16", "--protocol", "chapter", "--emit-deck", str(tmp_path / "d.lmp"),
                 "--out", str(tmp_path / "my run.h5")])
    err = capsys.readouterr().err
    assert code == 2 and "choose an --out without them" in err and list(tmp_path.iterdir()) == []
