"""Where methods break down (docs/notes/failure-modes.md): each case ends in a clear error or a
flagged result, never a silent wrong packing."""

import numpy as np
import pytest

from jamflow import CompressionSettings, MinimizerSettings, jam
from jamflow.decks.jam import DeckFailed, default_deck_path, run_deck
from jamflow.engines.lammps.engine import LammpsEngine
from jamflow.protocols.outcome import JammingFailed
from jamflow.protocols.compression import compress, initial_packing
from jamflow.minimize.rules import minimize as run_minimizer

from test_decks import assert_jammed


@pytest.fixture(scope="module")
def onset():
    """16 bidisperse disks at onset (FIRE, chapter protocol)."""
    return jam(n=16, dim=2, seed=5)


@pytest.fixture(scope="module")
def above(onset):
    """The onset packing compressed by 1e-3: V ~ 1e-7 per particle, max force ~1e-4."""
    return onset.packing.scaled_to_phi(onset.phi_j + 1e-3)


def minimize(packing, **settings):
    with LammpsEngine(packing) as engine:
        return run_minimizer(engine, MinimizerSettings(**settings))


def test_cg_line_search_stall_is_reported(above):
    """CG cannot reach a force tolerance below round-off: LAMMPS's line search stops it
    early, and the result says so instead of claiming convergence."""
    r = minimize(above, method="cg", force_tol=1e-20)
    assert (r.reason, r.converged) == ("linesearch", False)
    assert r.iterations < 2000 and r.max_force > 1e-20


def test_fire_at_the_round_off_floor_stops_by_no_progress(above):
    """FIRE with a tolerance below the ~1e-15 force floor: detected after two windows
    without progress, well before the iteration cap."""
    r = minimize(above, force_tol=1e-17, window=2000, max_iterations=200_000)
    assert (r.reason, r.converged) == ("no-progress", False)
    assert r.iterations < 50_000 and 1e-17 < r.max_force < 1e-13


def test_final_minimisation_at_the_floor_warns():
    start = initial_packing(16, 2, "bi:1.4:0.5", "spring", 5, 0.85)
    settings = CompressionSettings(dphi0=1e-3, minimizer=MinimizerSettings(force_tol=1e-17, window=2000))
    with pytest.warns(UserWarning, match="stopped by 'no-progress'"):
        res = compress(start, settings)
    assert 1e-16 < res.energy_per_particle < 2e-16 and res.max_force < 1e-13  # flagged, still balanced to 1e-13


def test_damped_md_with_too_little_damping_is_not_converged(above):
    """b = 1e-3: underdamped, the energy rings; the cap is reported as not converged."""
    r = minimize(above, method="md", damping=1e-3, max_iterations=20_000)
    assert (r.reason, r.converged) == ("iteration-cap", False) and r.max_force > 1e-10


def test_strongly_damped_md_stops_at_its_force_floor(above):
    """b dt = 1 (b = 10): overdamped creep at v = F / b. Positions freeze once the step
    F dt / b is below the spacing of doubles, at F ~ b ulp(x) / dt ~ 4e-14: stopped by
    no-progress and flagged. (The total force, drag included, read ~1e-15 there: the drag
    cancels the potential force, which is why md measures the force at rest.) b = 1 converges."""
    r = minimize(above, method="md", damping=10.0, max_iterations=200_000)
    floor = 10.0 * np.spacing(above.box.lengths.max()) / 0.1
    assert (r.reason, r.converged) == ("no-progress", False) and 0.3 * floor < r.max_force < 3 * floor
    r = minimize(above, method="md", damping=1.0, max_iterations=200_000)
    assert r.converged and r.reason == "force" and r.max_force < 1e-14


def test_too_much_damping_is_refused_by_the_deck(tmp_path):
    with pytest.raises(DeckFailed, match="damping x dt"):
        run_deck(tmp_path, {"N": 16, "minimizer": "md", "damping": 21}, deck=default_deck_path())


def test_damped_md_with_too_much_damping_is_rejected():
    with pytest.raises(ValueError, match="damping"):
        MinimizerSettings(method="md", damping=21.0)


def test_large_increment_overshoots_then_bisects_into_the_window():
    """dphi0 = 0.09 jumps far past jamming; the halving still brackets the window."""
    res = jam(n=16, dim=2, seed=5, settings=CompressionSettings(dphi0=0.09))
    assert_jammed(res)
    assert res.history["energy_per_particle"][1] > 1e-6  # the first step landed far above jamming


def test_unresolvable_vtol_is_refused_before_work(monkeypatch):
    """V_tol = 1e-34 per particle: overlaps ~1e-17 diameters, below float64 resolution of
    positions; refused before any minimisation (was: JammingFailed at float64 resolution
    after 0.1 s), with the smallest resolvable V_tol."""
    settings = CompressionSettings(v_tol=1e-34, minimizer=MinimizerSettings(v_min=1e-34))
    monkeypatch.setattr("jamflow.protocols.compression.open_engine", lambda *a, **k: pytest.fail("work started"))
    with pytest.raises(ValueError, match="vtol 1e-34 is not resolvable.*round-off.*use vtol"):
        jam(n=16, dim=2, seed=5, settings=settings)


def test_vtol_below_vmin_is_refused_by_the_deck(tmp_path):
    with pytest.raises(DeckFailed, match="vmin = 1e-16 is above vtol"):
        run_deck(tmp_path, {"N": 16, "vtol": 1e-20}, deck=default_deck_path())


def test_unresolvable_vtol_fails_clearly_in_the_deck(tmp_path):
    with pytest.raises(DeckFailed, match="float64 resolution"):
        run_deck(tmp_path, {"N": 16, "seed": 1, "vtol": 1e-34, "vmin": 1e-34}, deck=default_deck_path())


def test_vtol_below_vmin_is_rejected_before_work():
    with pytest.raises(ValueError, match="v_min"):
        CompressionSettings(v_tol=1e-20)


def test_start_above_jamming_decompresses_to_the_window():
    res = jam(n=16, dim=2, seed=5, settings=CompressionSettings(phi0=0.88))
    assert_jammed(res)
    assert res.history["energy_per_particle"][0] > 2e-16 and res.phi_j < 0.88


def test_repulsive_lj_above_jamming_start_is_refused():
    with pytest.raises(JammingFailed, match="phi0 is above jamming"):
        jam(n=16, dim=2, seed=5, potential="rlj", settings=CompressionSettings(phi0=0.88))


def test_repulsive_lj_from_overlapping_start_is_refused_before_work():
    start = initial_packing(16, 2, "bi:1.4:0.5", "rlj", 5, 0.80)
    with pytest.raises(ValueError, match="overlap"):
        compress(start, CompressionSettings())

