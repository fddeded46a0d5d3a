"""Minimisers report why they stopped; the chapter's stopping rules."""

import numpy as np
import pytest

from jamflow.engines.lammps.engine import LammpsEngine
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.minimize.settings import MinimizerSettings
from jamflow.minimize.rules import minimize


@pytest.mark.parametrize("method", ["fire", "cg", "md"])
def test_overcompressed_packing_converges_by_force(config, method):
    d = np.where(np.arange(64) % 2 == 0, 1.0, 1.4)
    p = config(64, 2, 0.88, seed=1, diameters=d)
    with LammpsEngine(p) as eng:
        res = minimize(eng, MinimizerSettings(method=method, force_tol=1e-12))
        q = eng.packing()
    assert res.converged and res.reason == "force"
    ref = energy_forces_pressure(q)
    assert np.max(np.abs(ref.forces)) < 1e-12
    assert ref.energy / 64 == pytest.approx(res.energy_per_particle, rel=1e-9)
    assert res.energy_per_particle > 1e-6  # still jammed


def test_dilute_packing_stops_below_vmin(config):
    p = config(64, 2, 0.5, seed=2, diameters=np.ones(64))
    with LammpsEngine(p) as eng:
        res = minimize(eng, MinimizerSettings())
    assert res.converged and res.reason in ("energy-below-vmin", "force")
    assert res.energy_per_particle < 1e-16


def test_iteration_cap_is_reported_as_not_converged(config):
    p = config(64, 2, 0.88, seed=1, diameters=np.ones(64))
    with LammpsEngine(p) as eng:
        res = minimize(eng, MinimizerSettings(max_iterations=10, window=5))
    assert not res.converged and res.reason == "iteration-cap" and res.iterations == 10


def test_unknown_method_rejected():
    with pytest.raises(ValueError, match="unknown minimizer"):
        MinimizerSettings(method="bfgs")


def test_force_bound_closed_form_for_the_linear_spring(config):
    from jamflow.minimize.rules import _force_bound

    # all of E in one contact of the smallest pair: delta = sqrt(2 E), |f| = delta / sigma
    p = config(10, 2, 0.5, seed=1, diameters=np.full(10, 1.0))
    assert _force_bound(p, 1e-12) == pytest.approx(10 * np.sqrt(2e-12), rel=1e-9)


@pytest.mark.parametrize("energy,fmax", [(float("nan"), 1e-3), (1e-20, float("inf")), (0.0, 1e3)])
def test_blown_up_states_are_not_reported_as_unjammed(energy, fmax):
    """A diverged integration can report V = 0 with huge forces; it must not pass as V < V_min."""
    from jamflow.minimize.rules import _stop_reason

    s = MinimizerSettings()
    reason = _stop_reason(s, 1e-14, energy, fmax, 1.0, 1.0, 10, 10, 10, fmax_at_vmin=1e-6)
    assert reason == "blown-up"


def test_a_genuinely_unjammed_state_is_not_blown_up():
    from jamflow.minimize.rules import _stop_reason

    s = MinimizerSettings()
    assert _stop_reason(s, 1e-14, 1e-20, 1e-9, 1.0, 1.0, 10, 10, 10, fmax_at_vmin=1e-6) == "energy-below-vmin"


def test_energy_steady_is_the_md_fluctuation_rule():
    """The chapter's MD rule: relative rms energy fluctuation over the window below delta; the
    force and V_min rules come first, and it is not reported as converged by force."""
    from jamflow.minimize.settings import CONVERGED_REASONS
    from jamflow.minimize.rules import _stop_reason

    s = MinimizerSettings(method="md")
    args = (1e-14, 1.5e-16, 1e-12, 1.5e-16, 1e-12, 10, 10, 10)
    assert _stop_reason(s, *args, fmax_at_vmin=1e-6, fluctuation=0.5e-16) == "energy-steady"
    assert _stop_reason(s, *args, fmax_at_vmin=1e-6, fluctuation=2e-16) != "energy-steady"
    assert _stop_reason(s, *args, fmax_at_vmin=1e-6, fluctuation=None) != "energy-steady"
    assert _stop_reason(s, 1e-14, 1.5e-16, 1e-15, 1.5e-16, 1e-12, 10, 10, 10, fmax_at_vmin=1e-6,
                        fluctuation=0.0) == "force"
    assert "energy-steady" not in CONVERGED_REASONS
    # no-progress compares the mechanical energy V + K: V rising while K is dissipated is progress
    rising_v = (1e-14, 1.6e-16, 1e-12, 2.0e-16, 1e-12, 10, 10, 10)
    assert _stop_reason(s, *rising_v, fmax_at_vmin=1e-6, mechanical=1.7e-16) is None
    assert _stop_reason(s, *rising_v, fmax_at_vmin=1e-6, mechanical=2.0e-16) == "no-progress"


@pytest.mark.parametrize("damping", ["viscous", "pairwise"])
def test_md_window_reports_the_energy_fluctuation_of_its_samples(config, damping, tmp_path):
    """The session's fluctuation equals <(V - <V>)^2>^(1/2) / <V> computed in numpy from the
    energies that an independent ``fix print`` writes on the same steps (multiples of 10)."""
    d = np.where(np.arange(64) % 2 == 0, 1.0, 1.4)
    p = config(64, 2, 0.88, seed=1, diameters=d)
    s = MinimizerSettings(method="md", md_damping=damping, window=1000)
    log = tmp_path / "pe.txt"
    with LammpsEngine(p) as eng, eng.minimizer_session(s, 1e-30) as window:
        eng.command(f'fix check all print 10 "$(step) $(pe:%.17g)" file {log} screen no')
        before = eng.lmp.extract_global("ntimestep")
        ran, energy, fmax, gmax, fluctuation, kinetic = window(995)  # a window not aligned with the samples
        v = eng._gather("v")  # the velocities, put back after the force was measured at rest
        one_sample = window(12)  # steps 995-1007: only step 1000 sampled
        two_samples = window(13)  # steps 1007-1020: 1010 and 1020
    steps, pe = np.loadtxt(log, unpack=True)
    inside = (steps >= before) & (steps <= before + ran)
    assert inside.sum() == len(range(-(-before // 10) * 10, before + ran + 1, 10)) >= 99
    expected = np.std(pe[inside]) / np.mean(pe[inside])
    assert fluctuation == pytest.approx(expected, rel=1e-9) and fluctuation > 1e-6  # relaxing: V changes
    assert before == 0 and one_sample[4] is None and two_samples[4] is not None and gmax == 0.0
    assert kinetic == pytest.approx(0.5 * np.sum(v**2), rel=1e-12) and kinetic > 0
