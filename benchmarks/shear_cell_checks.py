"""The Lees-Edwards checks of docs/notes/shear-cell.md, as numbers (the tests assert bounds on them).

1. Shear steps gamma 0.4 -> 0.6 (dgamma 0.02, the reduced tilt flips at 0.5) in LAMMPS against
   the numpy reference on positions moved x -> x + dgamma y in numpy: largest relative
   difference of energy, forces and pressure tensor over the steps.
2. Across a flip (strain 0.5 - 1e-16 -> one ulp above 0.5): relative change of the LAMMPS
   energy, forces and pressure tensor.
3. gamma vs gamma + 1 (same positions) and gamma vs 1 - gamma (positions mirrored x -> -x):
   relative energy differences (numpy reference).

Random polydisperse configurations (diameters 1..1.4), N = 90, phi 0.9 (2D) / 0.7 (3D).

    python benchmarks/shear_cell_checks.py
"""

from __future__ import annotations

import numpy as np

from jamflow.model.box import Box
from jamflow.engines.lammps.engine import LammpsEngine
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.model.packing import Packing


def configuration(dim: int, gamma: float, seed: int) -> Packing:
    rng = np.random.default_rng(seed)
    d = 1.0 + 0.4 * rng.random(90)
    vol = (np.pi * d**2 / 4).sum() if dim == 2 else (np.pi * d**3 / 6).sum()
    box = Box.cube((vol / (0.9 if dim == 2 else 0.7)) ** (1 / dim), dim).with_shear_strain(gamma)
    return Packing(box.to_cartesian(rng.random((90, dim))), d, box)


def rel(a, b) -> float:
    return float(np.max(np.abs(np.asarray(a) - b)) / np.max(np.abs(b)))


def state_difference(state, other) -> tuple[float, float, float]:
    """Relative differences of energy, forces, pressure tensor (other: a State or ReferenceResult)."""
    return (abs(state.energy - other.energy) / abs(other.energy), rel(state.forces, other.forces),
            rel(state.pressure_tensor, other.pressure_tensor))


def shear_steps(dim: int) -> np.ndarray:
    p = configuration(dim, 0.4, seed=1)
    x, box, worst = p.positions, p.box, np.zeros(3)
    with LammpsEngine(p) as eng:
        for gamma in np.linspace(0.42, 0.6, 10):
            new = box.with_shear_strain(gamma)
            x, box = x @ (new.h @ np.linalg.inv(box.h)).T, new
            eng.set_box(new)
            ref = energy_forces_pressure(p.with_positions(x, box))
            worst = np.maximum(worst, state_difference(eng.evaluate(), ref))
    return worst


def across_flip(dim: int) -> tuple[float, float, float]:
    p = configuration(dim, 0.45, seed=2)
    with LammpsEngine(p) as eng:
        eng.set_box(p.box.with_shear_strain(0.5 - 1e-16))
        before = eng.evaluate()
        eng.set_box(p.box.with_shear_strain(np.nextafter(0.5, 1.0)))
        return state_difference(eng.evaluate(), before)


def periodic_images(dim: int) -> tuple[float, float]:
    p = configuration(dim, 0.3, seed=3)
    e = energy_forces_pressure(p).energy
    plus_one = energy_forces_pressure(p.with_positions(p.positions, p.box.with_shear_strain(1.3))).energy
    mirrored = p.positions * np.r_[-1.0, np.ones(dim - 1)]
    inverted = energy_forces_pressure(p.with_positions(mirrored, p.box.with_shear_strain(0.7))).energy
    return abs(plus_one - e) / e, abs(inverted - e) / e


def main(argv=None):
    for dim in (2, 3):
        print(f"{dim}D  steps 0.4->0.6 vs reference (energy, forces, pressure): "
              + ", ".join(f"{v:.1e}" for v in shear_steps(dim)))
        print(f"{dim}D  across the flip at 0.5 (energy, forces, pressure):     "
              + ", ".join(f"{v:.1e}" for v in across_flip(dim)))
        print(f"{dim}D  energy gamma+1 vs gamma, mirrored 1-gamma vs gamma:     "
              + ", ".join(f"{v:.1e}" for v in periodic_images(dim)))


if __name__ == "__main__":
    main()
