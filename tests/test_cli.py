"""The command line: a working default and clear errors before any work."""

import pytest

from jamflow.cli import main
from jamflow.io import load_packing


def test_jam_writes_a_packing_and_a_summary(tmp_path, capsys):
    out = tmp_path / "p.h5"
    assert main(["jam", "--n", "32", "--seed", "3", "--out", str(out), "--quiet"]) == 0
    line = capsys.readouterr().out
    assert "phi_J =" in line and str(out) in line
    assert load_packing(out).n == 32


@pytest.mark.parametrize("args,message", [
    (["--n", "1"], "n must be"),
    (["--phi0", "1.2"], "phi0"),
    (["--phi0", "0.95"], "densest"),
    (["--vtol=-1e-16"], "vtol"),
    (["--dphi0", "nan"], "dphi0"),
    (["--dim", "3", "--phi0", "0.8"], "densest"),
    (["--sizes", "bi:0.5:0.5"], "RATIO"),
    (["--potential", "spring:0.5"], "alpha"),
    (["--out", "/nonexistent-dir/p.h5"], "does not exist"),
    (["--md-damping", "pairwise"], "applies to --minimizer md only"),
])
def test_bad_input_gives_clear_error(tmp_path, capsys, args, message):
    argv = ["jam", "--quiet", *args] + ([] if "--out" in args else ["--out", str(tmp_path / "x.h5")])
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not (tmp_path / "x.h5").exists()


def test_jam_with_pairwise_damped_md_records_it(tmp_path, capsys):
    import h5py

    out = tmp_path / "p.h5"
    assert main(["jam", "--n", "16", "--seed", "3", "--minimizer", "md", "--md-damping", "pairwise",
                 "--out", str(out), "--quiet"]) == 0
    assert "phi_J =" in capsys.readouterr().out
    with h5py.File(out) as f:
        assert f["protocol"].attrs["minimizer_md_damping"] == "pairwise"
        assert f["protocol"].attrs["minimizer_method"] == "md"
