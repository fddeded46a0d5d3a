"""A variant of the jammed-side Newton corrector (docs/notes/speed-3.md) for the last approach only: the
float64 bisection of the default protocol stopped at a loose window V_L < V < 2 V_L, then the
double-double Newton landing (``jamflow.refine_to_vtol``: Newton on the contact network, the secant
in log p, log V) down to the chapter's window at V_tol = 1e-16; against the default jam
(``jamflow.jam``, V_tol = 1e-16) of the same seed, in the same process, CPU seconds of each (so the
ratio holds under load; the seconds do not).

    python benchmarks/newton_landing.py --n 1024 --seeds 1 2 3 --loose 1e-12 --out docs/notes/newton-landing.csv

A row per (N, seed, V_L): CPU seconds and FIRE iterations of the default jam, of the loose
bisection and of the landing; phi_J of the default, phi of the landed state (hi part) and their
difference; V / V_tol and max|F| / <f> of the landed state; whether its checks pass.
"""

from __future__ import annotations

import argparse
import sys
import time

from common import append_row, scratch

COLUMNS = ["n", "seed", "loose", "default_cpu", "default_iterations", "default_phi_j", "loose_cpu", "loose_iterations",
           "landing_cpu", "total_cpu", "phi", "dphi", "v_over_vtol", "force_balance", "checks_passed", "error"]
V_TOL = 1e-16


def one(n: int, seed: int, loose: float) -> dict:
    import jamflow
    from jamflow.minimize.settings import MinimizerSettings
    from jamflow.protocols.settings import fast_protocol

    t0 = time.process_time()
    default = jamflow.jam(n=n, seed=seed, engine="numba")
    t1 = time.process_time()
    settings = fast_protocol(v_tol=loose, coarse_v_min=max(1e-10, 4 * loose), minimizer=MinimizerSettings(v_min=loose))
    first = jamflow.jam(n=n, seed=seed, engine="numba", settings=settings)
    t2 = time.process_time()
    row = {"n": n, "seed": seed, "loose": loose, "default_cpu": f"{t1 - t0:.2f}", "default_iterations": default.iterations,
           "default_phi_j": f"{default.phi_j:.12f}", "loose_cpu": f"{t2 - t1:.2f}", "loose_iterations": first.iterations}
    try:
        landed = jamflow.refine_to_vtol(first.packing, V_TOL)
    except Exception as err:  # noqa: BLE001 - a failed landing is a row with its error
        return {**row, "error": f"{type(err).__name__}: {err}"}
    t3 = time.process_time()
    return {**row, "landing_cpu": f"{t3 - t2:.2f}", "total_cpu": f"{t3 - t1:.2f}", "phi": f"{landed.phi[0]:.12f}",
            "dphi": f"{landed.phi[0] - default.phi_j:+.2e}", "v_over_vtol": f"{landed.energy_per_particle / V_TOL:.4f}",
            "force_balance": f"{landed.force_balance:.1e}", "checks_passed": landed.checks().passed, "error": ""}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, nargs="+", default=[1024])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--loose", type=float, nargs="+", default=[1e-12], help="V_L of the float64 bisection")
    ap.add_argument("--out", default=str(scratch("newton-landing.csv")))
    args = ap.parse_args(argv)
    for n in args.n:
        for loose in args.loose:
            for seed in args.seeds:
                row = one(n, seed, loose)
                append_row(args.out, COLUMNS, row)
                print(" ".join(f"{k}={row.get(k, '')}" for k in COLUMNS if row.get(k, "") != ""), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
