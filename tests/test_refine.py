"""Double-double refinement of jammed disk packings (docs/guide/precision.md): force balance, pressure and the
isostatic contact count at p = 1e-14, where float64 cannot resolve the overlaps; agreement with the
float64 constant-pressure minimisation where float64 suffices; the packing file's low parts."""

import math
import warnings
from dataclasses import replace
from fractions import Fraction
from pathlib import Path

import h5py
import numpy as np
import pytest
from test_ddouble import exact, exact_spring

import jamflow
from jamflow.io.packing_file import load_packing, save_packing
from jamflow.mechanics.checks import check_packing
from jamflow.protocols.pressure import PressureSettings, jam_at_pressure, pressure_floor
from jamflow.protocols.refine import RefineSettings, check_refine, dd_pressure_floor, refine

DATA = Path(__file__).parent / "data"


@pytest.fixture(scope="module")
def onset32():
    return jamflow.jam(n=32, seed=1, engine="numba").packing


@pytest.fixture(scope="module")
def onset1024():
    return jamflow.jam(n=1024, seed=1, engine="numba").packing


@pytest.fixture(scope="module")
def refined32(onset32):
    return refine(onset32, 1e-14)


def test_refine_result_repr_is_one_short_line(refined32):
    text = repr(refined32)
    assert "\n" not in text and len(text) < 300, text
    assert text.startswith("RefineResult(N=32, dim=2, P_target=1.000e-14") and f"N_c={refined32.n_contacts}" in text


def test_refined_packing_at_1e_14_is_balanced_isostatic_and_at_its_pressure(refined32):
    r = refined32
    assert r.packing.precision == "double-double" and np.abs(r.packing.positions_lo).max() > 0
    assert abs(r.pressure / 1e-14 - 1) < 1e-2
    assert r.force_balance < 1e-10
    assert r.n_contacts == r.isostatic_contacts == (32 - r.n_floaters) * 2 - 1
    opened, closed = r.contact_changes()
    assert not opened and not closed  # no contact lost to round-off on the way down from the onset
    assert r.checks().passed


def test_force_balance_of_the_refined_packing_in_exact_arithmetic(refined32):
    """The pure-Python reference (Fractions, the law of potentials.spring_energy_force) on hi + lo."""
    p = refined32.packing
    _, forces, virial, overlaps = exact_spring(p.positions, p.positions_lo, p.box.lengths, p.lengths_lo,
                                                    p.diameters)
    floater = refined32.network.floater
    contact = {k: o for k, o in overlaps.items() if o > 0}
    assert len(contact) == refined32.n_contacts  # floaters touch nothing
    mean_f = sum(contact.values()) / len(contact) / Fraction(1.2) ** 2  # ~ eps delta / sigma^2
    worst = max(math.hypot(*(float(v) for v in forces[k])) for k in range(p.n) if not floater[k])
    assert worst / float(mean_f) < 1e-10
    volume = exact(p.box.lengths[0], p.lengths_lo[0]) * exact(p.box.lengths[1], p.lengths_lo[1])
    pressure = (virial[0][0] + virial[1][1]) / (2 * volume)
    assert abs(float(pressure) / 1e-14 - 1) < 1e-2
    assert abs(float(pressure) / refined32.pressure - 1) < 1e-12


def test_float64_cannot_resolve_the_refined_packing(refined32):
    """The same state in float64 (hi only): overlaps below an ulp, so the float64 force balance is lost."""
    p = refined32.packing
    assert p.with_positions(p.positions + 1e-3).extended is None  # a float64 move drops the low parts
    hi = replace(p, extended=None)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        checks = check_packing(hi)
    assert checks.force_ratio > 1e-3 or checks.n_contacts != refined32.n_contacts


def test_refine_reproduces_the_float64_minimum_at_1e_6(onset32):
    """Where float64 suffices the double-double walk lands on the float64 enthalpy minimum."""
    r = refine(onset32, 1e-6)
    f64 = jam_at_pressure(onset32, PressureSettings(pressures=(1e-6,)), engine="numba")
    assert abs(f64.pressure / 1e-6 - 1) < 1e-6 and abs(r.pressure / 1e-6 - 1) < 1e-4
    assert abs(r.packing.phi - f64.phi) < 1e-10  # measured 4.4e-16
    dr = r.packing.box.minimum_image(r.packing.positions - f64.packing.box.wrap(f64.packing.positions)
                                     * (r.packing.box.lengths / f64.packing.box.lengths))
    live = ~r.network.floater
    dr = dr[live] - dr[live].mean(axis=0)  # FIRE may drift the whole packing: compare up to a translation
    assert np.abs(dr).max() < 1e-9  # measured 9e-13
    assert r.n_contacts == check_packing(f64.packing).n_contacts


def test_n64_at_1e_14():
    onset = jamflow.jam(n=64, seed=2, engine="numba").packing
    r = refine(onset, 1e-14)
    assert abs(r.pressure / 1e-14 - 1) < 1e-2 and r.force_balance < 1e-10
    assert r.n_contacts == r.isostatic_contacts


def test_targets_below_the_double_double_floor_are_refused_with_the_floor(onset32):
    floor = dd_pressure_floor(onset32)
    # float64: 1000 x the round-off floor; double-double: 2^-52 of it, and 1 / force_tol = 1e12 x
    assert floor == pytest.approx(pressure_floor(onset32, jamflow.MinimizerSettings()) / 1000 * 2.0**-52 * 1e12)
    assert 1e-18 < floor < 3e-18  # 1.9e-18 for 2D bidisperse disks at N = 32
    assert dd_pressure_floor(onset32, 1e-6) == pytest.approx(floor * 1e-6)
    with pytest.raises(ValueError, match=f"P >= {floor:.1e}"):
        refine(onset32, floor / 2)
    with pytest.raises(ValueError, match="linear spring"):
        check_refine(jamflow.Packing(onset32.positions, onset32.diameters, onset32.box, jamflow.Spring(2.5)),
                     RefineSettings(1e-10))


def test_packing_file_round_trip_keeps_the_low_parts(refined32, tmp_path):
    path = refined32.save(tmp_path / "dd.h5")
    with h5py.File(path) as f:
        assert f.attrs["precision"] == "double-double"
        assert f["positions_lo"].shape == (32, 2)
    back = load_packing(path)
    assert np.array_equal(back.positions, refined32.packing.positions)
    assert np.array_equal(back.positions_lo, refined32.packing.positions_lo)
    assert np.array_equal(back.lengths_lo, refined32.packing.lengths_lo)
    again = refine(back, 1e-14)  # already balanced: no rescaling, Newton finds it converged
    assert again.history["newton_steps"][0] == 0


def test_check_packing_reads_the_double_double_overlaps(refined32, tmp_path, recwarn):
    """At p = 1e-14 the overlaps (~1e-14) are below an ulp of a coordinate: from the float64
    positions the net forces are round-off as large as the contact forces; from hi + lo the checks
    see the refinement's balance, the same contacts and its energy."""
    back = load_packing(refined32.save(tmp_path / "dd.h5"))
    checks = check_packing(back)
    assert not [w for w in recwarn if "extended precision" in str(w.message)]
    assert checks.force_ratio < 1e-10 and checks.force_balanced
    assert checks.n_contacts == refined32.n_contacts and checks.n_floaters == refined32.n_floaters
    assert checks.energy_per_particle == pytest.approx(refined32.energy_per_particle, rel=1e-12)
    float64_only = check_packing(replace(back, extended=None))
    assert float64_only.force_ratio > 1e-6  # what the checks saw before they read hi + lo


@pytest.mark.parametrize("bad, message", [(np.zeros((31, 2)), r"positions_lo must have shape \(32, 2\)"),
                                          (np.full((32, 2), np.nan), "positions_lo must be finite")])
def test_files_with_bad_low_parts_are_refused_with_their_name(onset32, tmp_path, bad, message):
    path = save_packing(tmp_path / "bad.h5", onset32)
    with h5py.File(path, "a") as f:
        f["positions_lo"] = bad
    with pytest.raises(ValueError, match=f"{path}.*{message}"):
        load_packing(path)


def test_cli_jam_double_double_and_refine(tmp_path, capsys):
    from jamflow.cli.app import main

    out = tmp_path / "dd.h5"
    assert main(["jam", "--n", "32", "--seed", "1", "--precision", "double-double", "--pressure", "1e-14",
                 "--out", str(out), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "float64 onset phi_J" in text and "N_c = 61 (isostatic 61" in text
    p = load_packing(out)
    assert p.precision == "double-double"
    again = tmp_path / "again.h5"
    assert main(["refine", str(out), "--pressure", "1e-12", "--out", str(again)]) == 0
    with h5py.File(again) as f:
        assert f.attrs["precision"] == "double-double" and abs(f.attrs["pressure"] / 1e-12 - 1) < 1e-2
        assert f["checks"].attrs["passed"] and f["checks"].attrs["n_contacts"] == 61


@pytest.mark.parametrize("argv, message", [
    (["jam", "--precision", "double-double", "--pressure", "1e-14", "--engine", "lammps"], "needs the numba engine"),
    (["jam", "--precision", "double-double", "--pressure", "1e-14", "--vtol", "1e-24"], "not both"),
    (["jam", "--precision", "double-double", "--pressure", "1e-30"], "P >= 1.9e-18"),
    (["jam", "--pressure", "1e-14"], "or --precision double-double"),
])
def test_cli_refusals_before_work(tmp_path, capsys, argv, message):
    from jamflow.cli.app import main

    out = tmp_path / "x.h5"
    assert main([*argv, "--out", str(out)]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_cli_refine_refuses_a_target_below_the_floor(onset32, tmp_path, capsys):
    from jamflow.cli.app import main

    path = save_packing(tmp_path / "onset.h5", onset32)
    assert main(["refine", str(path), "--pressure", "1e-25", "--out", str(tmp_path / "x.h5")]) == 2
    assert "below what double-double resolves" in capsys.readouterr().err


def test_compression_through_contact_changes():
    """Up to p = 1e-3 (p N^2 ~ 4) the network rearranges: a contact in tension without which another
    overlaps makes the network solves cycle; the float64 FIRE fallback finds the new network and
    the double-double Newton balances it."""
    onset = jamflow.jam(n=64, seed=1, engine="numba").packing
    r = refine(onset, 1e-3)
    opened, closed = r.contact_changes()
    assert opened and closed
    assert abs(r.pressure / 1e-3 - 1) < 1e-4 and r.force_balance < 1e-12
    assert r.n_contacts >= r.isostatic_contacts and r.checks().passed


def test_phi_of_the_history_comes_from_the_double_double_box(refined32):
    """phi = hi + lo from the double-double box sides, checked in exact rational arithmetic (it was
    the float64 quotient by the high part of the volume: no phi_lo, phi - phi_J unresolved at 1e-14)."""
    p = refined32.packing
    hi, lo = refined32.phi
    assert (hi, lo) == (refined32.history["phi"][-1], refined32.history["phi_lo"][-1])
    volume = exact(p.box.lengths[0], p.lengths_lo[0]) * exact(p.box.lengths[1], p.lengths_lo[1])
    phi = Fraction(float(p.volumes.sum())) / volume
    assert abs(float(Fraction(hi) + Fraction(lo) - phi)) < 1e-29
    assert lo != 0.0 and abs(lo) <= 0.5 * np.spacing(hi)


def test_hessian_moduli_on_the_double_double_network(onset32, refined32):
    """Where float64 resolves the contacts (p = 1e-6) the Hessian route on the double-double network
    gives HessianModuli's G and B of the float64 positions; at 1e-14 it stays positive (rigid)."""
    from jamflow.mechanics.elastic import HessianModuli

    r = refine(onset32, 1e-6)
    m = r.moduli()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        h = HessianModuli().compute(replace(r.packing, extended=None))
    assert m.n_contacts == h.n_contacts == r.n_contacts
    assert abs(m.G / h.G - 1) < 1e-6 and abs(m.B / h.B - 1) < 1e-6
    low = refined32.moduli()
    assert low.G > 0 and low.n_contacts == refined32.n_contacts
    assert abs(np.trace(low.pressure_tensor) / 2 / refined32.pressure - 1) < 1e-6


def _enthalpy_minimum(n: int, dim: int, seed: int, last: int):
    """The float64 onset of ``seed`` taken down in pressure, two a decade from 1e-2 to 10^(-last/2)."""
    pk = jamflow.jam(n=n, dim=dim, seed=seed, engine="numba").packing
    for k in range(4, last + 1):
        pk = jam_at_pressure(pk, PressureSettings((10 ** (-k / 2),)), engine="numba").packing
    return pk


def test_a_floater_wedged_at_the_float64_round_off_is_freed():
    """N = 64, seed 7, its float64 enthalpy minimum at p = 1e-8 (from 1e-2, two pressures a decade):
    floater 28 touches particles 1 and 14 with overlaps ~1.4e-14 (float64 round-off) along nearly
    opposite normals, its net force ~0; moving it by F / k never closed them ("floaters still
    overlap after 200 relief sweeps", failed before); it now escapes along its contact normals."""
    r = refine(_enthalpy_minimum(n=64, dim=2, seed=7, last=16), 1e-8)
    assert abs(r.pressure / 1e-8 - 1) < 1e-3 and r.force_balance < 1e-10
    assert not r.network.floater_overlaps and r.n_contacts >= r.isostatic_contacts


def test_a_3d_floater_held_by_three_contacts_around_it_is_freed():
    """3D N = 128, seed 2, its float64 enthalpy minimum at p = 1e-5 (from 1e-2): floater 15 has three
    contacts (overlaps ~1e-9) with no direction opening all three along their summed normals; the
    least-norm move n_c . dx = overlap_c frees it (before: "floaters still overlap after 200 relief
    sweeps")."""
    r = refine(_enthalpy_minimum(n=128, dim=3, seed=2, last=10), 1e-5)
    assert abs(r.pressure / 1e-5 - 1) < 1e-3 and r.force_balance < 1e-10
    assert not r.network.floater_overlaps and r.n_contacts >= r.isostatic_contacts


def test_least_distance_closed_forms():
    """The shortest dx with normals @ dx >= lower (Lawson & Hanson's least-distance programming):
    three normals 120 degrees apart (a caged floater); a dimer, two moves, with one constraint on
    their difference."""
    from jamflow.protocols.refine import _least_distance

    normals = np.array([[1.0, 0.0], [-0.5, math.sqrt(3) / 2], [-0.5, -math.sqrt(3) / 2]])
    # open the first contact by 1, approach the others by up to 1: dx = (1, 0), one constraint active
    np.testing.assert_allclose(_least_distance(normals, np.array([1.0, -1.0, -1.0])), [1.0, 0.0], atol=1e-15)
    # approach the second by at most 0.2: the first two active, dx solves both equalities
    move = _least_distance(normals, np.array([1.0, -0.2, -1.0]))
    np.testing.assert_allclose(normals[:2] @ move, [1.0, -0.2], atol=1e-12)
    assert normals[2] @ move >= -1.0
    assert _least_distance(normals, np.array([1.0, 0.0, 0.0])) is None  # caged tight: no move opens one
    # dimer a-b along x: a pushed off its left neighbour by 1, b behind it (x_b - x_a >= 0), b's right
    # neighbour allows it 3: both move by 1; with 0.5 allowed the cage is closed
    g = np.array([[1.0, 0.0, 0.0, 0.0], [-1.0, 0.0, 1.0, 0.0], [0.0, 0.0, -1.0, 0.0]])
    np.testing.assert_allclose(_least_distance(g, np.array([1.0, 0.0, -3.0])), [1.0, 0.0, 1.0, 0.0], atol=1e-12)
    assert _least_distance(g, np.array([1.0, 0.0, -0.5])) is None


def test_a_floater_caged_at_the_float64_round_off_is_freed(onset1024):
    """2D N = 1024, seed 1, at its float64 onset: floater 458 touches 991 (overlap ~1e-15, the float64
    round-off) inside a cage of 176, 638 and 991 whose normals surround it, so no move keeps clear of
    all three; moving it by F / k shrank the overlap to 4e-18 and stalled there ("floaters still
    overlap after 200 relief sweeps", failed before); the least move that opens the contact and
    approaches the others by at most half their gaps frees it."""
    from jamflow.protocols.refine import _relieve_floaters, _State, evaluate

    st = _State.of(onset1024)
    _, net = _relieve_floaters(onset1024, st, evaluate(onset1024, st))
    assert not net.floater_overlaps


def test_n1024_seed1_refines_from_its_onset(onset1024):
    """After the Newton step at the onset's pressure floaters 176 and 458 (nearly touching, gap
    ~4e-15) overlap their neighbours 13, 638 and 991 by 1e-11 to 2.5e-10; neither frees alone (458 is
    caged by 638, 991 and 176), so relief failed ("floaters still overlap after 200 relief sweeps",
    exit 3 of ``jamflow refine``); the pair moves together (``_cluster_move``)."""
    r = refine(onset1024, 1e-14)
    assert abs(r.pressure / 1e-14 - 1) < 1e-2 and r.force_balance < 1e-10
    assert r.network.floater[[176, 458]].all() and not r.network.floater_overlaps
    assert r.n_contacts >= r.isostatic_contacts and r.checks().passed


def _grown_dimer(grow):
    """N = 32, seed 4 at its onset: floaters 7 and 14 (gap 2.5e-10) grown by ``grow`` diameters each."""
    pk = jamflow.jam(n=32, seed=4, engine="numba").packing
    d = pk.diameters.copy()
    d[[7, 14]] += grow
    return replace(pk, diameters=d)


def test_a_floater_dimer_is_freed_by_a_joint_move():
    """Grown by 0.004 the dimer overlaps itself by 4e-3 and 22 and 28 by 2e-3 and 5e-5; moving each
    along F / k or alone never freed both ("floaters still overlap after 200 relief sweeps", failed
    before); moving both together does, and they stay floaters."""
    r = refine(_grown_dimer(0.004), 1e-14)
    assert r.network.floater[[7, 14]].all() and not r.network.floater_overlaps
    assert abs(r.pressure / 1e-14 - 1) < 1e-2 and r.force_balance < 1e-10 and r.checks().passed
    assert r.n_contacts == r.isostatic_contacts


def test_a_floater_dimer_whose_cage_closed_joins_the_network():
    """Grown by 0.042 the dimer no longer fits its cage: no joint move opens its contacts
    (``_Caged``), while grown by 0.035 it still fits, tightly. Refined, its overlaps (~4e-2, the
    backbone's ~1e-8) throw the packing far out of balance, relief and Newton end with a cluster no
    move frees, and one float64 FIRE at the onset's box (p ~ 1e-8, resolved) puts the dimer in the
    network, with contacts 1-7, 7-14, 7-31, 14-22, 14-28 (before: "floaters still overlap after 200
    relief sweeps"); it stays in the network down to 1e-14."""
    from jamflow.model.box import Box
    from jamflow.protocols.refine import _Caged, _cluster_move, _State, evaluate

    def joint_move(pk):
        st = _State.of(pk)
        net = evaluate(pk, st)
        assert net.floater[[7, 14]].all()
        off = ~net.backbone
        depth = {}
        for a, b, o in zip(net.i[off].tolist(), net.j[off].tolist(), net.overlap[off].tolist()):
            depth[(a, b)] = depth[(b, a)] = o
        return _cluster_move(pk, Box(np.diag(st.lh)), st.xh, [7, 14], depth)

    assert joint_move(_grown_dimer(0.035)).shape == (2, 2)
    pk = _grown_dimer(0.042)
    with pytest.raises(_Caged):
        joint_move(pk)
    r = refine(pk, 1e-14)
    assert not r.network.floater[[7, 14]].any()
    assert {(1, 7), (7, 14), (7, 31), (14, 22), (14, 28)} <= r.start_contacts
    assert abs(r.pressure / 1e-14 - 1) < 1e-2 and r.force_balance < 1e-10 and r.checks().passed
    assert r.n_contacts == r.isostatic_contacts


def test_newton_refuses_a_step_that_no_halving_makes_downhill(onset32, monkeypatch):
    """A Newton direction that raises both the residual and the energy (here: against the forces) is
    refused after ``STEP_HALVINGS`` halvings (before: its smallest halving was accepted, uphill, and
    the refinement ran on to the Newton-step limit)."""
    import jamflow.protocols.refine as refine_module

    monkeypatch.setattr(refine_module, "_newton_step", lambda packing, st, net: -1e-3 * net.forces)
    with pytest.raises(jamflow.JammingFailed, match="no Newton step of 12 halvings lowers"):
        refine(onset32, 1e-14)


def test_a_start_newton_cannot_balance_is_relaxed_once_in_float64():
    """3D N = 128 seed 20 of the pressure ladder at p = 3.2e-5: a float64 enthalpy minimum stopped at
    its iteration cap mid-rearrangement (max|F|/<f> = 1.5e-3), where Newton on its network crept
    (7-10 halvings a step) and failed after 60 steps. It is relaxed once by float64 FIRE at its box
    and balanced from there (before: "force balance not reached in 60 Newton steps")."""
    capped = load_packing(DATA / "sphere3d_n128_s20_p3e-5_capped.h5")
    assert check_packing(capped).force_ratio > 1e-3
    r = refine(capped, 10**-4.5)
    assert r.force_balance < 1e-12 and abs(r.pressure / 10**-4.5 - 1) < 1e-4
    assert r.n_contacts >= r.isostatic_contacts


def test_the_float64_fallback_relaxes_below_the_chapters_v_min(refined32):
    """The fallback FIRE (``_float64_relax``) relaxes to force balance: below p ~ 1e-8 the energy per
    particle (~1e-20 at 1e-10) is under the chapter's V_min = 1e-16, whose stop ended the FIRE at once
    and returned the state unrelaxed (before RELAX_V_MIN)."""
    import jamflow.protocols.refine as refine_module

    at = refine(refined32.packing, 1e-10)
    assert at.energy_per_particle < 1e-16
    shaken = replace(at.packing, extended=None, positions=at.packing.positions
                     + 1e-9 * np.random.default_rng(5).standard_normal((32, 2)))
    before = check_packing(shaken).force_ratio
    st = refine_module._float64_relax(shaken, refine_module._State.of(shaken), 1e-10, "test")
    after = check_packing(st.packing(shaken)).force_ratio
    assert before > 1 and after < 1e-3  # float64 FIRE stops at max|F| ~ 1e-14 ~ 1e-4 of a contact force here


def test_a_floater_cluster_too_large_to_move_together_goes_to_the_float64_fallback(monkeypatch):
    """More than MAX_JOINT_FLOATERS floaters in one cluster (a state past its onset: N = 1024 seed 5
    landed from V = 1e-12 to 1e-16 had 978 in contact) are handed to the float64 FIRE as caged,
    without the least-distance problem of d x 978 unknowns (20 s of the 24 s landing before)."""
    import jamflow.protocols.refine as refine_module
    from jamflow.model.box import Box

    pk = jamflow.jam(n=16, seed=1, engine="numba").packing
    monkeypatch.setattr(refine_module, "MAX_JOINT_FLOATERS", 8)
    monkeypatch.setattr(refine_module, "_least_distance", lambda g, h: pytest.fail("solved a too-large cluster"))
    with pytest.raises(refine_module._Caged, match="9 floaters in contact form one cluster"):
        refine_module._cluster_move(pk, Box(np.diag(pk.box.lengths)), pk.positions, list(range(9)), {})
