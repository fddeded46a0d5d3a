"""When the disks' polish should fire (docs/speed-2.md section 11): jam() in process with the
default creep method (2D disks: one Gauss-Newton polish per minimisation at the first multiple of
20 000 iterations below max force 1e-9) against other triggers of the same ``jamflow.minimize.polish.Polisher``
(earlier, from a higher force, repeated: the form that resolved the creep of rigid bodies), same
seeds, one process:

    OPENBLAS_NUM_THREADS=1 python benchmarks/polish_triggers.py --n 1024 --seeds 1 2 3

The triggers are set on the Polisher that ``jamflow.minimize.rules`` builds (its fields after, every,
creep_force), so everything else is the default path. Prints phi_J, all FIRE iterations and CPU
seconds per (seed, trigger).
"""

from __future__ import annotations

import argparse
import time

import jamflow.minimize.rules as minimize_module
from jamflow.minimize.settings import MinimizerSettings
from jamflow.minimize.polish import Polisher
from jamflow.protocols.settings import fast_protocol
from jamflow.protocols.compression import jam

TRIGGERS = {  # Polisher fields; {} = the default
    "default": {},
    "from-1e-6": {"creep_force": 1e-6},
    "from-1e-6-every-20k": {"creep_force": 1e-6, "every": 20_000},
    "every-20k": {"every": 20_000},
    "from-1e-6-every-5k": {"after": 5_000, "creep_force": 1e-6, "every": 5_000},
}


def with_trigger(fields: dict):
    """``minimize._creep_method`` with ``fields`` set on the Polisher it returns."""
    original = minimize_module._creep_method

    def creep_method(*args):
        method = original(*args)
        if isinstance(method, Polisher):
            for name, value in fields.items():
                setattr(method, name, value)
        return method

    return creep_method


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=1024)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--triggers", nargs="+", choices=sorted(TRIGGERS), default=list(TRIGGERS))
    args = ap.parse_args(argv)
    jam(n=16, seed=0)  # numba's cache load outside the timings
    original = minimize_module._creep_method
    for seed in args.seeds:
        for name in args.triggers:
            minimize_module._creep_method = with_trigger(TRIGGERS[name])
            try:
                cpu = time.process_time()
                r = jam(n=args.n, seed=seed, settings=fast_protocol(minimizer=MinimizerSettings()))
                cpu = time.process_time() - cpu
            finally:
                minimize_module._creep_method = original
            print(f"n={args.n} seed={seed} trigger={name} phi_j={r.phi_j:.10f} iterations={r.iterations} "
                  f"cpu_s={cpu:.2f} max_force={r.max_force:.1e}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
