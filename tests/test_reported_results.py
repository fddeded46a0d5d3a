"""What is printed and stored about a result holds, or says why not (docs/hardening.md has the
catalogue): modes and analyze warn about a packing that is not at an energy minimum, and not about
a jammed one; moduli warns when no amplitude of a sweep stayed linear; jam at one pressure reports
no extrapolated phi_J; an ensemble of piles records each pile's own phi_J, and onsets refuses a
distribution of zero width."""

import h5py
import numpy as np
import pytest
from conftest import no_traceback

from jamflow.cli.app import main
from jamflow.io.packing_file import load_packing, read_attrs, save_packing


@pytest.fixture(scope="module")
def squeezed_file(packing_file, tmp_path_factory):
    p = load_packing(packing_file)
    out = tmp_path_factory.mktemp("squeezed") / "squeezed.h5"
    return save_packing(out, p.scaled_to_phi(p.phi / 0.95**2))  # box 5% smaller: max force ~0.05


def test_modes_warns_when_not_at_a_minimum(squeezed_file, capsys):
    """Was: a stability class without saying the state is not force balanced."""
    assert main(["modes", str(squeezed_file), "--no-figure"]) == 0
    out, err = capsys.readouterr()
    assert "warning" in err and "not at an energy minimum" in err and "[NOT FORCE BALANCED]" in out
    with h5py.File(squeezed_file.with_name("squeezed.modes.h5")) as f:
        assert not f.attrs["force_balanced"] and not f["checks"].attrs["passed"]


def test_modes_on_a_jammed_packing_does_not_warn(packing_file, capsys):
    assert main(["modes", str(packing_file), "--no-figure"]) == 0
    out, err = capsys.readouterr()
    assert "warning" not in err and "NOT FORCE BALANCED" not in out
    with h5py.File(packing_file.with_name("p.modes.h5")) as f:
        assert f.attrs["force_balanced"]


def test_analyze_warns_when_not_at_a_minimum(squeezed_file, packing_file, tmp_path, capsys):
    out = tmp_path / "s.h5"
    assert main(["analyze", str(packing_file), str(squeezed_file), "--out", str(out), "--r-min", "1.3"]) == 0
    assert "squeezed.h5 is not at an energy minimum" in capsys.readouterr().err
    with h5py.File(out) as f:
        assert list(f["order/force_balanced"][...]) == [1, 0]


def test_moduli_warns_when_a_sweep_has_no_linear_amplitude(tmp_path, capsys, packing_file):
    # was: "B = nan +- nan", exit 0, nothing said (an onset packing yields at the first amplitude 1e-6)
    source = tmp_path / "p.h5"
    source.write_bytes(packing_file.read_bytes())
    args = ["moduli", str(source), "--min-amplitude", "1e-6", "--max-amplitude", "1e-5", "--per-decade", "1"]
    assert main([*args, "--quiet", "--no-figure"]) == 0
    err = capsys.readouterr().err
    assert "no bulk amplitude stayed linear" in err and "--min-amplitude" in err


def test_jam_at_one_pressure_reports_no_extrapolated_onset(tmp_path, capsys):
    # was: "phi_J(P->0) = 0.8763408138", the phi at P = 1e-2 itself (one pressure extrapolates nothing)
    out = tmp_path / "p.h5"
    assert main(["jam", "--n", "32", "--pressure", "1e-2", "--out", str(out), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "phi_J(P->0) n/a: one pressure" in text and "phi_J(P->0) =" not in text
    attrs = read_attrs(out)
    assert np.isnan(attrs["phi_j"]) and attrs["phi"] > 0.85  # the file: phi at P, no phi_J
    several = tmp_path / "p6.h5"
    assert main(["jam", "--n", "32", "--pressure", "1e-6", "--out", str(several), "--quiet"]) == 0
    printed = float(capsys.readouterr().out.split("phi_J(P->0) = ")[1].split()[0])
    attrs = read_attrs(several)
    assert attrs["phi_j"] == pytest.approx(printed, abs=1e-10) and attrs["phi_j"] < attrs["phi"]


def test_ensemble_of_piles_records_each_piles_fraction_and_onsets_refuse_a_zero_width(tmp_path, capsys):
    # was: summary.csv phi_j = phi0 = 0.5 for every pile (sd 0), while jam printed each pile's own
    # fraction; `jamflow onsets` then printed LAPACK noise and "SVD did not converge"
    from jamflow.ensemble import Store

    store = tmp_path / "piles"
    args = ["--n", "16", "--gravity", "1e-3", "--walls", "y", "--quiet"]
    assert main(["ensemble", "--seeds", "0:3", "--workers", "1", "--out", str(store), *args]) == 0
    rows = sorted(Store(store).read_summary(), key=lambda r: int(r["seed"]))
    capsys.readouterr()
    for row in rows:
        out = tmp_path / f"jam{row['seed']}.h5"
        assert main(["jam", "--seed", row["seed"], "--out", str(out), *args]) == 0
        printed = float(capsys.readouterr().out.split("phi_J = ")[1].split()[0])
        assert float(row["phi_j"]) == pytest.approx(printed, abs=1e-9)  # what jam reports: the pile's fraction
        assert float(row["phi"]) == 0.5 and float(row["phi_j"]) > 0.6  # the box's phi is the start's
    assert np.std([float(r["phi_j"]) for r in rows]) > 1e-3
    # a store summarised the old way (every phi_j the same): one clear line, no numerical noise
    from jamflow.ensemble.onsets import onset_statistics

    with pytest.raises(ValueError, match="N = 16: all 3 packings have phi_J = 0.5, a distribution of zero width"):
        onset_statistics([{**r, "phi_j": "0.5"} for r in rows], n_bootstrap=50)
    with pytest.raises(ValueError, match="N = 16: 1 of 3 packings have no phi_J"):
        onset_statistics([{**r, "phi_j": "nan" if r["seed"] == "0" else r["phi_j"]} for r in rows], n_bootstrap=50)


def test_onsets_command_refuses_a_zero_width_store_in_one_line(tmp_path, capsys):
    import csv

    from jamflow.ensemble import Store

    store = tmp_path / "flat"
    assert main(["ensemble", "--seeds", "0:3", "--workers", "1", "--n", "16", "--out", str(store), "--quiet"]) == 0
    rows = Store(store).read_summary()
    with (store / "summary.csv").open("w", newline="") as fh:  # the summary an older jamflow wrote for piles
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows({**r, "phi_j": "0.5"} for r in rows)
    capsys.readouterr()
    code = main(["onsets", str(store)])
    err = capsys.readouterr().err
    assert code == 2 and no_traceback(err) and len(err.strip().splitlines()) == 1 and "zero width" in err
    assert "SVD" not in err and not (store / "onsets.csv").exists()
