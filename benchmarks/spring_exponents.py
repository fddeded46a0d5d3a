"""Which spring exponents alpha end in a checked packing (jamflow.mechanics.checks): jam N = 32 bidisperse
disks (seed 0) with spring:ALPHA at the smallest V_tol that jamflow.mechanics.checks.resolution accepts
(x 1.5, at least 1e-16) and check the packing. Basis of compression.SPRING_ALPHA_RANGE.

    python benchmarks/spring_exponents.py fast 1.5 2 2.5 3 4 6 8 --out docs/notes/spring-exponents.csv
    python benchmarks/spring_exponents.py chapter 10                   (about 20 minutes; rows to the scratch directory)

The refusal in compress() is switched off here, since this measures what it refuses.
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

import jamflow.protocols.compression as compression
from jamflow.mechanics.checks import check_packing, resolution
from jamflow.minimize.settings import MinimizerSettings
from common import DOCS, jam_quietly, scratch  # (benchmarks/ is the script's directory)

CSV = DOCS / "spring-exponents.csv"
COLUMNS = ["alpha", "protocol", "vtol", "status", "phi_j", "final_reason", "force_balance", "excess_contacts",
           "minimizations", "iterations", "passed"]


def one(alpha: float, protocol: str) -> dict:
    make = compression.PROTOCOLS[protocol]
    start = compression.initial_packing(32, 2, "bi:1.4:0.5", f"spring:{alpha}", 0, make().start_phi(2))
    ftol = make().minimizer.resolved_force_tol(start.box, start.potential.contact_stiffness)
    vtol = max(resolution(start, 1e-16, ftol).smallest_v_tol, 1e-16) * 1.5
    settings = make(v_tol=vtol, minimizer=MinimizerSettings(v_min=vtol))
    row = dict(alpha=alpha, protocol=protocol, vtol=f"{vtol:.2g}")
    r, failure = jam_quietly(start, settings)
    if failure:
        return {**row, "status": f"JammingFailed: {failure[:80]}"}
    c = check_packing(r.packing, r.energy_per_particle, None, vtol, ftol)
    return {**row, "status": "jammed", "phi_j": f"{r.phi_j:.10f}", "final_reason": r.history["reason"][-1].decode(),
            "force_balance": f"{c.force_ratio:.2g}", "excess_contacts": c.excess_contacts,
            "minimizations": r.minimizations, "iterations": r.iterations, "passed": c.passed}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("protocol")
    ap.add_argument("alphas", type=float, nargs="+")
    ap.add_argument("--out", type=Path, default=scratch(CSV.name), help=f"CSV the rows are added to (curated: {CSV})")
    args = ap.parse_args(argv)
    protocol, alphas = args.protocol, args.alphas
    compression.check_resolution = lambda packing, settings: None  # measure what the check would refuse
    new = not args.out.exists()
    with open(args.out, "a", newline="") as fh:
        out = csv.DictWriter(fh, COLUMNS)
        if new:
            out.writeheader()
        for alpha in alphas:
            row = one(alpha, protocol)
            out.writerow(row)
            fh.flush()
            print(row, file=sys.stderr)


if __name__ == "__main__":
    main()
