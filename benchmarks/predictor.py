"""Affine remap against a secant predictor between jammed states (issue 17, item 2),
measured, not kept (docs/speed-2.md): same seeds, the compiled engine, the default protocol.

Secant: above jamming the minimum moves smoothly with phi while the contact network does
not change, so the last two force-balanced jammed states (phi_0, u_0), (phi_1, u_1) predict
the next start u(phi) = u_1 + (u_1 - u_0) (phi - phi_1) / (phi_1 - phi_0), in base-box units
u = x / (box scale) (u_1 - u_0 in its minimum image): the affine remap plus the extrapolated
non-affine relaxation (the secant form of H^-1 dF/dphi). Contact-network check: the two
networks, and the prediction's against the last, may differ by at most ``--max-change`` of
the contacts (1 = no check); otherwise, and after an unjammed state, the affine remap.
The predictor is installed on ``CompiledEngine`` (set_box / minimize) for the secant runs.

    python benchmarks/predictor.py --n 1024 --seeds 0 1 2 3 4 5 6 7 8 9 --max-change 0.05 1 --out docs/predictor-n1024.csv

Phases of a run (from its history): ``compress`` the minimisations before the first jammed
state, ``approach`` from there to the one before the final phi, ``final`` the minimisations
at the final phi (window resumes and in-place polishing included). One row per run.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

from speed_accuracy import append_row  # (benchmarks/ is the script's directory)

import numpy as np

from jamflow.mechanics.checks import check_packing
from jamflow.engines.compiled.engine import CompiledEngine
from jamflow.model.pairs import overlapping_pairs
from jamflow.protocols.settings import fast_protocol
from jamflow.protocols.compression import jam

PLAIN = {"set_box": CompiledEngine.set_box, "minimize": CompiledEngine.minimize}


def contact_ids(packing) -> np.ndarray:
    i, j = overlapping_pairs(packing)[:2]
    return np.sort(i.astype(np.int64) * packing.n + j)


def network_change(a, b) -> float:
    """Contacts in one network and not the other, as a fraction of the larger network."""
    return len(np.setxor1d(a, b, assume_unique=True)) / max(len(a), len(b), 1)


class Secant:
    """The last two jammed states of one compression, in base-box units."""

    def __init__(self, template, max_change):
        self.base_box, self.base_volume, self.max_change = template.box, template.box.volume, max_change
        self.states, self.starts = [], 0  # [(phi, u, contacts)], secant starts made

    def scale(self, box) -> float:
        return (box.volume / self.base_volume) ** (1.0 / box.dim)

    def record(self, packing, jammed: bool) -> None:
        if not jammed:
            self.states.clear()
            return
        phi = 1.0 / packing.box.volume  # phi up to a constant factor
        keep = [s for s in self.states[-1:] if s[0] != phi]
        self.states = [*keep, (phi, packing.positions / self.scale(packing.box), contact_ids(packing))]

    def predict(self, template, box):
        """Positions at ``box`` from the secant, or None (affine)."""
        phi = 1.0 / box.volume
        if len(self.states) < 2 or phi == self.states[-1][0]:
            return None
        (phi0, u0, c0), (phi1, u1, c1) = self.states
        if network_change(c0, c1) > self.max_change:
            return None
        u = u1 + self.base_box.minimum_image(u1 - u0) * ((phi - phi1) / (phi1 - phi0))
        x = box.wrap(u * self.scale(box))
        if network_change(contact_ids(template.with_positions(x, box=box)), c1) > self.max_change:
            return None
        self.starts += 1
        return x


def install(max_change: float, v_tol: float, predictors: list) -> None:
    """Give every new CompiledEngine a secant predictor (None: restore the affine remap)."""
    if max_change is None:
        CompiledEngine.set_box, CompiledEngine.minimize = PLAIN["set_box"], PLAIN["minimize"]
        return

    def minimize(self, settings=None):
        result = PLAIN["minimize"](self, settings)
        if not hasattr(self, "secant"):
            self.secant = Secant(self.template, max_change)
            predictors.append(self.secant)
        self.secant.record(self.packing(), result.converged and result.reason != "energy-below-vmin"
                           and result.energy_per_particle > v_tol)
        return result

    def set_box(self, box):
        PLAIN["set_box"](self, box)
        x = self.secant.predict(self.template, box) if hasattr(self, "secant") else None
        if x is not None:
            self.set_positions(x)

    CompiledEngine.set_box, CompiledEngine.minimize = set_box, minimize


def phase_iterations(history: dict, v_tol: float) -> dict:
    """Iterations in the compress / approach / final phases of one run."""
    phi, its, v = history["phi"], history["iterations"], history["energy_per_particle"]
    jammed = np.flatnonzero((v > v_tol) & (history["reason"] != b"energy-below-vmin"))
    first = int(jammed[0]) if len(jammed) else len(phi)
    final = int(np.flatnonzero(phi != phi[-1])[-1]) + 1 if np.any(phi != phi[-1]) else 0
    first = min(first, final)
    return {"compress": int(its[:first].sum()), "approach": int(its[first:final].sum()), "final": int(its[final:].sum())}


def run(n, dim, seed, max_change) -> dict:
    settings, predictors = fast_protocol(), []
    install(max_change, settings.v_tol, predictors)
    t0, c0 = time.perf_counter(), time.process_time()
    result = jam(n=n, dim=dim, seed=seed, settings=settings, engine="numba")
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    install(None, settings.v_tol, predictors)
    ftol = settings.minimizer.resolved_force_tol(result.packing.box, result.packing.potential.contact_stiffness)
    checks = check_packing(result.packing, result.energy_per_particle, None, settings.v_tol, ftol)
    return {"n": n, "dim": dim, "seed": seed, "predictor": "affine" if max_change is None else "secant",
            "max_change": "" if max_change is None else max_change, "phi_j": f"{result.phi_j:.10f}",
            "iterations": result.iterations, **phase_iterations(result.history, settings.v_tol),
            "minimizations": result.minimizations, "secant_starts": sum(p.starts for p in predictors),
            "cpu_s": round(cpu, 3), "wall_s": round(wall, 3), "checks": checks.passed,
            "max_force": f"{result.max_force:.2e}", "load": round(os.getloadavg()[0], 2)}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=256)
    ap.add_argument("--dim", type=int, default=2)
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    ap.add_argument("--max-change", type=float, nargs="+", default=[0.05],
                    help="contact-network change the secant check allows (1 = no check)")
    ap.add_argument("--out", default="docs/predictor.csv")
    args = ap.parse_args()
    jam(n=16, seed=0)  # numba's first call outside the timings
    out = Path(args.out)
    for seed in args.seeds:
        for max_change in [None, *args.max_change]:
            row = run(args.n, args.dim, seed, max_change)
            print(" ".join(f"{k}={v}" for k, v in row.items()), flush=True)
            append_row(out, list(row), row)


if __name__ == "__main__":
    main()
