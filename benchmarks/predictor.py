"""Affine remap against the secant predictor (issue 17, item 2), same seeds, same engine:
iterations per phase, phi_J, CPU seconds, how many starts the secant made, the checks.

    python benchmarks/predictor.py --n 256 --seeds 0 1 2 3 4 --max-change 0.05 1 --out docs/predictor.csv

Phases of a run (from its history): ``compress`` the minimisations before the first jammed
state, ``approach`` from there to the one before the final phi, ``final`` the minimisations
at the final phi (with window resumes and in-place polishing). Appends one row per run.
"""

from __future__ import annotations

import argparse
import csv
import os
import time
from pathlib import Path

import numpy as np

import jamflow.protocols.predictor as predictor_module
from jamflow.checks import check_packing
from jamflow.protocols.compression import fast_protocol, jam


def phase_iterations(history: dict, v_tol: float) -> dict:
    """Iterations in the compress / approach / final phases of one run."""
    phi, its, v = history["phi"], history["iterations"], history["energy_per_particle"]
    jammed = np.flatnonzero((v > v_tol) & (history["reason"] != b"energy-below-vmin"))
    first = int(jammed[0]) if len(jammed) else len(phi)
    final = int(np.flatnonzero(phi != phi[-1])[-1]) + 1 if np.any(phi != phi[-1]) else 0
    first = min(first, final)
    return {"compress": int(its[:first].sum()), "approach": int(its[first:final].sum()), "final": int(its[final:].sum())}


def run(n, dim, seed, predictor, max_change) -> dict:
    predictor_module.MAX_NETWORK_CHANGE = max_change
    settings = fast_protocol(predictor=predictor)
    t0, c0 = time.perf_counter(), time.process_time()
    result = jam(n=n, dim=dim, seed=seed, settings=settings)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    ftol = settings.minimizer.resolved_force_tol(result.packing.box, result.packing.potential.contact_stiffness)
    checks = check_packing(result.packing, result.energy_per_particle, None, settings.v_tol, ftol)
    predicted = result.history.get("predicted", np.zeros(0))
    return {"n": n, "dim": dim, "seed": seed, "predictor": predictor, "max_change": max_change, "phi_j": f"{result.phi_j:.10f}",
            "iterations": result.iterations, **phase_iterations(result.history, settings.v_tol),
            "minimizations": result.minimizations, "secant_starts": int(np.sum(predicted)),
            "cpu_s": round(cpu, 3), "wall_s": round(wall, 3), "checks": checks.passed,
            "max_force": f"{result.max_force:.2e}", "load": round(os.getloadavg()[0], 2)}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=256)
    ap.add_argument("--dim", type=int, default=2)
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    ap.add_argument("--predictors", nargs="+", default=["affine", "secant"])
    ap.add_argument("--max-change", type=float, nargs="+", default=[predictor_module.MAX_NETWORK_CHANGE],
                    help="contact-network change allowed by the secant check (1 = no check)")
    ap.add_argument("--out", default="docs/predictor.csv")
    args = ap.parse_args()
    jam(n=16, seed=0)  # numba's first call outside the timings
    out = Path(args.out)
    for seed in args.seeds:
        variants = [(p, c) for p in args.predictors for c in (args.max_change if p == "secant" else [0.0])]
        for predictor, max_change in variants:
            row = run(args.n, args.dim, seed, predictor, max_change)
            print(" ".join(f"{k}={v}" for k, v in row.items()), flush=True)
            new = not out.exists()
            with out.open("a", newline="") as fh:
                writer = csv.DictWriter(fh, fieldnames=list(row))
                if new:
                    writer.writeheader()
                writer.writerow(row)


if __name__ == "__main__":
    main()
