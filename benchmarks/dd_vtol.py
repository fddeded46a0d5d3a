"""``jamflow jam --precision double-double --vtol V`` (docs/guide/precision.md): for each N, V_tol and seed, the
float64 onset refined to the energy window (``run_jam(JamSpec(precision="double-double", vtol=V))``):
refinements used, V / V_tol (double-double energy), pressure, max|F| / <f>, N_c against
N' d - d + 1, contacts opened/closed from the onset, seconds (wall clock: "under load" on a
shared machine); a run that fails or is refused is a row with its error.

    python benchmarks/dd_vtol.py                                   (N = 64, 256; seeds 1-3; 1e-20 1e-26 1e-32)
    python benchmarks/dd_vtol.py --n 64 --vtol 2e-35 --seeds 1     (the quick mode)
"""

from __future__ import annotations

import argparse
import time

from jamflow.protocols.outcome import JammingFailed
from jamflow.protocols.refine import dd_vtol_floor
from jamflow.protocols.spec import JamSpec, prepare, run_jam


def one(n: int, vtol: float, seed: int) -> dict:
    row = {"n": n, "vtol": vtol, "seed": seed}
    spec = JamSpec(n=n, seed=seed, engine="numba", precision="double-double", vtol=vtol)
    t0 = time.perf_counter()
    try:
        prepared = prepare(spec)
        r, checks = run_jam(spec, prepared=prepared)
    except (ValueError, JammingFailed) as err:
        return row | {"error": str(err)}
    opened, closed = r.contact_changes()
    return row | {"refines": r.refines, "v_over_vtol": f"{r.energy_per_particle / vtol:.4f}",
                  "pressure": f"{r.pressure:.4e}", "force_balance": f"{r.force_balance:.1e}",
                  "n_contacts": r.n_contacts, "isostatic": r.isostatic_contacts, "opened": len(opened),
                  "closed": len(closed), "passed": checks.passed, "floor": f"{dd_vtol_floor(prepared[1]):.1e}",
                  "seconds": f"{time.perf_counter() - t0:.2f}", "refine_seconds": f"{r.seconds:.2f}"}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, nargs="+", default=[64, 256])
    ap.add_argument("--vtol", type=float, nargs="+", default=[1e-20, 1e-26, 1e-32])
    ap.add_argument("--seeds", type=int, default=3, help="seeds 1 .. SEEDS")
    args = ap.parse_args(argv)
    for n in args.n:
        for vtol in args.vtol:
            for seed in range(1, args.seeds + 1):
                print("  ".join(f"{k}={v}" for k, v in one(n, vtol, seed).items()), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
