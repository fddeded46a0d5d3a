"""``jamflow jam --precision double-double --vtol V`` (docs/guide/precision.md): the float64 onset refined in
double-double to the pressure whose energy per particle lands in V_tol < V < 2 V_tol."""

import math
from fractions import Fraction

import h5py
import pytest
from test_ddouble import exact_spring

import jamflow
from jamflow.io.packing_file import load_packing
from jamflow.protocols import refine as refine_module
from jamflow.protocols.outcome import JammingFailed
from jamflow.protocols.spec import JamSpec, prepare, run_jam


def _dd(**options) -> JamSpec:
    return JamSpec(n=32, seed=1, engine="numba", precision="double-double", **options)


@pytest.fixture(scope="module")
def onset32():
    return jamflow.jam(n=32, seed=1, engine="numba").packing


@pytest.mark.parametrize("vtol", [1e-24, 1e-30])
def test_jam_lands_in_the_window_in_exact_arithmetic(vtol):
    """V and the net forces of hi + lo recomputed with Fractions (test_ddouble.exact_spring), not by
    the double-double kernel that chose the pressure."""
    result, checks = run_jam(_dd(vtol=vtol))
    p = result.packing
    assert p.precision == "double-double" and checks.passed and checks.in_window
    energy, forces, _, overlaps = exact_spring(p.positions, p.positions_lo, p.box.lengths, p.lengths_lo, p.diameters)
    v = energy / p.n
    assert Fraction(vtol) < v < 2 * Fraction(vtol)
    contact = [o for o in overlaps.values() if o > 0]
    assert len(contact) == result.n_contacts == result.isostatic_contacts
    mean_f = float(sum(contact) / len(contact)) / 1.2**2  # ~ eps delta / sigma^2
    floater = result.network.floater
    worst = max(math.hypot(*(float(f) for f in forces[k])) for k in range(p.n) if not floater[k])
    assert worst / mean_f < 1e-10
    assert result.onset is not None and result.onset.energy_per_particle > 1e-16  # from the float64 onset


def test_the_secant_corrects_a_wrong_first_guess(onset32, monkeypatch):
    """With the exponent of the first guess wrong (V ~ p instead of p^2) the first pressure misses
    the window by orders of magnitude; the secant on (log p, log V) brings V back into it."""
    monkeypatch.setattr(refine_module, "ENERGY_EXPONENT", 1.0)
    r = jamflow.refine_to_vtol(onset32, 1e-26)
    assert r.refines > 1 and r.in_window and r.checks().passed
    monkeypatch.setattr(refine_module, "MAX_VTOL_REFINES", 1)
    with pytest.raises(JammingFailed, match="outside the window"):
        jamflow.refine_to_vtol(onset32, 1e-26)


def test_the_floor_is_refused_before_work_with_the_smallest_vtol(onset32):
    floor = refine_module.dd_vtol_floor(onset32)
    assert 1e-36 < floor < 1e-32  # the energy of p ~ 2e-18 (dd_pressure_floor) at N = 32
    with pytest.raises(ValueError, match=f"use --vtol >= {refine_module.dd_vtol_floor(prepare(_dd())[1]):.1e}"):
        prepare(_dd(vtol=1e-40))


@pytest.mark.parametrize("argv, message", [
    (["--precision", "double-double", "--vtol", "1e-40"], "below what double-double resolves"),
    (["--precision", "double-double", "--vtol", "1e-24", "--pressure", "1e-14"], "not both"),
    (["--vtol", "1e-30"], "or --precision double-double"),
])
def test_cli_refusals_before_work(tmp_path, capsys, argv, message):
    from jamflow.cli.app import main

    out = tmp_path / "x.h5"
    assert main(["jam", "--n", "32", *argv, "--out", str(out)]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_cli_writes_the_window_and_load_reads_it(tmp_path, capsys):
    from jamflow.cli.app import main

    out = tmp_path / "v26.h5"
    assert main(["jam", "--n", "32", "--seed", "2", "--precision", "double-double", "--vtol", "1e-26",
                 "--out", str(out), "--quiet"]) == 0
    assert "V_tol (V_tol = 1e-26)" in capsys.readouterr().out
    p = load_packing(out)
    assert p.precision == "double-double" and abs(p.positions_lo).max() > 0
    with h5py.File(out) as f:
        assert f["protocol"].attrs["v_tol"] == 1e-26 and f["checks"].attrs["v_tol"] == 1e-26
        assert f["checks"].attrs["in_window"] and f["checks"].attrs["passed"]
        assert 1e-26 < f.attrs["energy_per_particle"] < 2e-26
