"""How well do two predictors of phi_J do along the default protocol's Newton jumps (issue 17,
item 2: "a better bracket / secant on log V vs phi")? From each run's history, no new runs of
the protocol.

- newton (the default): phi_J = phi - alpha r, r = V phi^2 / (P v) = V / (dV/dphi) at one
  jammed state (V ~ (phi - phi_J)^alpha, the virial P = phi^2 dV/dphi / v).
- secant on log V: two consecutive jammed states give r_1, r_2 with r = (phi - phi_J) / beta for
  V ~ (phi - phi_J)^beta, so the exponent is fitted, beta = (phi_1 - phi_2) / (r_1 - r_2), and
  phi_J = phi_2 - beta r_2 (the secant of d log V / dphi = 1 / r).

The reference onset of a run is its final state's own Newton estimate (the window state sits
~1.7e-8 above phi_J; that estimate errs by ~1% of it), so only states with phi - phi_J >= 1e-7
are scored. Relative error = (predicted - true distance) / true distance.

    python benchmarks/onset_predictors.py --n 256 --seeds 0 1 2 3 4 5 6 7 --out docs/onset-predictors.csv
    python benchmarks/onset_predictors.py --n 1024 --seeds 1 2 3 4 5 --out docs/onset-predictors.csv
"""

from __future__ import annotations

import argparse
import statistics
from pathlib import Path

from speed_accuracy import append_row  # (benchmarks/ is the script's directory)

import numpy as np

from jamflow.protocols.compression import jam


def scored_states(result, min_distance=1e-7):
    """Rows (seed-free) of the two predictors' relative errors at the run's jammed states."""
    h, p = result.history, result.packing
    phi, v, pressure = h["phi"], h["energy_per_particle"], h["pressure"]
    alpha, vtol = p.potential.onset_exponent, result.settings.v_tol
    mean_volume = p.phi * p.box.volume / p.n_mobile
    jammed = (v > 2 * vtol) & (pressure > 0) & (h["reason"] != b"energy-below-vmin")
    r = np.where(jammed, v * phi**2 / (np.where(pressure > 0, pressure, 1.0) * mean_volume), np.nan)
    r_final = v[-1] * phi[-1] ** 2 / (pressure[-1] * mean_volume)
    onset = phi[-1] - alpha * r_final
    rows = []
    for k in range(1, len(phi) - 1):
        true = phi[k] - onset
        if not (jammed[k] and jammed[k - 1]) or true < min_distance:
            continue
        beta = (phi[k - 1] - phi[k]) / (r[k - 1] - r[k])
        rows.append({"distance": f"{true:.3e}", "newton_error": f"{(alpha * r[k] - true) / true:+.5f}",
                     "secant_error": f"{(beta * r[k] - true) / true:+.5f}", "beta": f"{beta:.5f}"})
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=256)
    ap.add_argument("--dim", type=int, default=2)
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    ap.add_argument("--out", default="docs/onset-predictors.csv")
    args = ap.parse_args()
    newton, secant = [], []
    for seed in args.seeds:
        result = jam(n=args.n, dim=args.dim, seed=seed)
        for row in scored_states(result):
            row = {"n": args.n, "dim": args.dim, "seed": seed, **row}
            append_row(Path(args.out), list(row), row)
            newton.append(abs(float(row["newton_error"])))
            secant.append(abs(float(row["secant_error"])))
    print(f"N = {args.n}: {len(newton)} states; |relative error| median newton {statistics.median(newton):.4f} "
          f"(max {max(newton):.4f}), secant {statistics.median(secant):.4f} (max {max(secant):.4f}); secant better "
          f"at {sum(s < n for s, n in zip(secant, newton))}")


if __name__ == "__main__":
    main()
