"""g(r) and S(k): closed-form crystals, the ideal gas, a literal eq. 2.29 sum, and freud.

freud computes in float32, so agreement with it is tested at float32 precision (pair
distances within 1e-5 of a bin edge may fall in the neighbouring bin).
"""

import math
from itertools import product

import freud
import numpy as np
import pytest

from jamflow.analysis.structure import (RDF, StructureFactor, fcc_packing, rms_contact_distance,
                                        structure_factor_grid, triangular_packing)
from jamflow.model.packing import Packing, random_packing
from jamflow.model.sizes import parse_sizes


def gas(n, dim, phi, seed, sizes="mono", gamma=0.0):
    p = random_packing(n, dim, parse_sizes(sizes), phi, seed)
    return p.with_positions(p.positions, p.box.with_shear_strain(gamma))


def lattice_distances(basis, r_max):
    """Every |sum_i k_i b_i| <= r_max over all integer k (negative ones included)."""
    span = int(math.ceil(r_max)) + 2
    ks = np.array(list(product(range(-span, span + 1), repeat=len(basis))), float)
    r = np.linalg.norm(ks @ np.asarray(basis, float), axis=1)
    return np.unique(np.round(r[(r > 0) & (r <= r_max)], 9))


# --- scale ---------------------------------------------------------------------------------
def test_rms_contact_distance_matches_all_pairs_average():
    d = np.random.default_rng(3).uniform(1.0, 1.4, 37)
    i, j = np.triu_indices(len(d), 1)
    brute = math.sqrt(np.mean(((d[i] + d[j]) / 2) ** 2))
    assert rms_contact_distance(d) == pytest.approx(brute, rel=1e-14)
    assert rms_contact_distance(np.full(10, 1.3)) == pytest.approx(1.3, rel=1e-15)


# --- crystals ------------------------------------------------------------------------------
@pytest.mark.parametrize("tilted", [False, True])
def test_triangular_lattice_peaks_are_the_lattice_distances(tilted):
    """Seed section 4.2: peaks at 1, sqrt 3, 2, sqrt 7, 3, 2 sqrt 3, sqrt 13, ... only."""
    p = triangular_packing(16, 16, tilted=tilted)
    res = RDF(dr=0.0137).compute(p)
    expected = lattice_distances([[1, 0], [0.5, math.sqrt(3) / 2]], res.edges[-1])
    assert np.min(np.abs(res.edges[:, None] - expected[None, :])) > 1e-6  # no distance on a bin edge
    occupied = res.r[res.g > 0]
    np.testing.assert_allclose(occupied, res.r[np.searchsorted(res.edges, expected) - 1], atol=1e-12)
    np.testing.assert_allclose(expected[:7], [1, math.sqrt(3), 2, math.sqrt(7), 3, 2 * math.sqrt(3), math.sqrt(13)])
    # height of the first shell, closed form: z = 6 neighbours at r = 1 -> g = z V / ((N - 1) * shell area)
    k = np.searchsorted(res.edges, 1.0) - 1
    shell = math.pi * (res.edges[k + 1] ** 2 - res.edges[k] ** 2)
    assert res.g[k] == pytest.approx(6 * p.box.volume / ((p.n - 1) * shell), rel=1e-12)


def test_tilted_and_rectangular_crystal_cells_give_the_same_rdf():
    a = RDF(dr=0.0137, r_max=5.0).compute(triangular_packing(14, 14))
    b = RDF(dr=0.0137, r_max=5.0).compute(triangular_packing(14, 0, tilted=True))
    np.testing.assert_allclose(a.g, b.g, rtol=1e-12, atol=1e-12)


def test_fcc_shells_and_coordination_numbers():
    """FCC shells (nearest distance 1): r^2 = 1, 2, ..., 9 with 12, 6, 24, 12, 24, 8, 48, 6, 36
    neighbours. The seed lists 1, sqrt 3, 2, sqrt 6, sqrt 7 from non-negative k, l, m only;
    allowing negative integers adds sqrt 2 and sqrt 5."""
    p = fcc_packing(5)
    res = RDF(dr=0.0137, r_max=3.05).compute(p)
    basis = [[1, 0, 0], [0.5, math.sqrt(3) / 2, 0], [0.5, 0.5 / math.sqrt(3), math.sqrt(2 / 3)]]
    expected = lattice_distances(basis, 3.05)
    np.testing.assert_allclose(expected, np.sqrt(np.arange(1, 10)), atol=1e-9)
    shell_counts = [res.counts[np.searchsorted(res.edges, r) - 1] for r in expected]
    np.testing.assert_array_equal(shell_counts, p.n * np.array([12, 6, 24, 12, 24, 8, 48, 6, 36]) / 2)
    assert res.counts.sum() == sum(shell_counts)


# --- ideal gas -----------------------------------------------------------------------------
@pytest.mark.parametrize("dim,gamma", [(2, 0.0), (2, 0.4), (3, 0.25)])
def test_ideal_gas_g_tends_to_one(dim, gamma):
    """Uniform random points: E[g] = 1 exactly with the N(N-1) normalisation; the deviations
    are Poisson noise (chi^2 per bin ~ 1)."""
    pk = [gas(600, dim, 0.02, seed, gamma=gamma) for seed in range(3)]
    res = RDF(dr=0.25, r_max=6.0).compute(pk)
    z = (res.g - 1) / res.stderr
    assert abs(np.sum(res.counts - res.ideal)) < 4 * math.sqrt(res.ideal.sum())
    assert 0.6 < np.mean(z**2) < 1.5


def test_ideal_gas_structure_factor_tends_to_one():
    """S(k) of independent uniform points is exponential with mean 1 at every allowed k."""
    pk = [gas(500, 2, 0.05, seed, gamma=0.3) for seed in range(3)]
    res = StructureFactor(k_max=8.0, dk=0.5).compute(pk)
    total = res.n_vectors.sum()
    mean = np.sum(res.s * res.n_vectors) / total
    assert abs(mean - 1.0) < 4 / math.sqrt(total)


# --- S(k) ----------------------------------------------------------------------------------
def test_structure_factor_of_a_crystal_in_a_tilted_cell():
    """Closed form: S(k) = N on the crystal's reciprocal lattice (k.a_i in 2 pi Z) and 0 elsewhere."""
    p = triangular_packing(12, 0, tilted=True)
    k, s = structure_factor_grid(p, 16.0)
    a = np.array([[1.0, 0.0], [0.5, math.sqrt(3) / 2]])
    m = k @ a.T / (2 * math.pi)
    bragg = np.all(np.abs(m - np.round(m)) < 1e-9, axis=1)
    assert bragg.sum() == 9  # |k| = 4 pi/sqrt 3 (x3), 4 pi (x3), 8 pi/sqrt 3 (x3) in one half-space
    np.testing.assert_allclose(s[bragg], p.n, rtol=1e-12)
    assert np.max(s[~bragg]) < 1e-20


@pytest.mark.parametrize("dim,gamma", [(2, 0.35), (3, 0.2)])
def test_structure_factor_matches_literal_double_sum(dim, gamma):
    """Second implementation: eq. 2.29's sum over i != j (plus the i = j term, N/N = 1) on the
    allowed vectors; also checks that k.a_d is a multiple of 2 pi (periodicity)."""
    p = gas(40, dim, 0.3, 5, sizes="bi:1.4:0.5", gamma=gamma)
    k, s = structure_factor_grid(p, 7.0)
    n = k @ p.box.h / (2 * math.pi)
    np.testing.assert_allclose(n, np.round(n), atol=1e-10)
    i, j = np.nonzero(~np.eye(p.n, dtype=bool))
    rij = p.positions[i] - p.positions[j]
    literal = 1.0 + np.cos(rij @ k.T).sum(axis=0) / p.n
    np.testing.assert_allclose(s, literal, atol=1e-10)


def test_structure_factor_matches_freud_in_a_cubic_box():
    """freud's direct S(k) samples only the octant n_x, n_y, n_z >= 0 (the chapter's literal
    wording); restricted to those vectors and freud's bins, the two agree at float32 level."""
    p = gas(300, 3, 0.3, 2)
    fbox = p.box.to_freud()
    sf = freud.diffraction.StaticStructureFactorDirect(bins=20, k_max=6.0, k_min=0.0)
    sf.compute((fbox, fbox.wrap(p.positions.astype(np.float32))))
    k, s = structure_factor_grid(p, 6.0)
    octant = np.all(np.rint(k @ p.box.h / (2 * math.pi)) >= 0, axis=1)
    idx = np.digitize(np.linalg.norm(k, axis=1), sf.bin_edges) - 1
    for b in range(1, 20):  # bin 0 holds freud's k = 0 term (S = N)
        sel = octant & (idx == b)
        if sel.any():
            assert s[sel].mean() == pytest.approx(sf.S_k[b], rel=2e-5)


def test_shell_average_pools_vectors_over_an_ensemble():
    pk = [gas(200, 2, 0.4, seed) for seed in (1, 2)]
    both = StructureFactor(k_max=6.0, dk=0.7).compute(pk)
    one = [StructureFactor(k_max=6.0, dk=0.7).compute(p) for p in pk]
    np.testing.assert_array_equal(both.n_vectors, one[0].n_vectors + one[1].n_vectors)
    pooled = (one[0].s * one[0].n_vectors + one[1].s * one[1].n_vectors) / both.n_vectors
    np.testing.assert_allclose(both.s, pooled, rtol=1e-12)


# --- g(r): second implementation (freud) and mixtures -------------------------------------------
def _near_edge(p, edges, scale):
    i, j = np.triu_indices(p.n, 1)
    r = np.linalg.norm(p.box.minimum_image(p.positions[i] - p.positions[j]), axis=1) / scale
    return int(np.sum(np.min(np.abs(r[:, None] - edges[None, :]), axis=1) < 1e-5))


@pytest.mark.parametrize("dim,gamma", [(2, 0.4), (3, 0.2)])
def test_rdf_matches_freud(dim, gamma):
    p = gas(250, dim, 0.3, 11, gamma=gamma)
    res = RDF(dr=0.05).compute(p)
    fr = freud.density.RDF(bins=len(res.g), r_max=res.edges[-1], normalization_mode="finite_size")
    pts = p.positions if dim == 3 else np.column_stack([p.positions, np.zeros(p.n)])
    fbox = p.box.to_freud()
    fr.compute((fbox, fbox.wrap(pts.astype(np.float32))), neighbors={"r_max": res.edges[-1], "exclude_ii": True})
    flips = _near_edge(p, res.edges, 1.0)
    assert np.sum(np.abs(2 * res.counts - fr.bin_counts)) <= 4 * flips  # freud counts ordered pairs
    ok = res.counts > 50
    np.testing.assert_allclose(res.g[ok], fr.rdf[ok], rtol=2e-5 + 2 * flips / 50)


def test_partial_rdfs_against_freud_and_the_total():
    p = gas(300, 2, 0.3, 4, sizes="bi:1.4:0.5", gamma=0.2)
    res = RDF(dr=0.1, partial=True).compute(p)
    np.testing.assert_array_equal(res.species, [1.0, 1.4])
    labels = np.searchsorted(res.species, p.diameters)
    n_a = np.bincount(labels)
    weights = np.outer(n_a, n_a) - np.diag(n_a)  # ordered pairs per species pair
    total = np.einsum("ab,abr->r", weights, res.partial) / (p.n * (p.n - 1))
    np.testing.assert_allclose(total, res.g, rtol=1e-12, atol=1e-14)
    scale = rms_contact_distance(p.diameters)
    fbox = p.box.to_freud()
    pts = fbox.wrap(np.column_stack([p.positions, np.zeros(p.n)]).astype(np.float32))
    fr = freud.density.RDF(bins=len(res.g), r_max=res.edges[-1] * scale)
    fr.compute((fbox, pts[labels == 0]), query_points=pts[labels == 1],
               neighbors={"r_max": res.edges[-1] * scale})
    ok = res.partial[0, 1] > 0.5
    flips = _near_edge(p, res.edges, scale)
    np.testing.assert_allclose(res.partial[0, 1][ok], fr.rdf[ok], rtol=2e-5 + flips / 20)


def test_ensemble_of_equal_size_packings_is_the_mean_g():
    pk = [gas(200, 2, 0.5, seed) for seed in (7, 8)]
    both = RDF(dr=0.1).compute(pk)
    one = [RDF(dr=0.1).compute(p) for p in pk]
    np.testing.assert_allclose(both.g, 0.5 * (one[0].g + one[1].g), rtol=1e-12)
    assert both.n_packings == 2


def test_rdf_is_reported_in_units_of_the_rms_contact_distance():
    p = gas(200, 2, 0.4, 9)
    big = Packing(p.positions * 1.7, p.diameters * 1.7, p.box.scaled(1.7))
    np.testing.assert_allclose(RDF(dr=0.1).compute(big).g, RDF(dr=0.1).compute(p).g, rtol=1e-12)


# --- bad input -----------------------------------------------------------------------------
def test_bad_input_is_refused_with_advice():
    p = gas(100, 2, 0.4, 1, sizes="poly-uniform:0.4")
    with pytest.raises(ValueError, match="half the shortest box width"):
        RDF(r_max=100.0).compute(p)
    with pytest.raises(ValueError, match="discrete species"):
        RDF(partial=True).compute(p)
    with pytest.raises(ValueError, match="non-empty"):
        RDF().compute([])
    with pytest.raises(ValueError, match="positive"):
        RDF(dr=0.0)
    with pytest.raises(ValueError, match="mix 2D and 3D"):
        RDF().compute([p, gas(100, 3, 0.3, 1)])
    with pytest.raises(ValueError, match="k_max"):
        StructureFactor(k_max=-1.0)


# --- input: LAMMPS files through MDAnalysis, and the analyze command ----------------------------
@pytest.fixture(scope="module")
def lammps_files(tmp_path_factory):
    """A sheared polydisperse 2D packing written by LAMMPS itself (write_data, write_dump)."""
    from jamflow.engines.lammps.engine import LammpsEngine

    d = tmp_path_factory.mktemp("lammps")
    p = gas(60, 2, 0.5, 1, sizes="poly-uniform:0.4", gamma=0.3)
    with LammpsEngine(p) as e:
        e.command(f"write_data {d / 'p.data'}")
        e.command(f"write_dump all custom {d / 'p.dump'} id type diameter x y z modify format float %.17g")
        e.command(f"write_dump all custom {d / 'nodiam.lammpstrj'} id type x y z")
    return p, d


@pytest.mark.parametrize("name", ["p.data", "p.dump"])
def test_lammps_files_read_back_through_mdanalysis(lammps_files, name):
    from jamflow.io.readers import packing_from_lammps

    p, d = lammps_files
    q = packing_from_lammps(d / name)
    assert q.dim == 2 and q.n == p.n
    np.testing.assert_allclose(q.box.h, p.box.h, rtol=2e-7)  # MDAnalysis keeps float32
    np.testing.assert_allclose(q.box.minimum_image(q.positions - p.positions), 0, atol=2e-6)
    np.testing.assert_allclose(q.diameters, p.diameters, rtol=1e-7)
    np.testing.assert_allclose(RDF(dr=0.1).compute(q).g, RDF(dr=0.1).compute(p).g, atol=1e-12)


def test_lammps_file_without_diameters_needs_a_type_mapping(lammps_files):
    from jamflow.io.readers import packing_from_lammps

    p, d = lammps_files
    with pytest.raises(ValueError, match="type -> diameter mapping"):
        packing_from_lammps(d / "nodiam.lammpstrj")
    types = np.loadtxt(d / "nodiam.lammpstrj", skiprows=9)[:, 1].astype(int)
    with pytest.raises(ValueError, match="no diameter given for atom type"):
        packing_from_lammps(d / "nodiam.lammpstrj", diameters={int(types[0]): 1.0})
    q = packing_from_lammps(d / "nodiam.lammpstrj", diameters={int(t): 1.2 for t in types})
    np.testing.assert_array_equal(q.diameters, 1.2)


def test_analyze_command_writes_hdf5_and_plots(tmp_path, lammps_files):
    import argparse

    import h5py

    from jamflow.cli.commands import analyze
    from jamflow.io.packing_file import save_packing
    from jamflow.model.shapes import Ellipsoid

    save_packing(tmp_path / "crystal.h5", triangular_packing(12, 12, tilted=True))
    parser = argparse.ArgumentParser()
    analyze.add_arguments(parser)
    out = tmp_path / "res.h5"
    assert analyze.run(parser.parse_args([str(tmp_path / "crystal.h5"), "--out", str(out), "--k-max", "8"])) == 0
    with h5py.File(out) as f:
        assert f["order/Q6_global"][0] == pytest.approx(1.0, abs=1e-12)
        assert f["order/G"][0] == 0.0 and 1 < f.attrs["r_min"] < math.sqrt(3)
        assert f["sk/s"].shape == f["sk/k"].shape and f["rdf/g"].shape == f["rdf/r"].shape
        assert np.isnan(f["order/P2"][0])  # disks have no nematic order
    for kind in ("rdf", "sk", "q6corr", "order", "q6map"):
        assert (tmp_path / f"res-{kind}.png").stat().st_size > 1000
    # aligned ellipses on the same lattice (b = 0.8, a = 0.96: no overlaps): P2 = 1 (closed form)
    crystal = triangular_packing(12, 12, tilted=True)
    aligned = Packing(crystal.positions, 0.8 * crystal.diameters, crystal.box, shape=Ellipsoid(1.2),
                      orientations=np.full(crystal.n, 0.4))
    save_packing(tmp_path / "ellipses.h5", aligned)
    assert analyze.run(parser.parse_args([str(tmp_path / "ellipses.h5"), "--out", str(out), "--k-max", "8",
                                          "--force"])) == 0
    with h5py.File(out) as f:
        assert f["order/P2"][0] == pytest.approx(1.0, abs=1e-12)
    bad = parser.parse_args([str(lammps_files[1] / "p.dump"), "--out", str(out), "--dr", "-1"])
    with pytest.raises(ValueError, match="--dr"):
        analyze.run(bad)
    with pytest.raises(ValueError, match="TYPE:DIAMETER"):
        analyze.parse_diameters("1=1.0")


def test_analyze_makes_the_plots_directory(tmp_path):
    """--plots DIR is made if missing (its parent must exist) and removed again if the command
    fails before writing into it."""
    import argparse

    from jamflow.cli.commands import analyze
    from jamflow.io.packing_file import save_packing

    save_packing(tmp_path / "crystal.h5", triangular_packing(6, 6, tilted=True))
    parser = argparse.ArgumentParser()
    analyze.add_arguments(parser)
    out, plots = tmp_path / "res.h5", tmp_path / "plots"
    args = [str(tmp_path / "crystal.h5"), "--out", str(out), "--k-max", "6", "--plots"]
    assert analyze.run(parser.parse_args([*args, str(plots)])) == 0
    assert (plots / "res-rdf.png").stat().st_size > 1000 and out.is_file()
    with pytest.raises(FileNotFoundError):
        analyze.run(parser.parse_args([str(tmp_path / "missing.h5"), "--out", str(out), "--plots",
                                       str(tmp_path / "empty")]))
    assert not (tmp_path / "empty").exists()  # made by the failed run, removed again
    with pytest.raises(ValueError, match="does not exist"):
        analyze.run(parser.parse_args([*args, str(tmp_path / "no" / "plots")]))
    (tmp_path / "file").write_text("")
    with pytest.raises(ValueError, match="not a directory"):
        analyze.run(parser.parse_args([*args, str(tmp_path / "file")]))
