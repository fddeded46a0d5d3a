"""Where a creeping minimisation's residual force lies, and what one soft-mode step does
(docs/notes/soft-modes.md).

    python benchmarks/soft_modes.py PACKING.h5                 # spectrum bands, gradient shares, energy along the mode
    python benchmarks/soft_modes.py PACKING.h5 --minimize soft-modes off   # then minimise from it with and without the steps

For a packing file (typically the last state of a minimisation that hit the iteration cap): the
eigenvalues of the dynamical matrix of the non-floaters in bands, the norm of the gradient in each
band, the mode carrying most of it, and the exact energy change along that mode (numpy reference)
against the Newton prediction -c^2 / (2 lambda). With ``--minimize``, ``minimize()`` from the file
with ``creep`` soft-modes / off (CPU seconds, iterations, stop reason, final energy per particle).
"""

from __future__ import annotations

import argparse
import logging
import time

import numpy as np

from jamflow.mechanics.dynamical_matrix import DynamicalMatrix
from jamflow.engines.compiled.engine import CompiledEngine
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.io.packing_file import load_packing
from jamflow.minimize.settings import MinimizerSettings
from jamflow.minimize.rules import minimize
from jamflow.mechanics.checks import generalized_forces
from jamflow.minimize.soft_modes import _moved

BANDS = [(-np.inf, 1e-15), (1e-15, 1e-11), (1e-11, 1e-8), (1e-8, 1e-5), (1e-5, np.inf)]


def analyse(packing) -> None:
    dyn = DynamicalMatrix().compute(packing)
    ref = energy_forces_pressure(packing)
    grad = -generalized_forces(packing, ref, dyn.particles)
    values, vectors = np.linalg.eigh(dyn.matrix.toarray())
    c = vectors.T @ grad
    print(f"N' = {len(dyn.particles)} of {packing.n}, {dyn.n_dof} coordinates, energy {ref.energy:.4g}, "
          f"|gradient| {np.linalg.norm(grad):.3g}")
    for lo, hi in BANDS:
        band = (values >= lo) & (values < hi)
        print(f"  eigenvalues in [{lo:.0e}, {hi:.0e}): {int(band.sum()):4d} modes, gradient norm {np.linalg.norm(c[band]):.3g}")
    k = int(np.argmax(np.abs(c)))
    lam, ck = values[k], c[k]
    step = abs(ck) / abs(lam)
    print(f"mode {k}: eigenvalue {lam:.4g}, c {ck:.4g}, translational share "
          f"{float(dyn.translational_fraction(vectors[:, k:k + 1])[0]):.2f}, Newton length {step:.4g}, "
          f"predicted energy change {-ck**2 / (2 * abs(lam)):.4g}")
    direction = -np.sign(ck) * vectors[:, k]
    for factor in (0.1, 0.35, 0.7, 1.0, 1.4, 2.3, 7.0):
        moved = _moved(packing, dyn, factor * step * direction)
        print(f"  {factor:4.2f} x Newton length: energy change {energy_forces_pressure(moved).energy - ref.energy:.4g}")


def run(packing, creep: str, max_iterations: int) -> None:
    cpu = time.process_time()
    with CompiledEngine(packing) as engine:
        result = minimize(engine, MinimizerSettings(creep=creep, creep_after=10_000,
                                                    max_iterations=max_iterations))
    print(f"creep {creep}: {result.reason}, {result.iterations} iterations, {result.creep_steps} steps "
          f"kept, V/N {result.energy_per_particle:.4g}, max F {result.max_force:.2g}, max tau/d "
          f"{result.max_torque:.2g}, {time.process_time() - cpu:.1f} CPU s")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("packing")
    ap.add_argument("--minimize", nargs="*", choices=("soft-modes", "off"), default=[],
                    help="minimise from the file with each creep method")
    ap.add_argument("--max-iterations", type=int, default=500_000)
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="  %(message)s")
    packing = load_packing(args.packing)
    analyse(packing)
    for creep in args.minimize:
        run(packing, creep, args.max_iterations)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
