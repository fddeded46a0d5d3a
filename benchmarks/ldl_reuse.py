"""The Gauss-Newton polish's factorisations, SuperLU against an LDL^T that keeps its symbolic analysis
(whether reusing the symbolic factorisation pays; measured in docs/notes/speed-3.md).

scikit-sparse (CHOLMOD) has no wheel for this Python on the package index this project installs
from; ``qdldl`` (OSQP's LDL^T, a wheel) has the same split: ``Solver(K)`` orders (AMD) and analyses
K once, ``Solver.update(K')`` refactorises a matrix of the same pattern numerically only. Within one
polish step the pairs (J) are fixed and only the active set changes, so the pattern of
K = J^T W J + mu I over *all* pairs within sigma + SKIN is fixed: inactive rows get the weight
``TINY`` instead of 0 (scipy drops exact zeros from a product, which would change the pattern).

For each seed: the default jam's packing, compressed affinely by ``--dphi`` and relaxed by FIRE to
max force 1e-9 (where the polish starts, ``minimize.settings.CREEP_FORCE``); then one
``polish.model_step`` as jamflow runs it (one SuperLU per active-set iteration) against the same
``model_step`` given the LDL^T (``ReusedLDL``), and the factorisation alone timed both ways (minimum of
``--repeats``, wall milliseconds). Needs ``pip install qdldl`` (not a jamflow dependency).

    python benchmarks/ldl_reuse.py --n 1024 --seeds 1 2 3 --out docs/notes/ldl-reuse.csv
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from common import append_row, check_outputs  # (benchmarks/ is the script's directory)

TINY = 1e-150  # the weight of an inactive pair: keeps the pattern, adds nothing a float64 sum sees


def _best_ms(fn, repeats):
    best, out = np.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return 1e3 * best, out


def _weighted(jac, weights, mu):
    """The upper triangle of J^T diag(w) J + mu I, CSC (qdldl's input)."""
    import scipy.sparse as sp

    jw = sp.diags(np.sqrt(weights)) @ jac
    return sp.triu((jw.T @ jw + mu * sp.identity(jac.shape[1], format="csc")).tocsc(), format="csc")


class ReusedLDL:
    """A ``factorise`` for ``polish.model_step``: the LDL^T of J^T W J + mu I over all pairs of
    ``jac``, analysed on the first call and refactorised numerically on the later ones."""

    def __init__(self, jac):
        self.jac, self.solver, self.pattern = jac, None, None

    def __call__(self, ja, active, mu):
        import qdldl

        matrix = _weighted(self.jac, np.where(active, 1.0, TINY), mu)
        if self.solver is None:
            self.solver = qdldl.Solver(matrix, upper=True)
            self.pattern = (matrix.indptr.copy(), matrix.indices.copy())
        elif not (np.array_equal(matrix.indptr, self.pattern[0]) and np.array_equal(matrix.indices, self.pattern[1])):
            raise RuntimeError("the weighted matrix changed its pattern")
        else:
            self.solver.update(matrix, upper=True)
        return self.solver


def polish_start(n, seed, dphi):
    """The default jam of ``seed``, compressed by ``dphi`` and relaxed to max force 1e-9."""
    from jamflow.engines.compiled.engine import CompiledEngine
    from jamflow.minimize.rules import minimize
    from jamflow.minimize.settings import CREEP_FORCE, MinimizerSettings
    from jamflow.protocols.compression import jam

    packing = jam(n=n, seed=seed).packing
    engine = CompiledEngine(packing.scaled_to_phi(packing.phi + dphi))
    result = minimize(engine, replace(MinimizerSettings(), force_tol=CREEP_FORCE, creep="off"))
    return engine.packing(), result


def row(n, seed, dphi, repeats):
    import qdldl

    from jamflow.minimize import polish

    start, relaxed = polish_start(n, seed, dphi)
    delta, jac = polish.model(start)
    mu = polish.shift(jac)
    t_step_lu, (dx_lu, _, inner_lu) = _best_ms(lambda: polish.model_step(delta, jac, mu), repeats)
    t_step_ldl, (dx_ldl, _, inner_ldl) = _best_ms(
        lambda: polish.model_step(delta, jac, mu, factorise=ReusedLDL(jac)), repeats)
    on = delta > 0
    ja = jac[on]
    t_lu, _ = _best_ms(lambda: polish.superlu(ja, on, mu), repeats)
    matrix = _weighted(jac, np.where(on, 1.0, TINY), mu)
    t_build, _ = _best_ms(lambda: _weighted(jac, np.where(on, 1.0, TINY), mu), repeats)
    t_analyse, solver = _best_ms(lambda: qdldl.Solver(matrix, upper=True), repeats)
    t_update, _ = _best_ms(lambda: solver.update(matrix, upper=True), repeats)
    m_lu, m_ldl = polish.model_value(delta, jac, dx_lu, mu), polish.model_value(delta, jac, dx_ldl, mu)
    return {"n": n, "seed": seed, "dphi": dphi, "start_max_force": f"{relaxed.max_force:.3g}",
            "pairs": jac.shape[0], "active": int(on.sum()), "inner_superlu": inner_lu, "inner_ldl": inner_ldl,
            "model_superlu": f"{m_lu:.6e}", "model_ldl": f"{m_ldl:.6e}", "step_superlu_ms": round(t_step_lu, 3),
            "step_ldl_ms": round(t_step_ldl, 3), "superlu_factor_ms": round(t_lu, 3),
            "ldl_build_ms": round(t_build, 3), "ldl_analyse_and_factor_ms": round(t_analyse, 3),
            "ldl_update_ms": round(t_update, 3)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, nargs="+", default=[1024])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--dphi", type=float, default=1e-5, help="compression above the jammed packing (phi)")
    ap.add_argument("--repeats", type=int, default=10)
    ap.add_argument("--out", default=None, help="append the rows to this CSV")
    args = ap.parse_args(argv)
    try:
        import qdldl  # noqa: F401
    except ImportError:
        raise SystemExit("ldl_reuse needs qdldl, which jamflow does not install: pip install qdldl")
    check_outputs(args.out and Path(args.out))
    for n in args.n:
        for seed in args.seeds:
            r = row(n, seed, args.dphi, args.repeats)
            print(" ".join(f"{k}={v}" for k, v in r.items()), flush=True)
            if args.out:
                append_row(Path(args.out), list(r), r)


if __name__ == "__main__":
    main()
