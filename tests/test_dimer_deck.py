"""lammps_inputs/jam_dimers.lmp: rigid dimers jammed by damped rigid bodies in the wheel's ``lmp``
alone (issue 14), checked by jamflow's numpy reference on the packing read back from the data
file; its closed-form dimer geometry against jamflow's union integrals; its refusals."""

import subprocess
from pathlib import Path

import numpy as np
import pytest

from jamflow.deck import DeckFailed, lmp_command, read_body_data, run_deck
from jamflow.engine.lammps_lib import lammps_env
from jamflow.engine.reference import energy_forces_pressure
from jamflow.shapes import parse_shape
from jamflow.checks import generalized_torques

DECK = Path(__file__).resolve().parents[1] / "lammps_inputs" / "jam_dimers.lmp"


def run_lmp(workdir, **variables):
    args = [*lmp_command(), "-in", str(DECK), "-log", "deck.log", "-screen", "none", "-nocite"]
    for name, value in variables.items():
        args += ["-var", name, str(value)]
    return subprocess.run(args, cwd=workdir, env=lammps_env(), capture_output=True, text=True, timeout=600)


def test_dimer_deck_jams_rigid_dimers(tmp_path):
    """2D, random start, damped fix rigid/small, the seed's bisection: in the window, every force
    and generalized torque below 1e-13 by the reference, dimers rigid (the reader checks every
    site distance to 1e-9), phi and P as the deck reports them. (3D runs too, but near onset
    damped dynamics creeps for 10^5 steps per minimisation: docs/nmers.md.)

    Known defect: the deck's trajectory is not reproducible from run to run (the same input,
    4 runs: 2 different histories from the first minimisation with overlaps on; cause not found:
    the start and a plain fix rigid/small langevin run are reproducible in one process), and
    about 1 run in 3 ends with damped minimisations capped at 5e5 steps near onset, V creeping
    below V_min, and the bisection at float64 resolution. That one failure is reported as xfail;
    any other failure fails, and a deck that jams must pass every check below."""
    dim, n = 2, 16
    shape = parse_shape("nmer:2:1.5", dim)
    try:
        res = run_deck(tmp_path, {"dim": dim, "N": n, "dphi0": 0.002, "seed": 1}, deck=DECK,
                       reader=lambda path: read_body_data(path, shape))
    except DeckFailed as err:
        if "reached float64 resolution" not in str(err):
            raise
        pytest.xfail(f"known, not reproducible run to run: {err}")
    p = res.packing
    ref = energy_forces_pressure(p)
    g = generalized_torques(p, ref.torques)
    assert p.n == n and 1e-16 < res.energy_per_particle < 2e-16
    assert ref.energy / n == pytest.approx(res.energy_per_particle, rel=1e-6)
    assert np.abs(ref.forces).max() < 1e-13 and np.abs(g).max() < 1e-13
    assert ref.pressure == pytest.approx(res.pressure, rel=1e-6) and res.pressure > 0
    assert p.phi == pytest.approx(res.phi_j, rel=1e-13)  # the deck's closed-form body volume
    assert res.history["reason"][-1] == "force"


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("alpha", [1.05, 1.5, 2.0])
def test_deck_geometry_is_jamflows(tmp_path, dim, alpha):
    """The deck's closed forms (union area/volume, radius of gyration across the dimer) equal
    jamflow's union integrals (shapes.union) to 1e-12."""
    run_lmp(tmp_path, dim=dim, alpha=alpha, N=4, maxsteps=1)
    line = next(ln for ln in (tmp_path / "jammed.protocol.txt").read_text().splitlines() if ln.startswith("# dimer"))
    words = line.split()
    volume, dk = float(words[3]), float(words[-1])
    shape = parse_shape(f"nmer:2:{alpha}", dim)
    assert volume == pytest.approx(shape.volumes([1.0], dim)[0], rel=1e-12)
    assert dk == pytest.approx(shape.rotational_lengths([1.0], dim)[0, -1], rel=1e-12)


@pytest.mark.parametrize("variables,message", [
    ({"alpha": 2.5}, "alpha = 2.5 is outside 1 < alpha <= 2"), ({"alpha": 1.0}, "outside 1 < alpha <= 2"),
    ({"dim": 4}, "dim must be 2 or 3"), ({"damping": 25}, "0 < damping < 2/dt"),
    ({"vmin": 1e-15}, "vmin = 1e-15 is above vtol"), ({"phi0": 0.8}, "placed .* of 64 dimers at phi0 = 0.8")])
def test_dimer_deck_refuses_bad_parameters(tmp_path, variables, message):
    with pytest.raises(DeckFailed, match=message):
        run_deck(tmp_path, variables, deck=DECK, reader=lambda path: read_body_data(path, parse_shape("nmer:2:1.5", 2)))
