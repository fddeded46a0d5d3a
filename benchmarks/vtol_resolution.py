"""Where V_tol stops being resolvable in float64: jam with ever smaller V_tol and check each
packing (window, force balance, contact count; jamflow.mechanics.checks) against the two ratios that
jamflow.mechanics.checks.resolution predicts before any work (typical window overlap / position
round-off, window contact force / force tolerance).

    python benchmarks/vtol_resolution.py --out docs/notes/vtol-resolution.csv   (default: the scratch directory)

The refusal in compress() is switched off here, since this measures what it refuses.
Load-independent: iteration counts and pass/fail only, no timings.
"""

from __future__ import annotations

import argparse
import sys

import jamflow.protocols.compression as compression
from jamflow.mechanics.checks import check_packing, resolution
from jamflow.minimize.settings import MinimizerSettings

from common import append_row, jam_quietly, scratch  # (benchmarks/ is the script's directory)

COLUMNS = ["n", "potential", "seed", "vtol", "overlap_ratio", "force_ratio", "refused", "status", "passed",
           "force_balance", "max_force", "excess_contacts", "n_floaters", "v", "minimizations", "iterations"]
CASES = [(n, pot) for n in (64, 256) for pot in ("spring", "hertz")]
VTOLS = [10.0**-k for k in range(16, 28, 2)]  # from 1e-26 on no packing passes (every particle a floater)
SEEDS = range(4)


def one(n, potential, seed, vtol) -> dict:
    settings = compression.fast_protocol(v_tol=vtol, minimizer=MinimizerSettings(v_min=vtol))
    start = compression.initial_packing(n, 2, "bi:1.4:0.5", potential, seed, settings.start_phi(2))
    res = resolution(start, vtol, settings.minimizer.resolved_force_tol(start.box, start.potential.contact_stiffness))
    row = dict(n=n, potential=potential, seed=seed, vtol=f"{vtol:g}", overlap_ratio=f"{res.overlap_ratio:.3g}",
               force_ratio=f"{res.force_ratio:.3g}", refused=res.problem() is not None)
    r, failure = jam_quietly(start, settings)
    if failure:
        return {**row, "status": f"JammingFailed: {failure[:60]}"}
    c = check_packing(r.packing, v_tol=vtol)
    return {**row, "status": "jammed", "passed": c.passed, "force_balance": f"{c.force_ratio:.2g}",
            "max_force": f"{c.max_force:.2g}",
            "excess_contacts": c.excess_contacts, "n_floaters": c.n_floaters, "v": f"{c.energy_per_particle:.3g}",
            "minimizations": r.minimizations, "iterations": r.iterations}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(scratch("vtol-resolution.csv")), help="CSV the rows are added to")
    args = ap.parse_args(argv)
    compression.check_resolution = lambda packing, settings: None  # measure what the check would refuse (column refused)
    for n, pot in CASES:
        for vtol in VTOLS:
            for seed in SEEDS:
                row = one(n, pot, seed, vtol)
                append_row(args.out, COLUMNS, row)
                print(row, file=sys.stderr)


if __name__ == "__main__":
    main()
