"""The isotropic compression protocol (chapter section 2.1) end to end on small systems."""

import numpy as np
import pytest

from jamflow import CompressionSettings, MinimizerSettings, jam
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.protocols.settings import chapter_protocol, fast_protocol


def assert_jammed(res, v_tol=1e-16, max_force=1e-13):
    assert v_tol < res.energy_per_particle < 2 * v_tol
    ref = energy_forces_pressure(res.packing)  # independent check of the final state
    assert ref.energy / res.packing.n == pytest.approx(res.energy_per_particle, rel=1e-6)
    assert np.max(np.abs(ref.forces)) < max_force
    assert res.pressure > 0
    assert res.history["phi"][-1] == res.phi_j == pytest.approx(res.packing.phi, rel=1e-14)


@pytest.fixture(scope="module")
def jammed_2d():
    return jam(n=64, dim=2, sizes="bi:1.4:0.5", seed=11, settings=chapter_protocol())


def test_2d_bidisperse_reaches_window_with_force_balance(jammed_2d):
    assert_jammed(jammed_2d)
    # small-N 2D bidisperse onsets lie below the large-N 0.842 (O'Hern et al. PRE 68, 011306, 2003)
    assert 0.80 < jammed_2d.phi_j < 0.86


def test_history_follows_the_bisection_rule(jammed_2d):
    h = jammed_2d.history
    above = h["energy_per_particle"] > 2e-16
    below = h["energy_per_particle"] < 1e-16
    for k in range(1, len(h["phi"]) - 1):
        dphi = h["phi"][k + 1] - h["phi"][k]
        assert (dphi > 0) == bool(below[k]) and (dphi < 0) == bool(above[k])
        crossed = (above[k] and below[k - 1]) or (below[k] and above[k - 1])
        # history dphi[k] is the increment that led to phi[k]; it halves after a crossing
        assert h["dphi"][k + 1] == pytest.approx(h["dphi"][k] / 2 if crossed else h["dphi"][k], rel=1e-9)
        assert abs(dphi) == pytest.approx(h["dphi"][k + 1], rel=1e-9)


def test_default_protocol_is_fast_and_reproducible():
    a, b = (jam(n=64, dim=2, sizes="bi:1.4:0.5", seed=12) for _ in range(2))
    assert a.settings == fast_protocol()
    assert abs(a.phi_j - b.phi_j) < 1e-10


def test_same_seed_same_phi_j(jammed_2d):
    again = jam(n=64, dim=2, sizes="bi:1.4:0.5", seed=11, settings=chapter_protocol())
    assert abs(again.phi_j - jammed_2d.phi_j) < 1e-10


def test_3d_monodisperse_spheres():
    res = jam(n=48, dim=3, sizes="mono", seed=2)
    assert_jammed(res)
    assert 0.55 < res.phi_j < 0.66  # small-N; large-N value 0.639-0.64 (O'Hern et al. 2003)


@pytest.mark.parametrize("method", ["cg", "md"])
def test_other_minimizers_reach_the_window(method):
    settings = fast_protocol(minimizer=MinimizerSettings(method=method))
    res = jam(n=32, dim=2, sizes="bi:1.4:0.5", seed=5, settings=settings)
    assert 1e-16 < res.energy_per_particle < 2e-16


def test_hertz_polydisperse_uses_plugin_and_jams():
    res = jam(n=32, dim=2, sizes="poly-uniform:0.4", potential="hertz", seed=3)
    assert_jammed(res)


@pytest.mark.parametrize("kwargs,match", [
    (dict(n=1), "n must be"), (dict(dim=4), "dim"), (dict(sizes="tri:1"), "size spec"),
    (dict(potential="morse"), "potential"), (dict(seed=-1), "seed"),
])
def test_bad_input_raises_before_lammps(kwargs, match):
    with pytest.raises(ValueError, match=match):
        jam(**kwargs)


@pytest.mark.parametrize("kwargs", [dict(phi0=0.95), dict(phi0=0.0), dict(dphi0=-1e-4),
                                    dict(v_tol=float("nan")), dict(v_tol=-1.0)])
def test_bad_settings_rejected(kwargs):
    with pytest.raises(ValueError):
        jam(settings=CompressionSettings(**kwargs))


def test_repulsive_lj_starts_from_relaxed_overlaps():
    """Seed step 1: RLJ needs a start without significant overlaps."""
    res = jam(n=32, dim=2, sizes="bi:1.4:0.5", potential="rlj", seed=4)
    assert_jammed(res, max_force=72 * 1e-13)  # round-off floor scales with d2V/dr2 = 72 at contact


@pytest.mark.parametrize("dim,sizes", [(2, "bi:1.4:0.5"), (3, "mono")])
def test_fast_protocol_reaches_the_window_with_force_balance(dim, sizes):
    res = jam(n=64, dim=dim, sizes=sizes, seed=8, settings=fast_protocol())
    assert_jammed(res)
    assert res.minimizations < 150


def test_state_in_window_cut_off_by_the_cap_is_minimised_again():
    """A state in the window whose minimisation hit the iteration cap is not yet a minimum:
    it is minimised again in place (dphi = 0 rows), at most WINDOW_RESUMES times, then
    accepted with a warning."""
    from jamflow.protocols.compression import WINDOW_RESUMES

    settings = fast_protocol(minimizer=MinimizerSettings(max_iterations=3000, window=100))
    with pytest.warns(UserWarning, match="iteration-cap"):
        r = jam(n=64, seed=2, settings=settings)
    h, reasons = r.history, [x.decode() for x in r.history["reason"]]
    capped_in_window = [i for i in range(len(reasons) - 1) if reasons[i] == "iteration-cap"
                        and 1e-16 < h["energy_per_particle"][i] < 2e-16]
    assert len(capped_in_window) == WINDOW_RESUMES
    for i in capped_in_window:
        assert h["dphi"][i + 1] == 0.0 and h["phi"][i + 1] == h["phi"][i]


def test_a_packing_short_of_isostatic_has_its_round_off_gaps_closed():
    """3D N = 256 seed 159: FIRE stops in the window with 756 contacts among 253 non-floaters, one
    short of the isostatic 757, a floppy mode still closing a gap at round-off (it was refused by
    the 3D ensemble's checks); the polish's active-set steps close it, and the packing passes."""
    from jamflow.mechanics.checks import check_packing

    res = jam(n=256, dim=3, sizes="mono", seed=159)
    checks = check_packing(res.packing, res.energy_per_particle, None, res.settings.v_tol)
    assert checks.passed, checks.problems()
    assert checks.n_contacts == checks.isostatic_count == 757
    assert_jammed(res)
    assert res.history["iterations"][-1] == 0 and res.history["dphi"][-1] == 0.0  # the polish's own row


def test_gap_closing_leaves_an_isostatic_packing_alone(jammed_2d):
    from jamflow.engines.choose import open_engine
    from jamflow.minimize.settings import MinimizeResult
    from jamflow.protocols.compression import close_gaps

    result = MinimizeResult(True, "force", 1, jammed_2d.energy_per_particle, jammed_2d.max_force, 0.0)
    with open_engine(jammed_2d.packing, engine="numba") as engine:
        x = engine.positions()
        assert close_gaps(engine, result, jammed_2d.settings) is None
        assert np.array_equal(engine.positions(), x)
