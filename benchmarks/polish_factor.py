"""The polish's sparse factorisation against the particles' numbering: CPU seconds of one
factorisation of J_A^T J_A + mu I (``jamflow.minimize.polish``) by SciPy's SuperLU (minimum degree
on A^T + A, as the polish runs it below ``cholesky.CHOLMOD_FROM_DOF``) and by CHOLMOD
(``jamflow.minimize.cholesky.factorise``), for one near-onset state with its particles in a random
order and numbered along the Morton curve (``jamflow.model.ordering``), alternating, best of
``--repeats`` (docs/notes/newton-krylov.md).

    python benchmarks/polish_factor.py --n 16384 --out docs/notes/polish-factor.csv

The state: a 2D bidisperse random start at phi = 0.85 relaxed by FIRE to max force 1e-9 (above
the onset, as the polish meets it).
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np

from common import append_row, check_outputs, scratch  # (benchmarks/ is the script's directory)

from jamflow.engines.compiled.engine import CompiledEngine
from jamflow.minimize import cholesky
from jamflow.minimize.polish import model, shift
from jamflow.minimize.rules import minimize
from jamflow.minimize.settings import MinimizerSettings
from jamflow.model.ordering import morton_order
from jamflow.protocols.compression import initial_packing

COLUMNS = ["n", "order", "solver", "cpu_s", "factor_nnz", "contacts", "load"]


def near_onset_state(n: int, seed: int, iterations: int):
    start = initial_packing(n, 2, "bi:1.4:0.5", "spring", seed, 0.85)
    with CompiledEngine(start) as eng:
        minimize(eng, MinimizerSettings(force_tol=1e-9, max_iterations=iterations, creep="off"))
        return eng.packing()


def matrix_of(packing):
    import scipy.sparse as sp

    delta, jac = model(packing)
    on = delta > 0
    return (jac[on].T @ jac[on] + shift(jac) * sp.identity(jac.shape[1])).tocsc(), int(on.sum())


def timed(solver: str, matrix) -> tuple[float, int]:
    t = time.process_time()
    if solver == "superlu":
        lu = cholesky.superlu(matrix)
        return time.process_time() - t, int(lu.L.nnz)
    cholesky.factorise(matrix)
    return time.process_time() - t, 0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, nargs="+", default=[16384])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--relax", type=int, default=100_000, help="FIRE iterations at most for the state")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", default=str(scratch("polish-factor.csv")))
    args = ap.parse_args(argv)
    check_outputs(args.out)
    for n in args.n:
        state = near_onset_state(n, args.seed, args.relax)
        shuffled = state.subset(np.random.default_rng(0).permutation(n))
        ordered = state.subset(morton_order(state.box.to_fractional(state.box.wrap(state.positions))))
        matrices = {"random": matrix_of(shuffled), "morton": matrix_of(ordered)}
        best = {}
        for _ in range(args.repeats):
            for order, (matrix, _contacts) in matrices.items():
                for solver in ("superlu", "cholmod"):
                    cpu, nnz = timed(solver, matrix)
                    key = (order, solver)
                    best[key] = min(best.get(key, (np.inf, 0)), (cpu, nnz))
        for (order, solver), (cpu, nnz) in best.items():
            row = {"n": n, "order": order, "solver": solver, "cpu_s": round(cpu, 4), "factor_nnz": nnz,
                   "contacts": matrices[order][1], "load": round(os.getloadavg()[0], 2)}
            print(" ".join(f"{k}={v}" for k, v in row.items()), flush=True)
            append_row(Path(args.out), COLUMNS, row)


if __name__ == "__main__":
    main()
