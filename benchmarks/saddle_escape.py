"""Saddle escape and Newton polishing for creeping minimisations (issue 17, items 3 and 4),
measured, not kept.

Near onset the final minimisation can creep for 10^5 iterations (docs/speed.md). The anchor
is the "mixed descent" of the pele fork of the Martiniani group (``mxopt.cpp``): every T
steps a convexity check from the Hessian's eigenvalues picks between the ODE integrator and
a shifted Newton step with a line search. Here every minimisation of ``jam()`` is run in
chunks of ``--after`` iterations; after a chunk that ends near force balance (max force <
1e-9) but unconverged, the lowest eigenpairs of the sparse Hessian of the non-floaters
(shift-invert about -1e-4) are computed and, if one is negative, the particles step along
that mode (downhill side) by the length in 1e-10 x 2^m (m = 0..30) of lowest energy; then
FIRE resumes (at most 5 attempts per minimisation). Same seeds with ``--after 0`` (off).
``--method newton`` instead takes Newton steps on the current contact network (the active
set: the Hessian of the overlapping pairs of the non-floaters, translations projected out,
a 1e-14 relative shift), each accepted at the largest of alpha = 1, 1/2, 1/4, 0.1, 0.03,
0.01 that lowers the energy, contacts recomputed after every step, until max force < 1.5e-14
or no alpha lowers the energy (at most 12 steps per attempt).

    python benchmarks/saddle_escape.py --n 1024 --seeds 1 3 --after 20000 0 --out docs/saddle-escape.csv
    python benchmarks/saddle_escape.py --n 1024 --seeds 1 3 --after 20000 --method newton --out docs/saddle-escape.csv

Prints each attempt (eigenvalue, step, energy before/after) and appends one row per run.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path

from speed_accuracy import append_row  # (benchmarks/ is the script's directory)

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from jamflow.mechanics.contacts import Contacts
from jamflow.mechanics.hessian import hessian
from jamflow.engines.compiled.engine import CompiledEngine
from jamflow.minimize.settings import MinimizerSettings
from jamflow.protocols.compression import jam

CREEP_FORCE, MAX_ATTEMPTS, SHIFT, MODES = 1e-9, 5, 1e-4, 6
PLAIN_MINIMIZE = CompiledEngine.minimize


def negative_mode(packing):
    """(lowest nontrivial eigenvalue, (N, d) unit mode or None if it is not negative)."""
    kept, d = Contacts().compute(packing).kept, packing.dim
    rows = (kept[:, None] * d + np.arange(d)).ravel()
    h = hessian(packing).tocsr()[rows][:, rows].tocsc()
    values, vectors = spla.eigsh(h, k=min(MODES + d, h.shape[0] - 2), sigma=-SHIFT, which="LM")
    translations = np.kron(np.ones((len(kept), 1)), np.eye(d)) / np.sqrt(len(kept))
    vectors = vectors - translations @ (translations.T @ vectors)
    norms = np.linalg.norm(vectors, axis=0)
    values, vectors = values[norms > 0.5], vectors[:, norms > 0.5] / norms[norms > 0.5]
    k = int(np.argmin(values))
    if values[k] >= -1e-12 * float(np.abs(h.diagonal()).max()):
        return float(values[k]), None
    mode = np.zeros((packing.n, d))
    mode[kept] = vectors[:, k].reshape(-1, d)
    return float(values[k]), mode


def escape(engine, log) -> bool:
    """Step along a negative mode to the lowest energy over the trial lengths; True if moved."""
    value, mode = negative_mode(engine.packing())
    start = engine.evaluate()
    if mode is None:
        log.append((value, 0.0, start.energy, start.energy))
        return False
    x0, sign = engine.positions(), (1.0 if float(np.sum(start.forces * mode)) >= 0 else -1.0)
    best_t, best_e = 0.0, start.energy
    for t in 1e-10 * 2.0 ** np.arange(31):
        engine.set_positions(x0 + sign * t * mode)
        e = engine.evaluate().energy
        if e < best_e:
            best_t, best_e = t, e
    engine.set_positions(x0 + sign * best_t * mode)
    engine.evaluate()
    log.append((value, best_t, start.energy, best_e))
    return best_t > 0


def newton(engine, log, steps: int = 12) -> bool:
    """Newton steps on the active contact set with an energy-decrease acceptance; True if moved."""
    state, moved = engine.evaluate(), False
    for _ in range(steps):
        packing = engine.packing()
        kept, d = Contacts().compute(packing).kept, packing.dim
        rows = (kept[:, None] * d + np.arange(d)).ravel()
        h = hessian(packing).tocsr()[rows][:, rows]
        translations = np.kron(np.ones((len(kept), 1)), np.eye(d)) / np.sqrt(len(kept))
        f = state.forces[kept].ravel()
        shift = 1e-14 * float(np.abs(h.diagonal()).max())
        dx = spla.spsolve((h + shift * sp.identity(h.shape[0])).tocsc(), f - translations @ (translations.T @ f))
        dx -= translations @ (translations.T @ dx)
        x0 = engine.positions()
        for alpha in (1.0, 0.5, 0.25, 0.1, 0.03, 0.01):
            x = x0.copy()
            x[kept] += alpha * dx.reshape(-1, d)
            engine.set_positions(x)
            trial = engine.evaluate()
            if trial.energy < state.energy:
                break
        else:
            engine.set_positions(x0)
            engine.evaluate()
            log.append(("newton: no alpha lowers the energy", state.max_force))
            return moved
        state, moved = trial, True
        log.append((f"newton alpha {alpha}", state.max_force))
        if state.max_force < 1.5e-14:
            break
    return moved


def install(after: int, log: list, method: str = "escape") -> None:
    """Make CompiledEngine.minimize run in chunks of ``after`` iterations with escapes between."""
    plain = PLAIN_MINIMIZE

    def minimize(self, settings=None):
        if after <= 0:
            return plain(self, settings)
        settings = settings or MinimizerSettings()
        done, attempts, seconds = 0, 0, 0.0
        while True:
            chunk = replace(settings, max_iterations=min(after, settings.max_iterations - done))
            result = plain(self, chunk)
            done, seconds = done + result.iterations, seconds + result.seconds
            if (result.reason != "iteration-cap" or done >= settings.max_iterations or attempts >= MAX_ATTEMPTS
                    or result.max_force >= CREEP_FORCE):
                if result.reason == "iteration-cap" and done < settings.max_iterations:
                    result = plain(self, replace(settings, max_iterations=settings.max_iterations - done))
                    done, seconds = done + result.iterations, seconds + result.seconds
                return replace(result, iterations=done, seconds=seconds)
            (newton if method == "newton" else escape)(self, log)
            attempts += 1

    CompiledEngine.minimize = minimize


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=1024)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1])
    ap.add_argument("--after", type=int, nargs="+", default=[20000, 0], help="chunk length; 0: no escape")
    ap.add_argument("--method", choices=("escape", "newton"), default="escape")
    ap.add_argument("--out", default="docs/saddle-escape.csv")
    args = ap.parse_args()
    jam(n=16, seed=0)
    out = Path(args.out)
    for seed in args.seeds:
        for after in args.after:
            log = []
            install(after, log, args.method)
            c0 = time.process_time()
            result = jam(n=args.n, seed=seed, engine="numba")
            cpu = time.process_time() - c0
            for entry in log:
                print("  attempt:", *entry)
            escapes = [e for e in log if len(e) == 4]
            row = {"n": args.n, "seed": seed, "method": args.method if after else "none", "after": after,
                   "phi_j": f"{result.phi_j:.10f}", "iterations": result.iterations,
                   "final_iterations": int(result.history["iterations"][-1]), "attempts": len(log),
                   "negative_modes": sum(e[0] < 0 for e in escapes),
                   "moved": sum(e[1] > 0 for e in escapes) + sum(str(e[0]).startswith("newton alpha") for e in log),
                   "cpu_s": round(cpu, 2)}
            print(" ".join(f"{k}={v}" for k, v in row.items()), flush=True)
            append_row(out, list(row), row)


if __name__ == "__main__":
    main()
