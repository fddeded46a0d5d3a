"""Minimisers report why they stopped; the seed's stopping rules."""

import numpy as np
import pytest

from jamflow.engine.lammps import LammpsEngine
from jamflow.engine.reference import energy_forces_pressure
from jamflow.minimize import MinimizerSettings


@pytest.mark.parametrize("method", ["fire", "cg", "md"])
def test_overcompressed_packing_converges_by_force(config, method):
    d = np.where(np.arange(64) % 2 == 0, 1.0, 1.4)
    p = config(64, 2, 0.88, seed=1, diameters=d)
    with LammpsEngine(p) as eng:
        res = eng.minimize(MinimizerSettings(method=method, force_tol=1e-12))
        q = eng.packing()
    assert res.converged and res.reason == "force"
    ref = energy_forces_pressure(q)
    assert np.max(np.abs(ref.forces)) < 1e-12
    assert ref.energy / 64 == pytest.approx(res.energy_per_particle, rel=1e-9)
    assert res.energy_per_particle > 1e-6  # still jammed


def test_dilute_packing_stops_below_vmin(config):
    p = config(64, 2, 0.5, seed=2, diameters=np.ones(64))
    with LammpsEngine(p) as eng:
        res = eng.minimize(MinimizerSettings())
    assert res.converged and res.reason in ("energy-below-vmin", "force")
    assert res.energy_per_particle < 1e-16


def test_iteration_cap_is_reported_as_not_converged(config):
    p = config(64, 2, 0.88, seed=1, diameters=np.ones(64))
    with LammpsEngine(p) as eng:
        res = eng.minimize(MinimizerSettings(max_iterations=10, window=5))
    assert not res.converged and res.reason == "iteration-cap" and res.iterations == 10


def test_unknown_method_rejected():
    with pytest.raises(ValueError, match="unknown minimizer"):
        MinimizerSettings(method="bfgs")
