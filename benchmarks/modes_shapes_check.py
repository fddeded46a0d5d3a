"""The numbers behind docs/modes-rotations.md's checks of the shape dynamical matrix: for each
model of tests/test_hessian_shapes.py, the largest difference between the analytic matrix and
Richardson-extrapolated second differences of the numpy reference energy (relative to max |M|),
at several steps h; the symmetry and translation residuals. Uses the tests' helpers.

Usage: python benchmarks/modes_shapes_check.py [--steps 1e-3 5e-4 2.5e-4]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from test_hessian_shapes import (MODELS, busiest_particle_entries, model_packing,  # noqa: E402
                                 second_difference)

from jamflow.mechanics.hessian import Coordinates, hessian  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=float, nargs="+", default=[1e-3, 5e-4, 2.5e-4])
    args = ap.parse_args()
    print(f"{'model':>12} {'N':>4} {'d_f N':>6} {'entries':>7} " + " ".join(f"{'h=' + format(h, 'g'):>10}" for h in args.steps)
          + f" {'|M-M^T|':>9} {'|M T|':>9}   (relative to max |M|)")
    for model, dim in MODELS:
        p = model_packing(model, dim)
        m = hessian(p).toarray()
        scale = np.abs(m).max()
        entries = busiest_particle_entries(p, m)
        got = np.array([m[a, b] for a, b in entries])
        errors = [np.abs(got - np.array([second_difference(p, a, b, h) for a, b in entries])).max() / scale
                  for h in args.steps]
        sym = np.abs(m - m.T).max() / scale
        trans = np.abs(m @ Coordinates.of(p).translations()).max() / scale
        print(f"{model + '-' + str(dim) + 'd':>12} {p.n:>4} {m.shape[0]:>6} {len(entries):>7} "
              + " ".join(f"{e:10.1e}" for e in errors) + f" {sym:9.1e} {trans:9.1e}", flush=True)


if __name__ == "__main__":
    main()
