"""Newton jumps whose length follows the measured prediction error (issue 17, item 2: fewer
minimisations near onset), against the default fixed ratio, same seeds, compiled engine.

The default protocol (``PhiStepper._newton``) shrinks the predicted distance to onset,
w = alpha V phi^2 / (P v), by at most ``newton_ratio`` = 10 per jump, because the prediction
errs by a few % of w. Adaptive: after a jump between two jammed states the change of the
predicted onset, |phi_J(new) - phi_J(old)|, is the error the old prediction made; the next
jump stops ``--margin`` times that error above the new predicted onset (never below the
window rule's 3x), so a sequence of accurate predictions takes longer jumps (up to
``--max-ratio``); a jump is never shorter than the default's. After a
jump that lands below jamming the history is dropped (the next jammed state may be another
basin) and the default rule applies.

    python benchmarks/adaptive_jumps.py --n 256 --seeds 0 1 2 3 4 5 6 7 --margin 5 10 --out docs/adaptive-jumps.csv
    python benchmarks/adaptive_jumps.py --n 1024 --seeds 1 2 3 4 5 --margin 10 --out docs/adaptive-jumps.csv
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

from predictor import phase_iterations  # (benchmarks/ is the script's directory)
from speed_accuracy import append_row

from jamflow.mechanics.checks import check_packing
from jamflow.protocols import compression
from jamflow.protocols.compression import NEWTON_FINAL_FACTOR, PhiStepper, jam
from jamflow.protocols.settings import fast_protocol


def adaptive_stepper(margin: float, max_ratio: float):
    class Adaptive(PhiStepper):
        """``PhiStepper`` whose intermediate Newton jumps stop ``margin`` x the last
        correction of the predicted onset above it (between the default 10x and max_ratio)."""

        jumps = 0

        def _newton(self, phi, v, pressure):
            if self.side != "above" or pressure <= 0:
                self.onset = None
                return None
            width = self.alpha * v * phi**2 / (pressure * self.mean_volume)
            onset, last = phi - width, getattr(self, "onset", None)
            self.onset = onset
            target = super()._newton(phi, v, pressure)
            if last is None or self.final_approach:
                return target
            window = width * (1.5 * self.s.v_tol / v) ** (1.0 / self.alpha)
            stop_at = max(NEWTON_FINAL_FACTOR * window, width / max_ratio, margin * abs(onset - last))
            if stop_at >= width - self.dphi:  # not longer than the default jump
                return target
            Adaptive.jumps += 1
            self.dphi = width - stop_at
            return phi - self.dphi

        def next_phi(self, phi, v, pressure, unjammed=False):
            if v <= self.s.v_tol or unjammed:
                self.onset = None
            return super().next_phi(phi, v, pressure, unjammed)

    return Adaptive


def run(n, dim, seed, margin, max_ratio) -> dict:
    settings = fast_protocol()
    stepper = PhiStepper if margin is None else adaptive_stepper(margin, max_ratio)
    compression.PhiStepper = stepper
    try:
        t0, c0 = time.perf_counter(), time.process_time()
        result = jam(n=n, dim=dim, seed=seed, settings=settings, engine="numba")
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    finally:
        compression.PhiStepper = PhiStepper
    ftol = settings.minimizer.resolved_force_tol(result.packing.box, result.packing.potential.contact_stiffness)
    checks = check_packing(result.packing, result.energy_per_particle, None, settings.v_tol, ftol)
    return {"n": n, "dim": dim, "seed": seed, "rule": "default" if margin is None else "adaptive",
            "margin": "" if margin is None else margin, "max_ratio": "" if margin is None else max_ratio,
            "phi_j": f"{result.phi_j:.10f}", "iterations": result.iterations,
            **phase_iterations(result.history, settings.v_tol), "minimizations": result.minimizations,
            "longer_jumps": getattr(stepper, "jumps", 0), "cpu_s": round(cpu, 3), "wall_s": round(wall, 3),
            "checks": checks.passed, "max_force": f"{result.max_force:.2e}", "load": round(os.getloadavg()[0], 2)}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=256)
    ap.add_argument("--dim", type=int, default=2)
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    ap.add_argument("--margin", type=float, nargs="+", default=[5.0])
    ap.add_argument("--max-ratio", type=float, default=100.0)
    ap.add_argument("--out", default="docs/adaptive-jumps.csv")
    args = ap.parse_args()
    jam(n=16, seed=0)  # numba's first call outside the timings
    for seed in args.seeds:
        for margin in [None, *args.margin]:
            row = run(args.n, args.dim, seed, margin, args.max_ratio)
            print(" ".join(f"{k}={v}" for k, v in row.items()), flush=True)
            append_row(Path(args.out), list(row), row)


if __name__ == "__main__":
    main()
