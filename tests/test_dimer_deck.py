"""lammps_inputs/jam_dimers.lmp: rigid dimers jammed by damped rigid bodies in the wheel's ``lmp``
alone (docs/notes/nmers.md), checked by jamflow's numpy reference on the packing read back from the data
file; its closed-form dimer geometry against jamflow's union integrals; its reproducibility; its
refusals."""

import subprocess
from pathlib import Path

import numpy as np
import pytest

from jamflow.decks.jam import DeckFailed, lmp_command, read_body_data, run_deck
from jamflow.engines.lammps.library import lammps_env
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.model.shapes import parse_shape
from jamflow.mechanics.checks import generalized_torques

DECK = Path(__file__).resolve().parents[1] / "lammps_inputs" / "jam_dimers.lmp"


def run_lmp(workdir, padding: int = 0, **variables):
    """The deck in ``workdir``; ``padding`` characters of an unused environment variable change
    the process's memory layout (and so what uninitialised memory holds), nothing else."""
    args = [*lmp_command(), "-in", str(DECK), "-log", "deck.log", "-screen", "none", "-nocite"]
    for name, value in variables.items():
        args += ["-var", name, str(value)]
    env = {**lammps_env(), "JAMFLOW_TEST_PADDING": "x" * padding}
    return subprocess.run(args, cwd=workdir, env=env, capture_output=True, text=True, timeout=600)


def test_dimer_deck_jams_rigid_dimers(tmp_path):
    """2D, random start, damped fix rigid, the chapter's bisection: in the window, every force
    and generalized torque below 1e-13 by the reference, dimers rigid (the reader checks every
    site distance to 1e-9), phi and P as the deck reports them, the last minimisation stopped by
    force. Any deck failure fails this test. (3D runs too, but near onset damped dynamics creeps
    for 10^5 steps per minimisation: docs/notes/nmers.md.)"""
    dim, n = 2, 16
    shape = parse_shape("nmer:2:1.5", dim)
    res = run_deck(tmp_path, {"dim": dim, "N": n, "dphi0": 0.002, "seed": 1}, deck=DECK,
                   reader=lambda path: read_body_data(path, shape))
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
    done = run_lmp(tmp_path, dim=dim, alpha=alpha, N=4, maxsteps=1)
    protocol, log = tmp_path / "jammed.protocol.txt", tmp_path / "deck.log"
    assert protocol.is_file(), (f"lmp exit {done.returncode}, no protocol file; stderr: {done.stderr[-300:]!r}; "
                                f"log tail: {log.read_text()[-600:] if log.is_file() else 'none'!r}")
    line = next(ln for ln in protocol.read_text().splitlines() if ln.startswith("# dimer"))
    words = line.split()
    volume, dk = float(words[3]), float(words[-1])
    shape = parse_shape(f"nmer:2:{alpha}", dim)
    assert volume == pytest.approx(shape.volumes([1.0], dim)[0], rel=1e-12)
    assert dk == pytest.approx(shape.rotational_lengths([1.0], dim)[0, -1], rel=1e-12)


@pytest.mark.parametrize("dim", [2, 3])
def test_dimer_deck_does_not_depend_on_the_environment(tmp_path, dim):
    """The same input under environments of different sizes writes the same protocol, digit for
    digit. With fix rigid/small the first half-step of every minimisation integrated
    uninitialised Langevin forces (engine/lammps_bodies.py): in 2D these three paddings gave
    three different histories, and the N = 4, alpha = 2 start of the geometry test a NaN."""
    texts = []
    for padding in (0, 555, 1000):
        work = tmp_path / f"pad{padding}"
        work.mkdir()
        run_lmp(work, padding, dim=dim, N=16, dphi0=0.05, seed=1, maxsteps=12)
        lines = (work / "jammed.protocol.txt").read_text().splitlines()
        assert "no packing in the window after 12 minimisations" in lines[-1]
        texts.append(lines)
    assert len(texts[0]) == 4 + 12 + 1 and texts[1] == texts[0] and texts[2] == texts[0]
    assert any(float(line.split()[2]) > 0 for line in texts[0][4:-1])  # overlaps were relaxed


@pytest.mark.parametrize("variables,message", [
    ({"alpha": 2.5}, "alpha = 2.5 is outside 1 < alpha <= 2"), ({"alpha": 1.0}, "outside 1 < alpha <= 2"),
    ({"dim": 4}, "dim must be 2 or 3"), ({"damping": 25}, "0 < damping < 2/dt"),
    ({"vmin": 1e-15}, "vmin = 1e-15 is above vtol"), ({"phi0": 0.8}, "placed .* of 64 dimers at phi0 = 0.8")])
def test_dimer_deck_refuses_bad_parameters(tmp_path, variables, message):
    with pytest.raises(DeckFailed, match=message):
        run_deck(tmp_path, variables, deck=DECK, reader=lambda path: read_body_data(path, parse_shape("nmer:2:1.5", 2)))
