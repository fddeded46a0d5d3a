"""Geometric families: joining segments (closed cases on hand-made points), the mirror map, the
richness estimate, and a small real sampling end to end."""

import numpy as np
import pytest

from jamflow.analysis.families import (
    by_starts,
    convergence,
    jackknife,
    join,
    matching_pairs,
    mirror_by_sightings,
    mirror_check,
    mirrored,
    more_samples_needed,
    richness,
    symmetric_strain,
)
from jamflow.cli.app import main
from jamflow.io.families_file import load_family_points
from jamflow.model.packing import BoxTooSmall
from jamflow.plots.shear import richness_figure
from jamflow.protocols import families as families_protocol
from jamflow.protocols.compression import at_shear_strain, compress, initial_packing
from jamflow.protocols.families import FamilySampling, sample, sample_start, signature
from jamflow.protocols.settings import chapter_protocol
from jamflow.protocols.shear import Network


def points(rows):
    """Point columns from (start, segment, strain_index, phi_j, mu, signature, step) rows."""
    cols = list(zip(*rows))
    out = {name: np.array(col) for name, col in zip(("start", "segment", "strain_index", "phi_j", "mu"), cols[:5])}
    out["signature"] = np.array(cols[5], dtype="S")
    out["step"] = np.array(cols[6])
    out["gamma"] = out["strain_index"] * 0.001
    return out


def test_segments_meeting_at_a_strain_are_one_family():
    p = points([
        (0, 0, 10, 0.80, 0.1, "a", 0), (0, 0, 11, 0.801, 0.11, "a", 1),  # start 0: one segment, strains 10-11
        (1, 1, 11, 0.801 + 1e-10, 0.11 + 1e-6, "a", 0), (1, 1, 12, 0.802, 0.12, "a", 1),  # start 1 meets it at 11
        (2, 2, 11, 0.801 + 1e-10, 0.3, "a", 0),  # same phi_J, other stress ratio: another family
        (3, 3, 11, 0.801 + 1e-6, 0.11, "a", 0),  # phi_J 1e-6 away: another family
        (4, 4, 11, 0.801, 0.11, "b", 0),  # another signature: another family
    ])
    fam = join(p, 0.001)
    assert fam.count == 4
    assert fam.family[0] == fam.family[1] == fam.family[2] == fam.family[3]
    assert len({fam.family[k] for k in (0, 4, 5, 6)}) == 4
    row = fam.table()[0]
    assert (row["gamma_min"], row["gamma_max"], row["strains"], row["starts"], row["segments"]) == \
        (0.01, 0.012, 3, 2, 2)
    gamma, phi, spread = fam.curve(0)
    assert np.allclose(gamma, [0.01, 0.011, 0.012]) and spread[1] == pytest.approx(1e-10, rel=1e-3)
    assert join(p, 0.001, starts=1).count == 1  # only start 0


def test_mirror_maps_gamma_to_one_minus_gamma_and_flips_the_stress_ratio():
    p = points([(0, 0, 200, 0.80, 0.1, "a", 0), (1, 1, 800, 0.80, -0.1, "a", 0), (2, 2, 800, 0.80, 0.1, "a", 0)])
    m = mirrored(p, 0.001)
    assert list(m["strain_index"]) == [800, 200, 200] and list(m["mu"]) == [-0.1, 0.1, -0.1]
    fam = join(p, 0.001)
    check = mirror_check(fam)
    assert check.partner[fam.family[0]] == {fam.family[1]} and check.partner[fam.family[1]] == {fam.family[0]}
    assert check.partner[fam.family[2]] == set() and check.matched() == 2 and check.unpaired == []
    with pytest.raises(ValueError, match="not symmetric"):
        mirrored(p, 0.003)


def test_a_reflected_twin_with_the_same_phi_and_stress_is_another_family():
    p = points([(0, 0, 999, 0.80, 0.1, "a", 0), (1, 1, 999, 0.80, 0.1, "a", 0), (2, 2, 999, 0.80, 0.1, "a", 0)])
    p["fabric_a"], p["fabric_b"] = np.array([0.12, 0.12, -0.12]), np.array([0.05, 0.05, 0.05])
    fam = join(p, 0.001)
    assert fam.count == 2 and fam.family[0] == fam.family[1] != fam.family[2]
    m = mirrored(p, 0.001)
    assert list(m["fabric_b"]) == [-0.05] * 3 and list(m["fabric_a"]) == [0.12, 0.12, -0.12]
    assert join(p, 0.001, tol_fabric=0.3).count == 1  # a looser fabric tolerance merges the twin


def test_no_joining_at_symmetric_strains():
    """At gamma = 0, 1/2, 1 congruent packings of two families coincide: not joined there."""
    p = points([(0, 0, 0, 0.80, 0.1, "a", 0), (1, 1, 0, 0.80, 0.1, "a", 0), (2, 2, 500, 0.8, 0.1, "a", 0),
                (3, 3, 500, 0.8, 0.1, "a", 0), (4, 4, 501, 0.8, 0.1, "a", 0), (5, 5, 501, 0.8, 0.1, "a", 0)])
    assert list(symmetric_strain(p["gamma"])) == [True, True, True, True, False, False]
    assert join(p, 0.001).count == 5  # only the pair at 0.501 joins


def test_sightings_count_distinct_sampled_paths_and_bin_the_mirror_check():
    rows = [(0, 0, 200, 0.80, 0.1, "a", 0), (1, 1, 200, 0.80, 0.1, "a", 0), (2, 2, 800, 0.80, -0.1, "a", 0),
            (3, 3, 300, 0.70, 0.0, "b", 0)]
    p = points(rows)
    p["grid"] = np.zeros(4, int)
    fam = join(p, 0.001)
    assert list(fam.sightings()) == [2, 1, 1]  # families in order of first strain: 200, 300, 800
    binned = mirror_by_sightings(fam, mirror_check(fam), [0, 1, 2])
    assert binned[0] == ("1", 2, 1) and binned[1] == ("2", 1, 1)


def test_richness_is_chao1_of_the_sampled_packings():
    rows = [(k, k, 10 * k + 1, 0.8 + 0.01 * k, 0.0, "a", 0) for k in range(5)]  # 5 families found once
    rows += [(5, 5, 1, 0.8, 0.0, "a", 0), (6, 6, 61, 0.9, 0.0, "a", 0), (7, 7, 61, 0.9, 0.0, "a", 0)]
    r = richness(join(points(rows), 0.001))
    # families 0 (found by starts 0 and 5) and the one at strain 60 (starts 6, 7) twice, four once
    assert (r["observed"], r["singletons"], r["doubletons"]) == (6, 4, 2)
    assert r["chao1"] == pytest.approx(6 + 4 * 3 / (2 * 3))
    # standard error (Chao 2005, bias-corrected): 4*3/6 + 4*7^2/(4*3^2) + 4^2*2*3^2/(4*3^4) = 2 + 49/9 + 8/9
    assert r["chao1_se"] == pytest.approx(np.sqrt(2 + 49 / 9 + 8 / 9), rel=1e-12)


def test_richness_adds_jackknife_and_coverage():
    rows = [(k, k, 10 * k + 1, 0.8 + 0.01 * k, 0.0, "a", 0) for k in range(5)]
    rows += [(5, 5, 1, 0.8, 0.0, "a", 0), (6, 6, 61, 0.9, 0.0, "a", 0), (7, 7, 61, 0.9, 0.0, "a", 0)]
    r = richness(join(points(rows), 0.001))  # n = 8 sampled, S_obs = 6, f1 = 4, f2 = 2
    assert r["jack1"] == pytest.approx(6 + 4 * 7 / 8, rel=1e-12)
    assert r["coverage"] == pytest.approx(1 - 4 / 8, rel=1e-12)


def test_jackknife_closed_form():
    """Burnham & Overton (1978) on the abundances 1, 1, 1, 2, 2, 3, 5 (n = 15, S_obs = 7,
    f1 = 3, f2 = 2), worked by hand: S = sum a_j f_j, var = sum a_j^2 f_j - S."""
    counts = [1, 1, 1, 2, 2, 3, 5]
    s1, se1 = jackknife(counts, 1)
    assert s1 == pytest.approx(7 + 3 * 14 / 15, rel=1e-12)  # 9.8
    assert se1 == pytest.approx(np.sqrt(3 * (14 / 15) * (29 / 15)), rel=1e-12)  # f1 c (1 + c), c = 14/15
    s2, se2 = jackknife(counts, 2)
    a1, a2 = 1 + 27 / 15, 1 - 13**2 / (15 * 14)
    assert s2 == pytest.approx(7 + 3 * 27 / 15 - 2 * 169 / 210, rel=1e-12)  # 10.790...
    assert se2 == pytest.approx(np.sqrt(3 * a1**2 + 2 * a2**2 + 2 - s2), rel=1e-12)
    with pytest.raises(ValueError, match="order"):
        jackknife(counts, 3)


def test_more_samples_needed_inverts_the_extrapolation():
    """S_obs = 6, f1 = 4, n = 8, Chao1 8 (f0 = 2): 90 % of 8 needs m with 2 (1 - 0.8^m) = 1.2."""
    rich = dict(observed=6, singletons=4, sampled=8, chao1=8.0)
    m = more_samples_needed(rich, 0.9)
    assert m == pytest.approx(np.log(0.4) / np.log(0.8), rel=1e-12)
    assert 6 + 2 * (1 - (1 - 4 / (8 * 2 + 4)) ** m) == pytest.approx(0.9 * 8, rel=1e-12)
    assert more_samples_needed(rich, 0.5) == 0.0 and more_samples_needed(rich, 1.0) == float("inf")


def test_mirror_about_zero_is_the_mirror_about_one_half():
    """gamma -> -gamma on a lattice from -0.002: the point at 0.001 lands on the one at -0.001."""
    p = points([(0, 0, 3, 0.8, 0.2, "a", 0), (1, 1, 1, 0.8, -0.2, "a", 0)])
    p["gamma"] = -0.002 + p["strain_index"] * 0.001
    m = mirrored(p, 0.001, -0.002, center=0.0)
    assert m["strain_index"].tolist() == [1, 3] and np.allclose(m["gamma"], [-0.001, 0.001])
    fam = join(p, 0.001, -0.002)
    assert mirror_check(fam, center=0.0).partner == {0: {1}, 1: {0}}
    with pytest.raises(ValueError, match="multiple of 1/2"):
        mirrored(p, 0.001, -0.002, center=0.3)


def test_small_cells_are_refused_before_work_with_the_strain_limit():
    """N = 6 bidisperse disks fit the cell at phi 0.84 only within |gamma - k| <= 0.243: a plan
    beyond it is refused when it is made, naming the limit and a range that works."""
    with pytest.raises(ValueError, match=r"gamma = 0\.25: .* > 0\.243.*--gamma-min -0\.24 --gamma-max 0\.24"):
        FamilySampling(n=6, gamma_max=1.0)
    assert len(FamilySampling(n=6, gamma_min=-0.24, gamma_max=0.24).grid) == 49
    with pytest.raises(ValueError, match="even unsheared"):
        FamilySampling(n=4, gamma_max=0.01)


def test_families_command_refuses_a_small_cell_in_one_line(tmp_path, capsys):
    argv = ["families", "--n", "6", "--gamma-max", "0.5", "--out", str(tmp_path / "f"), "--quiet"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "0.243" in err and not (tmp_path / "f").exists()


def test_a_start_denser_than_its_cell_is_a_failure_not_an_abort(monkeypatch):
    def too_dense(**kwargs):
        raise BoxTooSmall("box too small")
    monkeypatch.setattr(families_protocol, "jam", too_dense)
    plan = FamilySampling(n=6, gamma_min=0.0, gamma_max=0.02, spacing=0.01, starts=1)
    pts, failures = sample_start(plan, 1, 0, 0)
    assert pts == [] and len(failures) == 1 and "box too small" in failures[0]


def test_signature_ignores_labels():
    start = initial_packing(10, 2, "bi:1.4:0.5", "spring", 3, 0.8)
    p = compress(at_shear_strain(start, 0.1), chapter_protocol()).packing
    order = np.random.default_rng(0).permutation(10)
    relabelled = p.subset(order)
    assert signature(Network.of(p), p.diameters) == signature(Network.of(relabelled), relabelled.diameters)


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    """N = 8 on the grid 0, 0.01, 0.02 with 3 starts: the real pipeline end to end."""
    out = tmp_path_factory.mktemp("fam")
    argv = ["families", "--n", "8", "--gamma-min", "0", "--gamma-max", "0.02", "--spacing", "0.01",
            "--substeps", "4", "--starts", "3", "--out", str(out), "--quiet"]
    assert main(argv) == 0
    return out


def test_families_command_writes_table_points_and_chart(small, capsys):
    plan, pts, failures = load_family_points(small / "points.h5")
    assert failures == [] and int(plan["starts"]) == 3
    assert len(pts["gamma"]) == 3 * (3 + 2 * 2 * 4)  # per round: 3 packings, 2 intervals x 2 directions x 4 steps
    assert set(np.unique(pts["strain_index"])) == set(range(9))
    fam = join(pts, 0.0025)
    sigs = pts["signature"]
    for f in range(fam.count):  # one signature per family, phi_J consistent at each strain
        assert len(set(sigs[fam.members(f)])) == 1
        assert fam.curve(f)[2].max() < 1e-8
    for name in ("families.h5", "families.csv", "families.png"):
        assert (small / name).stat().st_size > 500
    import h5py
    with h5py.File(small / "families.h5", "r") as f:
        curves = {k: v[...] for k, v in f["curves"].items()}
        assert f.attrs["families"] == fam.count and len(f["table/family"]) == fam.count
    g, phi, _ = fam.curve(0)
    mine = curves["family"] == 0
    assert np.allclose(curves["gamma"][mine], g) and np.array_equal(curves["phi_j"][mine], phi)


def test_families_resume_adds_rounds_only(small, capsys):
    argv = ["families", "--n", "8", "--gamma-min", "0", "--gamma-max", "0.02", "--spacing", "0.01",
            "--substeps", "4", "--starts", "4", "--out", str(small), "--quiet", "--resume"]
    before = load_family_points(small / "points.h5")[1]
    assert main(argv) == 0
    after = load_family_points(small / "points.h5")[1]
    keep = after["start"] < 3
    assert np.array_equal(after["phi_j"][keep], before["phi_j"]) and set(after["start"]) == {0, 1, 2, 3}
    conv = convergence(after, 0.0025, hi=0.02)
    assert [k for k, *_ in conv] == [1, 2, 3, 4]
    with pytest.raises(ValueError, match="another plan"):
        from jamflow.cli.commands.families import _resumed
        _resumed(small / "points.h5", FamilySampling(n=8, gamma_max=0.02, spacing=0.01, substeps=5, starts=4))


def test_richness_by_starts_matches_convergence_and_draws(small, tmp_path):
    pts = load_family_points(small / "points.h5")[1]
    rows = by_starts(pts, 0.0025, counts=[1, 2, 3], hi=0.02)
    assert [(r["starts"], r["half"], r["total"]) for r in rows] == convergence(pts, 0.0025, counts=[1, 2, 3], hi=0.02)
    assert rows[-1]["chao1"] == richness(join(pts, 0.0025, starts=3))["chao1"] and rows[-1]["sampled"] == 9
    assert richness_figure(tmp_path / "r.png", [("N = 8", rows), ("again", rows)]).stat().st_size > 500


def test_mirrored_start_lands_on_the_mirror_family():
    """Item 1's inversion through the family rule: a start jammed at 0.25 and its mirror at 0.75."""
    plan = FamilySampling(n=10, gamma_min=0.0, gamma_max=1.0, spacing=0.25, substeps=1, starts=1)
    rows = []
    for gamma, mirror in ((0.25, False), (0.75, True)):
        start = initial_packing(10, 2, "bi:1.4:0.5", "spring", 1, 0.8)
        if mirror:
            start = start.with_positions(start.positions * [-1.0, 1.0])
        res = compress(at_shear_strain(start, gamma), chapter_protocol())
        net = Network.of(res.packing)
        rows.append((int(mirror), int(mirror), int(plan.strain_index(gamma)), res.phi_j,
                     -res.pressure_tensor[0, 1] / res.pressure, signature(net, res.packing.diameters), 0))
    p = points(rows)
    assert matching_pairs(mirrored(p, plan.step), p) == [(0, 1), (1, 0)]


@pytest.mark.parametrize("kwargs,message", [
    (dict(spacing=0.03), "whole intervals"), (dict(gamma_max=0.0), "must exceed"), (dict(starts=0), "positive"),
    (dict(spacing=float("nan")), "finite"),
])
def test_bad_plans_are_refused(kwargs, message):
    with pytest.raises(ValueError, match=message):
        FamilySampling(**kwargs)


def test_families_command_mirrors_about_the_middle_of_a_symmetric_range(tmp_path, capsys):
    """A range symmetric about gamma = 0 (the one N = 6 allows) gets the mirror gamma -> -gamma."""
    argv = ["families", "--n", "8", "--gamma-min", "-0.01", "--gamma-max", "0.01", "--spacing", "0.01",
            "--substeps", "2", "--starts", "2", "--out", str(tmp_path / "f"), "--quiet"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "mirror gamma -> 0 - gamma" in out and "families met in [0, 0.01] by how many" in out
