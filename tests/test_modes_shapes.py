"""Spectra, energy profiles and stability classes of packings of particles that turn.

Stored packings (tests/data, made by the commands in tests/data/README.md): 2D bidisperse
ellipses (alpha = 1.5, N = 16) jammed on the reference energy, and 2D dimers (alpha = 1.5,
N = 32) jammed by the compiled engine. Published facts checked: ellipse packings at onset are
hypostatic and their quartic modes number the missing contacts N' d_f - d + 1 - N_c (Mailman
et al., Phys. Rev. Lett. 102, 255501 (2009)); the modes of the lowest branch are mostly
rotational (chapter section 3, Figure 2.17); site-site contacts are point-point distances, so
dimer packings obey Maxwell's count (isostatic; VanderWerf et al., Phys. Rev. E 97, 012909
(2018)). Second implementations: the pair-by-pair energy change against the difference of two
reference energies and against the quadratic form of the dynamical matrix."""

import argparse
from pathlib import Path

import h5py
import numpy as np
import pytest

from jamflow.mechanics.contacts import Contacts, remove_floaters
from jamflow.mechanics.deformation import PROBE, displaced, energy_change, pair_changes
from jamflow.mechanics.hessian import Coordinates, hessian
from jamflow.analysis.modes import QUARTIC_STABLE, STABLE, DensityOfStates, Spectrum, Stability
from jamflow.model.box import Box
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.io.packing_file import load_packing
from jamflow.model.packing import Packing
from jamflow.model.pairs import overlapping_sites
from jamflow.model.potentials import Spring
from test_engines import dimer
from test_hessian_shapes import model_packing

DATA = Path(__file__).parent / "data"
ELLIPSES = sorted(DATA.glob("ellipse1.5_n16_s*.h5"))


@pytest.fixture(scope="module")
def ellipses():
    return [load_packing(f) for f in ELLIPSES]


@pytest.fixture(scope="module")
def dimers():
    return load_packing(DATA / "dimer2d_a1.5_n32_s0.h5")


@pytest.mark.parametrize("model,dim", [("dimer", 2), ("trimer", 3), ("ellipsoid", 2), ("ellipsoid", 3)])
def test_energy_change_matches_reference_difference_and_quadratic_form(model, dim):
    p = model_packing(model, dim)
    c = Coordinates.of(p)
    xi = np.random.default_rng(1).normal(size=c.size)
    u, w = c.split(xi)
    direct = energy_forces_pressure(displaced(p, 1e-3 * u, 1e-3 * w)).energy - energy_forces_pressure(p).energy
    assert energy_change(p, 1e-3 * u, 1e-3 * w) == pytest.approx(direct, rel=1e-9)
    # for a tiny displacement the symmetric part is xi^T M xi / 2 (third order cancels)
    tiny = 1e-7
    sym = 0.5 * (energy_change(p, tiny * u, tiny * w) + energy_change(p, -tiny * u, -tiny * w))
    assert sym == pytest.approx(0.5 * tiny**2 * xi @ (hessian(p) @ xi), rel=1e-6)


def test_relaxed_quartic_coefficient_obeys_the_self_stress_bound(ellipses):
    """With contact forces lambda_c = -V'(s_c) (lambda^T C = 0 at force balance) every path
    correction keeps lambda^T (C eta + b) = lambda^T b, so the one-sided residual is at least
    (V''/2) (lambda^T b)^2 / |lambda|^2 (linear springs: V'' = 1); and it is at most the straight
    coefficient. lambda^T b < 0 is the stress term that makes e > 0: e = -2 lambda^T b."""
    from jamflow.mechanics.hessian import _local_index, law_derivatives, reduced_distances
    from jamflow.analysis.quartic import quartic_coefficients

    checked = 0
    for p in ellipses:
        spec = Spectrum().compute(p)
        q, coords = spec.dynamical.packing, spec.dynamical.coordinates
        null = spec.eigenvectors[:, np.abs(spec.eigenvalues) <= spec.e_min]
        red = reduced_distances(q)
        lam = -law_derivatives(q.potential, red.s)[0]
        for pr in Stability().compute(p, spec).profiles:
            if pr.behaviour != "quartic":
                continue
            local = pr.mode[_local_index(coords, red.i, red.j)]
            b = 0.5 * np.einsum("pa,pab,pb->p", local, red.d2s, local)
            assert -2 * lam @ b == pytest.approx(pr.eigenvalue, rel=1e-3)  # the stress term is e
            straight, relaxed = quartic_coefficients(q, pr.mode, null)
            bound = 0.5 * (lam @ b) ** 2 / (lam @ lam)
            assert bound * (1 - 1e-3) <= relaxed <= straight  # lambda^T C = 0 holds to ~1e-7 of |lambda|
            checked += 1
    assert checked == 10


def test_sparse_relaxed_solver_agrees_with_the_exact_one(ellipses, monkeypatch):
    """Above DENSE_MAX unknowns the relaxed problem goes to scipy's sparse trf: the same held
    coefficients (free dimer modes reach 2e-11..9e-11 of straight there, docs/notes/modes-rotations.md)."""
    from jamflow.analysis import quartic

    spec = Spectrum().compute(ellipses[0])
    null = spec.eigenvectors[:, np.abs(spec.eigenvalues) <= spec.e_min]
    held = [pr for pr in Stability().compute(ellipses[0], spec).profiles if pr.behaviour == "quartic"]
    monkeypatch.setattr(quartic, "DENSE_MAX", 0)
    for pr in held:
        straight, relaxed = quartic.quartic_coefficients(spec.dynamical.packing, pr.mode, null)
        assert straight == pytest.approx(pr.quartic_straight, rel=1e-12)
        assert relaxed == pytest.approx(pr.quartic_relaxed, rel=1e-6)


def test_stored_ellipse_packings_are_at_onset(ellipses):
    assert len(ellipses) == 3
    for p in ellipses:
        ref = energy_forces_pressure(p)
        assert 1e-16 < ref.energy / p.n < 2e-16  # the chapter's window, V_tol = 1e-16
        assert np.abs(ref.forces).max() < 1e-13 and np.abs(ref.torques).max() < 1e-13


def test_quartic_modes_number_the_missing_contacts(ellipses):
    """At onset the lowest-branch eigenvalues scale with the pressure (~1e-8 here, below
    e_min = 1e-6): they are the extra zero modes, and along each of them the energy rises as
    delta^4 once contacts have opened (the just-touching limit); their count equals the
    missing contacts, and no contact changes at first order along them."""
    for p in ellipses:
        spec = Spectrum().compute(p)
        c = spec.dynamical.contacts
        missing = -c.excess_contacts
        assert missing > 0  # hypostatic
        st = Stability().compute(p, spec)
        assert spec.n_negative == 0 and spec.n_zero == spec.dim + missing
        assert st.n_quartic == missing and st.label == QUARTIC_STABLE
        q = spec.dynamical.packing
        coords = spec.dynamical.coordinates
        quartic = [pr for pr in st.profiles if pr.behaviour == "quartic"]
        for pr in quartic:
            assert 0 < pr.eigenvalue < 1e-7
            assert abs(pr.power - 4) < 0.3
            u, w = coords.split(pr.mode)
            _, _, s, plus = pair_changes(q, PROBE * u, PROBE * w)
            _, _, _, minus = pair_changes(q, -PROBE * u, -PROBE * w)
            rate = np.abs(plus - minus)[s < 1] / (2 * PROBE)
            assert rate.max() < 1e-6  # first-order change of every contact ~ pressure
        nonzero = [pr for pr in st.profiles if pr.eigenvalue > spec.e_min]
        assert nonzero and nonzero[0].behaviour == "quadratic"
        # mostly rotational, as the seed says of the low branches (Figure 2.17)
        assert np.mean([pr.translational_fraction for pr in quartic]) < 0.5


def test_dimer_packing_obeys_maxwell_with_site_contacts(dimers):
    spec = Spectrum().compute(dimers)
    c = spec.dynamical.contacts
    assert c.is_isostatic  # N_c (site pairs) = N' d_f - d + 1
    assert spec.n_zero == 2 and spec.n_negative == 0
    st = Stability().compute(dimers, spec)
    assert st.label == STABLE and st.behaviour == "quadratic" and st.n_quartic == 0
    assert spec.translation_residual < 1e-13
    frac = spec.translational_fraction
    assert np.all((frac >= 0) & (frac <= 1 + 1e-12)) and 0.1 < frac[2:].mean() < 0.9
    # counted per pair of bodies, some pairs touch twice: fewer "contacts" than constraints
    bodies = Contacts(count="bodies", min_contacts=0).compute(dimers)
    assert bodies.n_contacts < Contacts(count="sites", min_contacts=0).compute(dimers).n_contacts


def test_load_bearing_particles_with_few_contacts_are_kept_and_turn_freely():
    """Seed Figure 2.19's exception: a particle with d + 1 .. d_f contacts whose contact forces
    balance it is no floater. In this dimer packing each such dimer carries all its contacts on
    one site; dropping it (the bare count rule) leaves its neighbours out of balance. Kept, each
    turns freely about that site: a flat zero mode carried by one particle, one per missing
    contact -- no quartic modes."""
    p = load_packing(DATA / "dimer2d_a1.5_n64_s0.h5")
    c = Contacts(count="sites").compute(p)
    plain = Contacts(count="sites", balanced_exception=False).compute(p)
    assert c.n_balanced == 3 and c.n_floaters == 0 and plain.n_floaters == 4
    bi, bj, s, t, dr, r, sigma = overlapping_sites(p)
    contact_force = np.max(1 - r / sigma)  # |f| = eps (1 - r/sigma) / sigma, sigma = 1
    whole = energy_forces_pressure(p)  # nothing removed: in balance
    assert np.abs(whole.forces).max() < 1e-13 and np.abs(whole.torques).max() < 1e-13
    dropped = energy_forces_pressure(remove_floaters(p, plain))
    assert np.abs(dropped.forces).max() > 0.1 * contact_force
    spec = Spectrum().compute(p)
    st = Stability().compute(p, spec)
    missing = -spec.dynamical.contacts.excess_contacts
    assert missing == 4 and spec.n_zero == spec.dim + missing and spec.n_negative == 0
    assert st.n_single_flat == missing and st.n_quartic == 0


def test_two_dimers_touching_at_two_site_pairs():
    body = dimer(2)
    p = Packing([[0.0, 0.0], [0.0, 0.95]], [1.0, 1.0], Box.cube(10.0, 2), Spring(), shape=body,
                orientations=[0.0, 0.0])  # parallel, one above the other: two site pairs overlap
    assert Contacts(count="sites", min_contacts=0).compute(p).n_contacts == 2
    assert Contacts(count="bodies", min_contacts=0).compute(p).n_contacts == 1
    with pytest.raises(ValueError, match="count must be"):
        Contacts(count="pairs")


def test_density_of_states_splits_by_mode_character(ellipses, dimers):
    spectra = [Spectrum().compute(p) for p in ellipses + [dimers]]
    dos = DensityOfStates(bins=20).compute(spectra)
    assert np.all(dos.translational >= -1e-12) and np.all(dos.rotational >= -1e-12)
    total_trans = sum(s.translational_fraction[s.eigenvalues > s.e_min].sum() for s in spectra)
    assert np.sum(dos.translational * np.diff(dos.edges)) * len(spectra) == pytest.approx(total_trans)
    disks = Spectrum().compute(_disks())
    assert np.allclose(disks.translational_fraction, 1.0)
    only = DensityOfStates(bins=10).compute([disks])
    assert np.allclose(only.translational, only.density)


def _disks():
    from test_contacts import triangular_lattice

    return triangular_lattice(6, 6, 0.97)


def test_stability_profiles_the_requested_modes(dimers):
    spec = Spectrum().compute(dimers)
    st = Stability(n_modes=3).compute(dimers, spec)
    assert len(st.profiles) == 3
    assert np.all(np.diff([p.eigenvalue for p in st.profiles]) >= 0)
    assert st.mode_eigenvalue == pytest.approx(spec.lowest_nonzero, rel=1e-9)
    for bad in (0, -1, "all", 1.5):
        with pytest.raises(ValueError, match="n_modes"):
            Stability(n_modes=bad)


def test_three_branches_partition_the_nontrivial_modes(ellipses):
    """Branch 1 = the extra zero modes, 2 and 3 split the nonzero ones by character at 1/2
    (chapter Figure 2.17); disks have no branches."""
    from jamflow.analysis.modes import Spectrum, branches

    spec = Spectrum().compute(ellipses[0])
    one, two, three = branches(spec)
    assert one.count == spec.n_extra_zero and one.count + two.count + three.count == spec.n_dof - spec.dim
    assert two.translational < 0.5 <= three.translational and one.omega_high < two.omega_low
    assert two.count + three.count == len(spec.nonzero)
    from jamflow import jam

    assert branches(Spectrum().compute(jam(n=16, seed=1).packing)) is None


def test_cli_stores_mode_character_and_profiles(tmp_path, capsys):
    from jamflow.cli.commands import modes

    src = ELLIPSES[0]
    target = tmp_path / src.name
    target.write_bytes(src.read_bytes())
    parser = argparse.ArgumentParser()
    modes.add_arguments(parser)
    args = parser.parse_args([str(target), "--save-vectors"])
    assert modes.run(args) == 0
    out = capsys.readouterr().out
    from jamflow.io.modes_file import read_modes

    res = read_modes(tmp_path / (target.stem + ".modes.h5"))
    missing = res["missing_contacts"]
    assert f"quartic modes {missing}, one-particle flat 0 (missing contacts {missing})" in out
    assert "extra zero modes = missing contacts 1/1, quartic modes = missing contacts 1/1" in out
    assert f"branches: 1 zero {missing} (omega" in out and "; 2 rotational " in out and "; 3 translational " in out
    assert res["schema_version"] == 2 and res["shape"] == "ellipse:1.5" and res["dof_per_particle"] == 3
    assert res["n_quartic"] == missing and res["classification"] == QUARTIC_STABLE
    assert res["n_translational"] == 2 * res["n_kept"]
    assert len(res["translational_fraction"]) == len(res["eigenvalues"]) == 3 * res["n_kept"]
    assert list(res["stability/profiles/behaviours"]).count("quartic") == missing
    assert res["stability/profiles/modes"].shape[1] == 3 * res["n_kept"]
    assert (tmp_path / (target.stem + ".modes.png")).read_bytes()[:4] == b"\x89PNG"
    with h5py.File(target, "r") as f:
        assert "eigenvalues" not in f


def test_cli_figure_colours_modes_by_character(tmp_path, monkeypatch):
    """``jamflow modes --colour fraction`` on ellipses colours each mode of panel (a) by its translational fraction
    (Figure 2.17's three branches) and draws the translational part of D(omega), as the API does:
    it once dropped the eigenvectors before drawing, and every mode came out grey (0.5)."""
    from matplotlib.axes import Axes

    from jamflow.analysis.modes import branch_labels
    from jamflow.cli.commands import modes

    drawn, stairs = [], []
    scatter, stair = Axes.scatter, Axes.stairs
    monkeypatch.setattr(Axes, "scatter", lambda ax, x, y, **kw: drawn.append(np.asarray(kw["c"])) or scatter(ax, x, y, **kw))
    monkeypatch.setattr(Axes, "stairs", lambda ax, v, e, **kw: stairs.append(kw.get("label")) or stair(ax, v, e, **kw))
    target = tmp_path / ELLIPSES[0].name
    target.write_bytes(ELLIPSES[0].read_bytes())
    parser = argparse.ArgumentParser()
    modes.add_arguments(parser)
    assert modes.run(parser.parse_args([str(target), "--colour", "fraction"])) == 0
    assert (tmp_path / (target.stem + ".modes.png")).read_bytes()[:4] == b"\x89PNG"
    spec = Spectrum().compute(ellipses_packing := load_packing(target))
    order = np.argsort(np.abs(spec.eigenvalues))[spec.dim:]
    order = order[np.argsort(spec.eigenvalues[order])]
    (colours,) = drawn
    np.testing.assert_allclose(colours, spec.translational_fraction[order], atol=1e-8)
    labels = branch_labels(spec)[order]
    assert colours[labels == 2].max() < 0.5 < colours[labels == 3].min()  # rotational blue-red split, not grey
    assert "translational part" in stairs and ellipses_packing.shape.oriented


def drawn_modes_figure(tmp_path, monkeypatch, *options):
    """Run ``jamflow modes`` on the first stored ellipse packing; the Figure it saves, and the packing."""
    import jamflow.plots.modes as plots
    from jamflow.cli.commands import modes

    figures, save = [], plots.save_figure
    monkeypatch.setattr(plots, "save_figure", lambda fig, path: figures.append(fig) or save(fig, path))
    target = tmp_path / ELLIPSES[0].name
    target.write_bytes(ELLIPSES[0].read_bytes())
    parser = argparse.ArgumentParser()
    modes.add_arguments(parser)
    assert modes.run(parser.parse_args([str(target), *options])) == 0
    (fig,) = figures
    return fig, load_packing(target)


def test_cli_figure_colours_the_three_branches_by_default(tmp_path, monkeypatch):
    """Panel (a) of ``jamflow modes`` on ellipses: one colour per branch of ``branch_labels``
    (the chapter's Figure 2.17), named in a legend; the colours mean one thing across the panels
    (red = zero/quartic in (a) and quartic in (d), rotational and translational neither red nor
    the blue of quadratic); omega's axes carry its units and normalisation."""
    from matplotlib.colors import to_hex

    from jamflow.analysis.modes import branch_labels

    fig, packing = drawn_modes_figure(tmp_path, monkeypatch)
    spec = Spectrum().compute(packing)
    labels = branch_labels(spec)
    a, b, _, d = fig.axes[:4]
    legend = [t.get_text() for t in a.get_legend().get_texts()]
    assert legend[:3] == ["1 zero (quartic)", "2 rotational", "3 translational"]
    colours = {}
    for collection, name, branch in zip(a.collections, legend, (1, 2, 3)):
        omega = np.sort(np.sqrt(np.abs(spec.eigenvalues[labels == branch]) / spec.mass))
        np.testing.assert_allclose(np.sort(collection.get_offsets()[:, 1]), omega, rtol=1e-8)
        (colours[branch],) = {to_hex(c) for c in collection.get_facecolors()}
    profiles = {line.get_label(): to_hex(line.get_color()) for line in d.get_lines()}
    assert colours[1] == profiles["quartic"] and profiles["quadratic"] not in colours.values()
    assert len(set(colours.values())) == 3 and to_hex("red") != colours[2]
    units = r", M = N m  [$\sqrt{\epsilon/(m\sigma^2)}$]"
    assert a.get_ylabel().endswith(units) and b.get_xlabel() == r"$\omega$" + units
    assert r"\Delta V(-\delta)" in d.get_ylabel()  # the symmetric part, spelled out


def test_modes_figure_refuses_an_unknown_colouring(tmp_path):
    from jamflow.plots.modes import modes_figure

    with pytest.raises(ValueError, match="colour must be one of branches, fraction"):
        modes_figure(tmp_path / "x.png", [], colour="rainbow")
    assert not (tmp_path / "x.png").exists()
