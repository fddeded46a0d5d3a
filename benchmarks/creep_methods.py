"""jam() in process with each creep method (``MinimizerSettings.creep``), same seeds, one process
(docs/speed-2.md section 9):

    python benchmarks/creep_methods.py --n 4096 --seeds 1 2 --creep auto off

Prints phi_J, all FIRE iterations, CPU seconds and the final max force per (seed, method).
"""

from __future__ import annotations

import argparse
import time

from jamflow.minimize.settings import CREEP_METHODS, MinimizerSettings
from jamflow.protocols.settings import fast_protocol
from jamflow.protocols.compression import jam


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=4096)
    ap.add_argument("--dim", type=int, default=2, choices=(2, 3))
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--creep", nargs="+", choices=CREEP_METHODS, default=["auto", "off"])
    args = ap.parse_args(argv)
    jam(n=16, dim=args.dim, seed=0)  # numba's cache load outside the timings
    for seed in args.seeds:
        for creep in args.creep:
            cpu = time.process_time()
            r = jam(n=args.n, dim=args.dim, seed=seed, settings=fast_protocol(minimizer=MinimizerSettings(creep=creep)))
            print(f"n={args.n} seed={seed} creep={creep} phi_j={r.phi_j:.10f} iterations={r.iterations} "
                  f"cpu_s={time.process_time() - cpu:.2f} max_force={r.max_force:.2e}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
