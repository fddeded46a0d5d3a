"""Where a warm small-N jam spends its time (issue 17: the Python work per minimisation): the
wall seconds inside the FIRE kernel calls, the pair-list rebuilds (``_build_pairs``, of which
``engine.packing()``), box changes and state reads, timed by wrapping those calls, in a warm
process (numba's first call excluded).

    python benchmarks/small_n_overhead.py --n 64 --seeds 1 2 3
"""

from __future__ import annotations

import argparse
import time

from jamflow.engines.compiled import aot, fire
from jamflow.engines.compiled import engine as compiled
from jamflow.protocols.compression import jam

CALLS = {"fire kernel": (fire, "fire"), "fire kernel (AOT)": (aot.AotKernels, "fire"),
         "pair builds": (compiled.CompiledEngine, "_build_pairs"), "engine.packing()": (compiled.CompiledEngine, "packing"), "set_box": (compiled.CompiledEngine, "set_box"),
         "state": (compiled.CompiledEngine, "state")}


def timed(spent: dict, key: str, fn):
    def call(*args, **kwargs):
        t0 = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            spent[key] = spent.get(key, 0.0) + time.perf_counter() - t0

    return call


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    args = ap.parse_args()
    jam(n=args.n, seed=args.seeds[0])  # numba's first call and cache loads outside the timings
    spent = {}
    for key, (owner, name) in CALLS.items():
        setattr(owner, name, timed(spent, key, getattr(owner, name)))
    for seed in args.seeds:
        spent.clear()
        t0 = time.perf_counter()
        result = jam(n=args.n, seed=seed)
        total = time.perf_counter() - t0
        parts = ", ".join(f"{k} {v:.4f} s ({100 * v / total:.0f}%)" for k, v in spent.items())
        print(f"N = {args.n} seed {seed}: jam {total:.4f} s, {result.minimizations} minimisations; {parts}")


if __name__ == "__main__":
    main()
