"""Onset statistics (W(N), nu, phi_inf) and modes / analyze over an ensemble store on Dask."""

import csv
import subprocess
import sys

import h5py
import numpy as np
import pytest

from jamflow.cli.commands.onsets import report_text, write_table
from jamflow.ensemble import Store, run_ensemble
from jamflow.ensemble.onsets import onset_statistics, width_chi2

JAMFLOW = [sys.executable, "-m", "jamflow.cli"]


def synthetic_rows(nu=0.5, phi_inf=0.84, shift=0.3, amplitude=0.2, count=400, sizes=(32, 64, 128, 256, 512), seed=1):
    """phi_J ~ Normal(phi_inf - shift N^-nu, amplitude N^-nu): the scaling the fits assume."""
    rng = np.random.default_rng(seed)
    rows = []
    for n in sizes:
        for k, phi in enumerate(rng.normal(phi_inf - shift * n**-nu, amplitude * n**-nu, count)):
            rows.append(dict(n=n, seed=k, status="ok", dim=2, phi_j=phi, mean_z=4.0, n_contacts=2 * (n - 1) + 1,
                             floaters=0))
    return rows + [dict(n=32, seed=count, status="failed", dim=2)]


def test_fits_recover_the_exponent_and_the_limit_of_synthetic_onsets():
    res = onset_statistics(synthetic_rows(), n_bootstrap=400)
    assert abs(res.nu.value - 0.5) < 3 * res.nu.err and res.nu.err < 0.05
    assert abs(res.phi_inf.value - 0.84) < 3 * res.phi_inf.err and res.phi_inf.err < 0.003
    assert res.sizes[0].failed == 1 and all(s.isostatic.all() for s in res.sizes)
    for s in res.sizes:  # bootstrap error of a normal sample's sd against its closed form sd / sqrt(2 (n - 1))
        assert s.width_err == pytest.approx(s.width / np.sqrt(2 * (s.count - 1)), rel=0.2)
        assert s.mean_phi_err == pytest.approx(s.width / np.sqrt(s.count))


def test_chi2_of_the_width_fit_measures_how_well_the_power_law_fits():
    ns = np.array([64.0, 128, 256, 512])
    law = 0.1 * ns**-0.5
    assert width_chi2(ns, law, 0.05 * law, 0.5, 0.1) == pytest.approx(0, abs=1e-20)
    off = law * [1, 1, np.exp(0.15), 1]  # one width 3 errors (5 % each, in log W) off the law
    assert width_chi2(ns, off, 0.05 * off, 0.5, 0.1) == pytest.approx(3**2 / (4 - 2), rel=1e-12)
    res = onset_statistics(synthetic_rows(), n_bootstrap=100)  # widths that follow the law within their errors
    assert 0 < res.width_chi2 < 4
    kinked = [r for r in synthetic_rows() if r["n"] != 128] + synthetic_rows(amplitude=0.4, sizes=(128,))[:-1]
    assert onset_statistics(kinked, n_bootstrap=100).width_chi2 > 50


def write_onsets_table(path, **synthetic):
    write_table(path, onset_statistics(synthetic_rows(**synthetic), n_bootstrap=100))
    return path


def test_widths_command_draws_two_tables_on_one_plot(tmp_path):
    a = write_onsets_table(tmp_path / "a.csv")
    b = write_onsets_table(tmp_path / "b.csv", nu=0.35, sizes=(64, 128, 256), seed=2)
    fig = tmp_path / "w.png"
    done = subprocess.run(JAMFLOW + ["widths", str(a), str(b), "--labels", "2D", "3D", "--figure", str(fig)],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    for label, table in (("2D", a), ("3D", b)):
        row = next(csv.DictReader(open(table)))
        assert f"{label}: " in done.stdout and f"nu = {float(row['nu']):.3f} +- {float(row['nu_err']):.3f}" in done.stdout
        chi2 = float(row["nu_chi2_dof"])  # the table's, from onset_statistics; the command refits the rows
        assert f"chi2/dof = {chi2:.2f}" in done.stdout and 0 < chi2 < 4
    assert "N = 64, 128, 256;" in done.stdout and fig.stat().st_size > 10_000


def test_onsets_report_says_what_one_or_two_sizes_cannot_give():
    one = report_text(onset_statistics(synthetic_rows(sizes=(64,), count=50), n_bootstrap=20))
    assert "nan" not in one
    assert "nu needs packings at two or more N, this store has 1 (N = 64)" in one
    assert "phi_inf needs three or more N" in one
    two = report_text(onset_statistics(synthetic_rows(sizes=(64, 128), count=50), n_bootstrap=20))
    assert "nan" not in two and "nu = " in two and "chi2/dof of the power law = none (needs three or more N)" in two
    assert "phi_inf needs three or more N, this store has 2 (N = 64, 128)" in two
    many = report_text(onset_statistics(synthetic_rows(count=50), n_bootstrap=20))
    assert "nan" not in many and "nu = " in many and "phi_inf = " in many


def test_widths_command_refuses_what_is_not_an_onsets_table(tmp_path):
    a = write_onsets_table(tmp_path / "a.csv")
    edited = tmp_path / "edited.csv"
    edited.write_text(a.read_text().replace(next(csv.DictReader(open(a)))["nu"], "0.5"))
    (tmp_path / "other.csv").write_text("n,phi_j\n64,0.64\n")
    for args, message in (([str(edited)], "is not the fit of its rows"), ([str(tmp_path / "other.csv")], "no column width"),
                          ([str(a), "--labels", "x", "y"], "2 label(s) for 1 table(s)"),
                          ([str(tmp_path / "none.csv")], "no such table")):
        done = subprocess.run(JAMFLOW + ["widths", *args, "--figure", str(tmp_path / "w.png")], capture_output=True,
                              text=True)
        assert done.returncode == 2 and message in done.stderr and len(done.stderr.splitlines()) == 1, done.stderr
    assert not (tmp_path / "w.png").exists()


def test_too_few_packings_are_refused():
    with pytest.raises(ValueError, match="fewer than 3 packings"):
        onset_statistics(synthetic_rows(count=2), n_bootstrap=50)
    with pytest.raises(ValueError, match="no finished packings"):
        onset_statistics([dict(n=8, status="failed")])


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    from distributed import Client

    out = tmp_path_factory.mktemp("ens") / "store"
    with Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=":0") as client:
        run_ensemble(out, "0:6", [8, 12, 16], client=client, progress=False)
    return out


def test_onsets_command_writes_table_and_figure(store):
    done = subprocess.run(JAMFLOW + ["onsets", str(store), "--bootstrap", "50"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "nu =" in done.stdout and "phi_inf =" in done.stdout and "published large-N value about 0.842" in done.stdout
    rows = list(csv.DictReader(open(store / "onsets.csv")))
    assert [int(r["n"]) for r in rows] == [8, 12, 16] and all(int(r["packings"]) == 6 for r in rows)
    phi = [float(r["phi_j"]) for r in Store(store).read_summary() if r["n"] == "12"]
    assert float(rows[1]["mean_phi_j"]) == pytest.approx(np.mean(phi)) and float(rows[1]["width"]) == pytest.approx(
        np.std(phi, ddof=1))
    assert (store / "onsets.png").stat().st_size > 10_000


def test_analyze_over_a_store_on_dask_equals_the_serial_pooling(store, tmp_path):
    for name, extra in (("serial", []), ("dask", ["--workers", "1"])):
        done = subprocess.run(JAMFLOW + ["analyze", str(store), "--out", str(tmp_path / f"{name}.h5")] + extra,
                              capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
        assert "18 packing(s)" in done.stdout
    with h5py.File(tmp_path / "serial.h5") as a, h5py.File(tmp_path / "dask.h5") as b:
        for key in ("rdf/counts", "rdf/ideal", "rdf/g", "rdf/partial", "sk/k", "sk/s", "sk/n_vectors", "order/Q6_local",
                    "order/G"):
            np.testing.assert_allclose(b[key][...], a[key][...], rtol=1e-12, atol=1e-14, err_msg=key)


def test_modes_over_a_store_on_dask(store):
    done = subprocess.run(JAMFLOW + ["modes", str(store), "--workers", "1"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "18 packing(s)" in done.stdout and (store / f"{store.name}.modes.png").exists()
    assert len(list(store.glob("*.modes.h5"))) == 18
    again = subprocess.run(JAMFLOW + ["modes", str(store), "--no-figure"], capture_output=True, text=True)
    assert again.returncode == 0 and "18 packing(s)" in again.stdout  # the results files are not taken for packings
