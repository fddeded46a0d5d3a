"""Bulk and shear moduli (chapter section 4.5): closed forms on the triangular lattice, finite
differences of the numpy reference energy, strain sweeps against the Hessian route on jammed
packings (orthogonal and tilted cells, both engines), the fit and yield logic on synthetic sweeps,
jam --above, the results file and bad input."""

from dataclasses import replace
from pathlib import Path

import h5py
import numpy as np
import pytest

from jamflow.mechanics.elastic import HessianModuli, StrainTerms, affine_terms
from jamflow.protocols.moduli import Moduli
from jamflow.mechanics.strains import BULK, SHEAR, STRAINS
from jamflow.protocols.sweeps import SweepSettings, StrainSweep, _fit, roundoff_amplitude
from jamflow.model.box import Box
from jamflow.cli.app import main
from jamflow.io.moduli_file import read_moduli
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.io.packing_file import load_packing, read_attrs, save_packing
from jamflow.model.packing import Packing
from jamflow.model.potentials import RepulsiveLJ, Spring
from jamflow.protocols.above import compress_above
from jamflow.protocols.compression import jam
from test_contacts import triangular_lattice
from test_hessian import perturbed_lattice

FEW = (1e-8, 1e-7, 1e-6, 1e-5)  # amplitudes of the quick sweeps


def lattice_moduli(potential, spacing):
    """Closed form for the triangular lattice of unit disks at ``spacing`` < 1 (every bond at
    angles 0, 60, 120 deg; area per particle A = sqrt(3)/2 l^2; no non-affine relaxation, every
    particle is a centre of inversion): P = -3 V' l / (2A), B = 3 V'' l^2 / (4A) + P / 2,
    G = [3/8 V'' l^2 + 9/8 V' l] / A (the unstressed limit is sqrt(3) k / 4)."""
    v1 = float(potential.dv_dr(np.array([spacing]), 1.0)[0])
    v2 = float(potential.d2v_dr2(np.array([spacing]), 1.0)[0])
    area = np.sqrt(3) / 2 * spacing**2
    p = -3 * v1 * spacing / (2 * area)
    return dict(P=p, B=3 * v2 * spacing**2 / (4 * area) + p / 2, G=(3 / 8 * v2 * spacing**2 + 9 / 8 * v1 * spacing) / area)


@pytest.fixture(scope="module")
def jammed():
    """N = 64 bidisperse disks at phi_J + 1e-3 (spring)."""
    return compress_above(jam(n=64, seed=1).packing, 1e-3).packing


# --- the strains -----------------------------------------------------------------------------------

@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("strain", STRAINS, ids=lambda s: s.kind)
def test_strain_cell_is_the_gradient_and_velocity_its_derivative(strain, dim):
    h = np.triu(np.arange(1.0, 1.0 + dim * dim).reshape(dim, dim)) + 5 * np.eye(dim)
    box = Box(h)
    a = 3e-3
    assert np.allclose(strain.cell(box, a).h, strain.gradient(a, dim) @ box.h, rtol=0, atol=1e-14)
    step = 1e-6
    fd = (strain.gradient(step, dim) - strain.gradient(-step, dim)) / (2 * step)
    assert np.allclose(fd, strain.velocity(dim), atol=1e-9)


def test_bulk_strain_is_log_phi_and_shear_keeps_volume():
    p = triangular_lattice(8, 8, 0.95)
    squeezed = p.with_positions(p.positions, box=BULK.cell(p.box, 0.01))
    assert np.log(squeezed.phi / p.phi) == pytest.approx(0.01, rel=1e-12)
    sheared = SHEAR.cell(p.box, 0.01)
    assert sheared.volume == pytest.approx(p.box.volume, rel=1e-15)
    assert sheared.shear_strain == pytest.approx(p.box.shear_strain + 0.01, abs=1e-15)


# --- closed forms ------------------------------------------------------------------------------------

@pytest.mark.parametrize("potential", [Spring(2.0), Spring(2.5), RepulsiveLJ()], ids=lambda p: p.spec)
def test_triangular_lattice_hessian_moduli_match_the_closed_form(potential):
    spacing = 0.95 if potential.name == "spring" else 0.98
    p = replace(triangular_lattice(8, 8, spacing), potential=potential)
    exact = lattice_moduli(potential, spacing)
    h = HessianModuli().compute(p)
    assert h.G == pytest.approx(exact["G"], rel=1e-12)
    assert h.B == pytest.approx(exact["B"], rel=1e-12)
    assert np.trace(h.pressure_tensor) / 2 == pytest.approx(exact["P"], rel=1e-12)
    assert h.G_affine == pytest.approx(h.G, rel=1e-12) and h.B_affine == pytest.approx(h.B, rel=1e-12)  # no relaxation


def test_nearly_unstressed_lattice_has_the_textbook_moduli():
    """Bonds a hair inside contact (overlap 1e-9, k = V'' = 1): the central-force triangular
    network's mu = sqrt(3) k / 4 and B = sqrt(3) k / 2 (e.g. Kittel; Maxwell-counted networks)."""
    h = HessianModuli().compute(triangular_lattice(8, 8, 1 - 1e-9))
    assert h.G == pytest.approx(np.sqrt(3) / 4, rel=1e-8)
    assert h.B == pytest.approx(np.sqrt(3) / 2, rel=1e-8)


@pytest.mark.parametrize("potential", [Spring(2.0), Spring(2.5)], ids=lambda p: p.spec)
def test_triangular_lattice_sweeps_match_the_closed_form(potential):
    p = replace(triangular_lattice(8, 8, 0.95), potential=potential)
    exact = lattice_moduli(potential, 0.95)
    sweep = StrainSweep(SweepSettings(FEW))
    for strain in STRAINS:
        result = sweep.compute(p, strain)
        assert result.modulus == pytest.approx(exact[strain.modulus], rel=1e-8)
        assert np.isnan(result.yield_strain)
        assert result.base_response == pytest.approx(exact["P"] if strain is BULK else 0.0,
                                                     rel=1e-12, abs=1e-14)


# --- finite differences of the numpy reference ----------------------------------------------------

DATA = Path(__file__).parent / "data"


def compressed(name, factor):
    p = load_packing(DATA / name)
    return p.with_positions(p.positions * factor ** 0.5, box=p.box.scaled(factor ** 0.5))


OFF_BALANCE = {  # overlaps 1e-3 .. 20 %, no contact within a finite-difference step of its edge
    "disks": lambda: perturbed_lattice(2, seed=2), "spheres": lambda: perturbed_lattice(3, seed=2),
    "ellipses": lambda: compressed("ellipse1.5_n16_s0.h5", 0.99),
    "dimers": lambda: compressed("dimer2d_a1.5_n32_s0.h5", 0.99)}


@pytest.mark.parametrize("name", sorted(OFF_BALANCE))
@pytest.mark.parametrize("strain", STRAINS, ids=lambda s: s.kind)
def test_affine_terms_are_derivatives_of_the_reference_energy(strain, name):
    """A = d^2 U / da^2 along x -> (I + a L) x (box too, orientations carried unturned); Xi's
    centre rows = d/da of the gradient in the reference coordinates, (I + a L)^T grad U, minus
    L^T grad U (nonzero off balance); its rotation rows = -d/da of the generalized torques tau/d_k."""
    p = OFF_BALANCE[name]()
    dim, lvel = p.dim, strain.velocity(p.dim)
    a, xi = affine_terms(StrainTerms.of(p), strain)

    def reference(step):
        f = np.eye(dim) + step * lvel
        return energy_forces_pressure(p.with_positions(p.positions @ f.T, box=p.box.with_h(f @ p.box.h)))

    step = 1e-5
    energies = [reference(s).energy for s in (-step, 0.0, step)]
    assert (energies[0] - 2 * energies[1] + energies[2]) / step**2 == pytest.approx(a, rel=1e-5)
    step = 1e-6
    low, high = reference(-step), reference(step)
    grads = [-r.forces @ (np.eye(dim) + s * lvel) for r, s in ((low, -step), (high, step))]
    fd = ((grads[1] - grads[0]) / (2 * step)).ravel()
    balance = (-energy_forces_pressure(p).forces @ lvel).ravel()  # L^T g per particle
    n_t = p.n * dim
    assert np.allclose(xi[:n_t] + balance, fd, rtol=0, atol=1e-6 * np.abs(fd).max())
    if p.shape.oriented:
        torque_fd = -(high.torques - low.torques) / (2 * step) / p.rotational_lengths[:, 0]
        assert np.allclose(xi[n_t:], torque_fd, rtol=0, atol=1e-6 * np.abs(torque_fd).max())


# --- the two routes on jammed packings ----------------------------------------------------------------

def test_sweeps_agree_with_the_hessian_on_a_jammed_packing(jammed):
    result = Moduli().compute(jammed)
    for strain in STRAINS:
        sweep = result.sweep(strain)
        assert abs(result.agreement(strain)) < 1e-6, strain.kind
        assert sweep.error < 1e-6 * abs(sweep.modulus)
        assert sweep.linear.sum() >= 3
    assert 0 < result.G < result.hessian.G_affine and 0 < result.B < result.hessian.B_affine
    assert result.hessian.n_negative == 0 and result.hessian.n_extra_zero == 0
    assert result.pressure == pytest.approx(np.trace(result.hessian.pressure_tensor) / 2, rel=1e-10)


def test_sweeps_agree_with_the_hessian_in_a_tilted_cell(jammed):
    """The jammed packing sheared to gamma = 0.37 (accumulated tilt) and relaxed there."""
    tilted = compress_above(jammed.with_positions(jammed.positions @ SHEAR.gradient(0.37, 2).T,
                                                  box=SHEAR.cell(jammed.box, 0.37)), 1e-4).packing
    assert tilted.box.shear_strain == pytest.approx(jammed.box.shear_strain + 0.37, rel=1e-12)
    result = Moduli(SweepSettings(FEW)).compute(tilted)
    for strain in STRAINS:
        assert abs(result.agreement(strain)) < 1e-6, strain.kind


def test_dimer_sweeps_agree_with_the_hessian_with_rotations():
    """32 dimers at phi_J + 1e-3: the compiled FIRE relaxes centres and rotations, the Hessian
    has the rotational coordinates; this packing's shear modulus is negative (residual shear
    stress), both routes say so."""
    p = compress_above(load_packing(DATA / "dimer2d_a1.5_n32_s0.h5"), 1e-3).packing
    result = Moduli(SweepSettings((1e-8, 1e-7, 1e-6))).compute(p)
    for strain in STRAINS:
        assert abs(result.agreement(strain)) < 1e-6, strain.kind
    assert result.hessian.n_negative == 0 and result.G < 0 < result.B


@pytest.mark.filterwarnings("error:the dynamical matrix has")
def test_ellipse_sweeps_match_the_hessian_route():
    """With the ellipse kernel the compiled engine relaxes ellipses, positions and
    orientations, under strain: the sweeps' G and B agree with the Hessian route's (rotations in
    the dynamical matrix) on the stored N = 16 packing at phi_J + 1e-3, minimised there (a stable
    minimum: no negative eigenvalue beyond round-off, on the input and on the sweeps' base state;
    the affinely compressed file without the minimisation has one, a saddle)."""
    p = compress_above(load_packing(DATA / "ellipse1.5_n16_s0.h5"), 1e-3).packing
    moduli = Moduli()
    checked = moduli.check(p)
    assert checked[0].n_negative == 0 and checked[0].lowest_eigenvalue > 0
    result = moduli.compute(p, checked=checked)
    assert result.hessian.n_negative == 0 and result.hessian.lowest_eigenvalue > 0
    assert result.G == pytest.approx(result.hessian.G, rel=1e-6) and result.G > 0
    assert result.B == pytest.approx(result.hessian.B, rel=1e-6)


def test_lammps_sweeps_match_the_compiled_engine(jammed):
    settings = SweepSettings((1e-7, 1e-6, 1e-5))
    compiled = StrainSweep(settings, engine="numba").compute(jammed, SHEAR)
    lammps = StrainSweep(settings, engine="lammps").compute(jammed, SHEAR)
    assert lammps.modulus == pytest.approx(compiled.modulus, rel=1e-6)


def test_shear_yield_is_seen_and_marked(jammed):
    """Up to strain 1e-2 the N = 64 packing at 1e-3 rearranges: contacts change, yield_strain is
    the first amplitude where they do, and the linear regime ends below it."""
    result = StrainSweep(SweepSettings(tuple(np.geomspace(1e-6, 1e-2, 9)), past_yield=1)).compute(jammed, SHEAR)
    assert np.isfinite(result.yield_strain) and result.yield_reason in ("contacts", "stress")
    assert result.linear_max < result.yield_strain
    k = int(np.argmin(np.abs(result.amplitudes - result.yield_strain)))
    assert len(result.amplitudes) == k + 2  # stopped one amplitude past the yield
    at = np.isin(np.abs(result.strains), result.amplitudes[k])
    if result.yield_reason == "contacts":
        assert np.any(result.added[at] + result.removed[at] > 0)


# --- the fit on synthetic sweeps --------------------------------------------------------------------

def synthetic(amps, modulus, cubic=0.0, noise=0.0, changed_from=None, drop_from=None, seed=0):
    rng = np.random.default_rng(seed)
    points = {0.0: dict(response=1.0, added=0, removed=0, reason="force")}
    for a in amps:
        for s in (a, -a):
            r = 1.0 + modulus * s + cubic * s**3 + noise * rng.normal()
            if drop_from is not None and a >= drop_from * (1 - 1e-9):
                r -= 0.9 * modulus * s
            change = int(changed_from is not None and a >= changed_from * (1 - 1e-9))
            points[s] = dict(response=r, added=change, removed=0, reason="force")
    return points


def test_fit_recovers_the_modulus_through_round_off_and_curvature():
    amps = np.geomspace(1e-9, 1e-3, 13)
    points = synthetic(amps, 2.0, cubic=-2e4, noise=1e-15)
    fit = _fit(SHEAR, points, SweepSettings(tuple(amps)))
    assert fit["modulus"] == pytest.approx(2.0, rel=1e-8)
    assert fit["error"] < 1e-7
    assert np.isnan(fit["yield_strain"])
    assert not fit["linear"][-1]  # c(1e-3) = 2 - 2e-2: curvature beyond the tolerance


def test_fit_flags_contact_changes_and_stress_drops():
    amps = np.geomspace(1e-9, 1e-4, 11)
    fit = _fit(SHEAR, synthetic(amps, 2.0, changed_from=1e-6), SweepSettings(tuple(amps)))
    assert fit["yield_strain"] == pytest.approx(1e-6) and fit["yield_reason"] == "contacts"
    assert fit["linear"].sum() == 6 and fit["modulus"] == pytest.approx(2.0, rel=1e-8)  # R0 = 1: round-off 1e-16 / 1e-9
    fit = _fit(SHEAR, synthetic(amps, 2.0, drop_from=1e-5), SweepSettings(tuple(amps)))
    assert fit["yield_strain"] == pytest.approx(1e-5) and fit["yield_reason"] == "stress"


def test_round_off_at_the_smallest_amplitude_is_no_yield():
    """Noise that throws the 1e-9 slope off by 100 % once, then fades, is not a yield."""
    amps = np.geomspace(1e-9, 1e-5, 9)
    points = synthetic(amps, 1.0, noise=0.0)
    points[1e-9]["response"] += 2e-9
    fit = _fit(SHEAR, points, SweepSettings(tuple(amps)))
    assert np.isnan(fit["yield_strain"])
    assert not fit["linear"][0] and fit["modulus"] == pytest.approx(1.0, rel=1e-8)


# --- bad input ----------------------------------------------------------------------------------------

def test_unjammed_packing_is_refused_before_work():
    p = triangular_lattice(8, 8, 1.05)  # no overlaps: V = 0
    with pytest.raises(ValueError, match="not jammed"):
        Moduli().check(p)


def test_floaters_only_are_refused():
    """Two overlapping disks in a large box: V > 0, but both are floaters."""
    p = Packing([[1.0, 1.0], [1.9, 1.0]], [1.0, 1.0], Box.cube(10.0, 2))
    with pytest.raises(ValueError, match="every particle is a floater"):
        Moduli().check(p)


def test_amplitude_below_round_off_is_refused(jammed):
    scale = roundoff_amplitude(jammed, HessianModuli().compute(jammed).G)
    assert 1e-14 < scale < 1e-9
    with pytest.raises(ValueError, match="below the round-off scale"):
        Moduli(SweepSettings((scale / 10, 1e-6))).check(jammed)


def test_walled_packing_is_refused():
    p = Packing([[1.0, 1.0], [1.9, 1.0]], [1.0, 1.0], Box(np.eye(2) * 10, periodic=(True, False)))
    with pytest.raises(ValueError, match="periodic box"):
        Moduli().check(p)


@pytest.mark.parametrize("amps, match", [((), "finite positive"), ((1e-6, 1e-7), "increasing"),
                                          ((1e-6, np.nan), "finite positive"), ((1e-3, 0.7), "not a small strain")])
def test_bad_sweep_settings(amps, match):
    with pytest.raises(ValueError, match=match):
        SweepSettings(amps)


# --- jam --above, the command and its file ------------------------------------------------------------

def test_compress_above_reaches_phi_and_force_balance():
    onset = jam(n=32, seed=2)
    above = compress_above(onset.packing, 1e-4)
    assert above.packing.phi == pytest.approx(onset.phi_j + 1e-4, abs=1e-12)
    assert above.minimization.converged and above.pressure > onset.pressure
    assert above.dphi == 1e-4 and above.phi_onset == onset.packing.phi


def test_compress_above_refuses_a_packing_that_relaxes_unjammed():
    """A dilute start with overlaps (V > 0 but far below phi_J) relaxes to V < V_min after the step:
    JammingFailed, not a packing 'above onset' with no contacts."""
    from jamflow.model.packing import random_packing
    from jamflow.model.sizes import parse_sizes
    from jamflow.protocols.outcome import JammingFailed

    dilute = random_packing(32, 2, parse_sizes("bi:1.4:0.5"), phi=0.5, seed=0)
    with pytest.raises(JammingFailed, match="not jammed at phi_J"):
        compress_above(dilute, 1e-4)


@pytest.mark.parametrize("value", ["-1e-4", "0", "nan", "inf", "1.5"])
def test_jam_above_refuses_bad_steps_before_work(value, tmp_path, capsys):
    assert main(["jam", "--n", "32", f"--above={value}", "--out", str(tmp_path / "p.h5"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "--above" in err and len(err.strip().splitlines()) == 1
    assert not list(tmp_path.iterdir())


def test_moduli_command_writes_the_contract(tmp_path, capsys):
    packing = tmp_path / "p.h5"
    assert main(["jam", "--n", "32", "--seed", "3", "--above", "1e-3", "--out", str(packing), "--quiet"]) == 0
    attrs = read_attrs(packing)
    assert attrs["dphi_above"] == 1e-3
    assert attrs["phi"] == pytest.approx(h5py.File(packing)["protocol"].attrs["phi_onset"] + 1e-3, abs=1e-12)
    assert main(["moduli", str(packing), "--min-amplitude", "1e-8", "--max-amplitude", "1e-4", "--quiet"]) == 0
    out = read_moduli(tmp_path / "p.moduli.h5")
    for name in ("G", "B", "G_hessian", "B_hessian", "yield_strain"):
        assert name in out
    assert abs(out["G"] / out["G_hessian"] - 1) < 1e-5 and abs(out["B"] / out["B_hessian"] - 1) < 1e-6
    assert out["dphi_above"] == 1e-3
    assert out["shear/strain"].shape == out["shear/response"].shape and 0.0 in out["shear/strain"]
    assert np.allclose(out["bulk/phi"], out["phi"] * np.exp(out["bulk/strain"]))
    assert sorted(f.name for f in tmp_path.iterdir()) == ["p.h5", "p.moduli.h5", "p.moduli.png"]
    assert "G = " in capsys.readouterr().out


def test_moduli_command_refuses_every_input_before_work(tmp_path, capsys):
    good = tmp_path / "good.h5"
    save_packing(good, triangular_lattice(8, 8, 0.95))
    loose = tmp_path / "loose.h5"
    save_packing(loose, triangular_lattice(8, 8, 1.05))
    assert main(["moduli", str(good), str(loose), "--quiet"]) == 2
    assert "not jammed" in capsys.readouterr().err
    assert sorted(f.name for f in tmp_path.iterdir()) == ["good.h5", "loose.h5"]
    assert main(["moduli", str(good), "--min-amplitude", "1e-3", "--max-amplitude", "1e-6"]) == 2
    assert main(["moduli", str(tmp_path / "missing.h5")]) == 2
    capsys.readouterr()
    assert main(["moduli", str(good), "--min-amplitude", "1e-20", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "below the round-off scale" in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert sorted(f.name for f in tmp_path.iterdir()) == ["good.h5", "loose.h5"]


def test_lattice_file_round_trip_through_the_command(tmp_path):
    path = tmp_path / "lattice.h5"
    save_packing(path, triangular_lattice(8, 8, 0.95))
    assert main(["moduli", str(path), "--min-amplitude", "1e-8", "--max-amplitude", "1e-5", "--no-figure",
                 "--quiet"]) == 0
    out = read_moduli(tmp_path / "lattice.moduli.h5")
    exact = lattice_moduli(Spring(), 0.95)
    assert out["G"] == pytest.approx(exact["G"], rel=1e-8) and out["G_hessian"] == pytest.approx(exact["G"], rel=1e-12)
    assert np.isnan(out["yield_strain"]) and np.isnan(out["dphi_above"])
    assert load_packing(path).n == 64
