"""Spectrum, density of states and stability class (chapter section 3).

Closed forms: the phonon spectrum of a compressed triangular lattice, a two-particle system,
a honeycomb network with an extra zero mode per cell (locally stable, chapter Figure 2.15b).
Second implementations: the energy change along a displacement against the all-pairs numpy
energy difference and against the quadratic form u^T M u / 2; dense against sparse solver.
Published facts: jammed frictionless disks are isostatic after floater removal with exactly d
zero modes (chapter section 4.1; O'Hern et al., Phys. Rev. E 68, 011306 (2003))."""

import argparse
from itertools import product

import h5py
import numpy as np
import pytest

from jamflow.mechanics.contacts import Contacts
from jamflow.mechanics.dynamical_matrix import DynamicalMatrix
from jamflow.analysis.modes import (LOCALLY_STABLE, STABLE, UNSTABLE, DensityOfStates, Spectrum, Stability,
                                    energy_change)
from jamflow.model.box import Box
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.model.packing import Packing
from jamflow.model.potentials import RepulsiveLJ, Spring
from test_contacts import disk_in_vacancy, triangular_lattice
from test_hessian import perturbed_lattice


def honeycomb(nx, ny, bond):
    """Monodisperse honeycomb network (4-site rectangular cell): every disk has three
    contacts at 120 degrees, so none is a floater, but z = 3 < 2d leaves floppy modes."""
    s3 = np.sqrt(3)
    cell = bond * np.array([[0, 0], [s3 / 2, 0.5], [s3 / 2, 1.5], [0, 2]])
    size = bond * np.array([s3, 3.0])
    sites = np.array(list(product(range(nx), range(ny))))
    pos = (sites[:, None, :] * size + cell[None]).reshape(-1, 2)
    return Packing(pos, np.ones(len(pos)), Box(np.diag(size * [nx, ny])))


def triangular_phonons(packing, spacing):
    """Eigenvalues of sum_n K_n (1 - cos k.b_n) over the 6 neighbours b_n, for every wave
    vector allowed by the (tilted) cell, reduced to distinct points of the primitive zone."""
    pot = packing.potential
    v1, v2 = float(pot.dv_dr(spacing, 1.0)), float(pot.d2v_dr2(spacing, 1.0))
    angles = np.arange(6) * np.pi / 3
    bonds = spacing * np.column_stack([np.cos(angles), np.sin(angles)])
    primitive = bonds[[0, 1]]
    inv_t = np.linalg.inv(packing.box.h).T
    seen, values = set(), []
    for m, l in product(range(-12, 13), repeat=2):
        k = 2 * np.pi * inv_t @ [m, l]
        key = tuple(np.round((primitive @ k / (2 * np.pi)) % 1.0, 9) % 1.0)
        if key in seen:
            continue
        seen.add(key)
        d = sum((v2 * np.outer(b, b) / spacing**2 + v1 / spacing * (np.eye(2) - np.outer(b, b) / spacing**2))
                * (1 - np.cos(k @ b)) for b in bonds)
        values.extend(np.linalg.eigvalsh(d))
    assert len(seen) == packing.n  # one wave vector per particle
    return np.sort(values)


@pytest.fixture(scope="module")
def jammed():
    from jamflow.protocols.compression import jam

    return jam(n=64, dim=2, sizes="bi:1.4:0.5", seed=1).packing


@pytest.mark.parametrize("pot", [Spring(2.0), Spring(2.5), RepulsiveLJ()], ids=lambda p: p.spec)
def test_triangular_lattice_spectrum_closed_form(pot):
    spacing = 0.97
    lattice = triangular_lattice(6, 6, spacing, tilt_cells=1)
    p = Packing(lattice.positions, lattice.diameters, lattice.box, pot)
    spec = Spectrum().compute(p)
    expected = triangular_phonons(p, spacing)
    assert spec.complete and spec.dynamical.contacts.n_floaters == 0
    assert np.allclose(spec.eigenvalues, expected, rtol=0, atol=1e-12 * expected.max())
    assert spec.n_zero == 2 and spec.n_negative == 0  # only the two uniform translations
    st = Stability(spectrum=Spectrum()).compute(p, spec)
    assert st.label == STABLE and st.behaviour == "quadratic"
    assert st.mode_eigenvalue == pytest.approx(spec.lowest_nonzero, rel=1e-10)


def test_two_particles_are_unstable_transversally():
    pot = Spring(2.0)
    p = Packing([[3.0, 3.0], [3.9, 3.0]], [1.0, 1.0], Box.cube(6.0, 2), pot)
    spec = Spectrum(dynamical=DynamicalMatrix(remove_floaters=False)).compute(p)
    v1, v2 = float(pot.dv_dr(0.9, 1.0)), float(pot.d2v_dr2(0.9, 1.0))
    assert np.allclose(spec.eigenvalues, sorted([0, 0, 2 * v2, 2 * v1 / 0.9]), atol=1e-14)
    assert spec.n_negative == 1
    st = Stability(spectrum=Spectrum(dynamical=DynamicalMatrix(remove_floaters=False))).compute(p, spec)
    assert st.label == UNSTABLE and st.behaviour == "negative quadratic"
    assert st.mode_eigenvalue == pytest.approx(2 * v1 / 0.9, rel=1e-12)


def test_honeycomb_is_only_locally_stable_with_flat_zero_mode():
    p = honeycomb(4, 3, 1.0 - 1e-12)  # contacts overlap by 1e-12: every stress eigenvalue < e_min
    spec = Spectrum().compute(p)
    c = spec.dynamical.contacts
    assert c.n_floaters == 0 and np.all(c.z == 3) and c.excess_contacts == 72 - 95
    # Maxwell-Calladine count: zero modes = d N - N_c + S = 96 - 72 + 1, S = 1 state of
    # self-stress (equal tension on every bond); the two translations are among them
    assert spec.n_negative == 0 and spec.n_zero == 25 and spec.n_extra_zero == 23
    st = Stability().compute(p, spec)
    assert st.label == LOCALLY_STABLE and st.flat and st.behaviour == "flat"
    # moving far along the mode costs nothing: contacts open (chapter Fig. 2.15c, dashed line)
    far = Stability(deltas=[1e-3, 1e-2, 1e-1]).compute(p, spec)
    assert far.flat and np.all(far.delta_v <= 0)


def test_compressed_honeycomb_is_unstable():
    st = Stability().compute(honeycomb(4, 3, 0.99))
    assert st.label == UNSTABLE and st.n_negative > 0
    assert st.behaviour == "negative quadratic" and st.mode_eigenvalue < 0


@pytest.mark.parametrize("pot", [Spring(2.0), Spring(2.5), RepulsiveLJ()], ids=lambda p: p.spec)
def test_energy_change_matches_direct_difference_and_quadratic_form(pot):
    p = perturbed_lattice(2, seed=4, potential=pot)
    u = np.random.default_rng(0).normal(size=p.positions.shape)
    big = 1e-3 * u
    direct = energy_forces_pressure(p.with_positions(p.positions + big)).energy - energy_forces_pressure(p).energy
    assert energy_change(p, big) == pytest.approx(direct, rel=1e-9)
    # for a tiny displacement the symmetric part is u^T M u / 2 (third order cancels)
    h = DynamicalMatrix(remove_floaters=False).compute(p).matrix
    tiny = 1e-7 * u
    sym = 0.5 * (energy_change(p, tiny) + energy_change(p, -tiny))
    assert sym == pytest.approx(0.5 * tiny.ravel() @ (h @ tiny.ravel()), rel=1e-6)


def test_jammed_packing_is_isostatic_and_mechanically_stable(jammed):
    spec = Spectrum().compute(jammed)
    c = spec.dynamical.contacts
    assert c.is_isostatic  # N_c = N' d - d + 1 (chapter section 4.1)
    # <z>_iso = 2 N_c,iso / N' = 2d - 2(d - 1)/N' (the chapter's text prints (d - 1)/N', without the 2)
    assert c.mean_z == pytest.approx(4 - 2 / c.n_kept, rel=1e-14)
    assert spec.n_zero == 2 and spec.n_negative == 0
    assert spec.translation_residual < 1e-14
    st = Stability().compute(jammed, spec)
    assert st.label == STABLE and st.behaviour == "quadratic"
    assert np.allclose(st.delta_v, 0.5 * st.mode_eigenvalue * st.deltas**2, rtol=1e-3)
    # frequencies as the seed defines them: omega = sqrt(e / M), M = N m
    assert np.allclose(spec.frequencies, np.sqrt(spec.nonzero / jammed.n))
    assert np.allclose(Spectrum(mass=1.0).compute(jammed).frequencies, np.sqrt(spec.nonzero))


def test_sparse_lowest_modes_match_dense(jammed):
    dense = Spectrum().compute(jammed)
    sparse = Spectrum(method="sparse", n_modes=4).compute(jammed)
    assert not sparse.complete and sparse.eigenvalues[-1] > sparse.e_min
    k = len(sparse.eigenvalues)
    assert np.allclose(sparse.eigenvalues, dense.eigenvalues[:k], atol=1e-12)
    assert sparse.n_zero == dense.n_zero == 2
    st = Stability().compute(jammed, sparse)
    assert st.mode_eigenvalue == pytest.approx(dense.lowest_nonzero, rel=1e-9)


def test_one_lowest_eigenpair_routine_serves_spectra_and_soft_modes(jammed):
    """``mechanics.eigen.lowest_eigenpairs``: grown until a value exceeds the threshold (spectra),
    or k pairs in ARPACK's order (soft-mode steps); both the dense spectrum's lowest."""
    from jamflow.mechanics.eigen import lowest_eigenpairs
    from jamflow.minimize.soft_modes import lowest_modes

    matrix = DynamicalMatrix().compute(jammed).matrix
    dense = np.linalg.eigvalsh(matrix.toarray())
    grown, vectors = lowest_eigenpairs(matrix, 1, 1e-6, grow_above=1e-6)
    assert len(grown) == 4 and np.sum(grown <= 1e-6) == 2 and grown[-1] > 1e-6  # k = 1, 2: the zero modes only
    assert np.allclose(grown, dense[:4], atol=1e-12) and vectors.shape == (matrix.shape[0], 4)
    values, _ = lowest_modes(matrix, 6, 1.0)
    assert np.allclose(np.sort(values), dense[:6], atol=1e-12)
    assert len(lowest_eigenpairs(matrix, 6, 1e-8, dense_limit=matrix.shape[0])[0]) == matrix.shape[0]


def test_density_of_states_counts_every_nonzero_mode(jammed):
    spectra = [Spectrum().compute(jammed), Spectrum().compute(triangular_lattice(6, 6, 0.97))]
    dos = DensityOfStates(bins=25).compute(spectra)
    total = sum(len(s.frequencies) for s in spectra)
    assert dos.n_modes == total and dos.n_packings == 2
    assert np.sum(dos.density * np.diff(dos.edges)) * 2 == pytest.approx(total)
    with pytest.raises(ValueError, match="complete spectra"):
        DensityOfStates().compute([Spectrum(method="sparse", n_modes=4).compute(jammed)])


@pytest.mark.parametrize("make,match", [
    (lambda: Spectrum(e_min=0.0), "e_min"),
    (lambda: Spectrum(mass=-1.0), "mass"),
    (lambda: Spectrum(method="lanczos"), "method"),
    (lambda: Spectrum(n_modes=0), "n_modes"),
    (lambda: DensityOfStates(bins=0), "bins"),
    (lambda: DensityOfStates(omega_max=float("nan")), "omega_max"),
    (lambda: Stability(deltas=[1e-3]), "deltas"),
    (lambda: Stability(deltas=[-1e-3, 1e-2]), "deltas"),
    (lambda: DensityOfStates().compute([]), "at least one"),
])
def test_bad_parameters_raise(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def _modes_args(argv):
    from jamflow.cli.commands import modes

    parser = argparse.ArgumentParser()
    modes.add_arguments(parser)
    return modes, parser.parse_args(argv)


def test_cli_writes_results_and_figure(jammed, tmp_path, capsys):
    from jamflow.io.packing_file import save_packing

    files = [save_packing(tmp_path / f"p{k}.h5", q) for k, q in enumerate([jammed, triangular_lattice(6, 6, 0.97)])]
    modes, args = _modes_args([str(f) for f in files])
    assert modes.run(args) == 0
    out = capsys.readouterr().out
    assert "isostatic 1/2" in out and "exactly d zero modes (none negative) 2/2" in out
    from jamflow.io.modes_file import read_modes

    res = read_modes(tmp_path / "p0.modes.h5")
    assert res["classification"] == STABLE and res["n_zero"] == 2
    assert res["n_contacts"] == res["isostatic_count"] and len(res["contacts"]) == res["n_contacts"]
    assert np.allclose(res["eigenvalues"], Spectrum().compute(jammed).eigenvalues, atol=1e-14)
    png = tmp_path / f"{tmp_path.name}.modes.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not list(tmp_path.glob(".*tmp"))  # atomic writes leave no temporaries
    with h5py.File(files[0], "r") as f:  # the packing file itself is untouched
        assert "eigenvalues" not in f


def test_cli_summary_prints_the_pooled_mean_z_and_floater_fraction(jammed, tmp_path, capsys):
    """<z> pooled over the files (2 sum N_c / sum N', periodic disks) and the floater fraction
    sum N_f / sum N on the ensemble line, not only in the figure."""
    from jamflow.io.packing_file import save_packing

    packings = [jammed, disk_in_vacancy(0, 0.0, 0.5)]  # the small disk in the lattice's vacancy: a floater
    files = [save_packing(tmp_path / f"p{k}.h5", q) for k, q in enumerate(packings)]
    modes, args = _modes_args([str(f) for f in files] + ["--no-figure"])
    with pytest.warns(UserWarning, match="not at an energy minimum"):  # the vacancy's neighbours are pushed inwards
        assert modes.run(args) == 0
    summary = next(line for line in capsys.readouterr().out.splitlines() if line.startswith("2 packing(s)"))
    found = [Contacts().compute(q) for q in packings]
    mean_z = 2 * sum(c.n_contacts for c in found) / sum(len(c.floater) - c.n_floaters for c in found)
    floaters, n = sum(c.n_floaters for c in found), sum(q.n for q in packings)
    assert floaters > 0 and abs(mean_z - np.mean([c.mean_z for c in found])) > 1e-3  # pooled, not averaged per packing
    assert summary.startswith(f"2 packing(s): pooled <z> = {mean_z:.4f}, floaters {floaters}/{n} ({floaters / n:.4f})")


def test_cli_rejects_bad_input_before_work(tmp_path):
    from jamflow.io.packing_file import save_packing

    good = save_packing(tmp_path / "good.h5", triangular_lattice(6, 6, 0.97))
    modes, args = _modes_args([str(good), str(tmp_path / "missing.h5")])
    with pytest.raises(FileNotFoundError, match="missing.h5"):
        modes.run(args)
    assert not (tmp_path / "good.modes.h5").exists()
    modes, args = _modes_args([str(good), "--e-min", "-1"])
    with pytest.raises(ValueError, match="e_min"):
        modes.run(args)


@pytest.mark.parametrize("fmt", ["lammps-data", "lammps-dump"])
def test_cli_reads_lammps_files(fmt, tmp_path, capsys):
    """A LAMMPS data file or dump is read as analyze reads it (jamflow.cli.inputs), not refused as
    'not an HDF5 file'; the spectrum matches the jamflow packing's to float32 round-off."""
    import warnings

    from jamflow.io.export import SUFFIXES, export_packing
    from jamflow.io.modes_file import read_modes

    lattice = triangular_lattice(6, 6, 0.97)
    src = export_packing(lattice, tmp_path / f"p{SUFFIXES[fmt]}", fmt)
    modes, args = _modes_args([str(src), "--no-figure"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # float32 coordinates may not pass jamflow's force balance test
        assert modes.run(args) == 0
    assert f"{src}: N' = 36" in capsys.readouterr().out
    res = read_modes(tmp_path / "p.modes.h5")
    assert res["n_zero"] == 2 and res["n_contacts"] == 108
    assert np.allclose(res["eigenvalues"], Spectrum().compute(lattice).eigenvalues, atol=1e-5)
