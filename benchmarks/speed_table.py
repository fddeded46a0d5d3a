"""The side-by-side table of issue 17: jamflow's default ``jamflow jam`` as a whole process
and in process, against the hand-written LAMMPS protocol (``speed_vs_handwritten.py``), the
same seeds and starts, with iterations per phase (compress / approach / final, as in
``predictor.py``) and the packing checks.

    python benchmarks/speed_table.py --dim 2 --n 64 256 1024 --seeds 1 2 3 4 5 --handwritten 64 256 1024 --out docs/speed-table.csv
    python benchmarks/speed_table.py --dim 3 --sizes mono --n 512 --seeds 1 2 3 --handwritten 512 --out docs/speed-table.csv

Whole process: ``python -m jamflow.cli jam ...`` wall and CPU (user + sys) seconds, imports
and numba's cache load included. In process: ``jam()`` with a warm interpreter. Rows are
appended with the load average; run under ``flock /tmp/jamflow-bench.lock``.
"""

from __future__ import annotations

import argparse
import csv
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from predictor import phase_iterations
from speed_vs_handwritten import handwritten_jam

from jamflow.checks import check_packing
from jamflow.protocols.compression import PROTOCOLS, DEFAULT_PROTOCOL, initial_packing, jam


def whole_process(n, dim, sizes, seed, tmp) -> tuple[float, float]:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "jamflow.cli", "jam", "--n", str(n), "--dim", str(dim), "--sizes", sizes,
                    "--seed", str(seed), "--quiet", "--force", "--out", f"{tmp}/p.h5"], check=True,
                   stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def jamflow_row(n, dim, sizes, seed, tmp, process: bool) -> dict:
    wall, cpu = whole_process(n, dim, sizes, seed, tmp) if process else (None, None)
    settings = PROTOCOLS[DEFAULT_PROTOCOL]()
    t0, c0 = time.perf_counter(), time.process_time()
    r = jam(n=n, dim=dim, sizes=sizes, seed=seed, settings=settings)
    inproc, inproc_cpu = time.perf_counter() - t0, time.process_time() - c0
    ftol = settings.minimizer.resolved_force_tol(r.packing.box, r.packing.potential.contact_stiffness)
    checks = check_packing(r.packing, r.energy_per_particle, None, settings.v_tol, ftol)
    return {"method": "jamflow", "n": n, "dim": dim, "sizes": sizes, "seed": seed, "phi_j": f"{r.phi_j:.10f}",
            "process_wall_s": "" if wall is None else round(wall, 3),
            "process_cpu_s": "" if cpu is None else round(cpu, 3), "inprocess_wall_s": round(inproc, 3),
            "inprocess_cpu_s": round(inproc_cpu, 3), "iterations": r.iterations,
            **phase_iterations(r.history, settings.v_tol), "minimizations": r.minimizations,
            "checks": checks.passed, "load": round(os.getloadavg()[0], 2)}


def handwritten_row(n, dim, sizes, seed, tmp) -> dict:
    start = initial_packing(n, dim, sizes, "spring", seed, PROTOCOLS["seed"]().start_phi(dim))
    c0 = time.process_time()
    phi, v, m, seconds = handwritten_jam(start, Path(tmp) / "start.data")
    return {"method": "handwritten", "n": n, "dim": dim, "sizes": sizes, "seed": seed, "phi_j": f"{phi:.10f}",
            "process_wall_s": "", "process_cpu_s": "", "inprocess_wall_s": round(seconds, 3),
            "inprocess_cpu_s": round(time.process_time() - c0, 3), "iterations": "", "compress": "", "approach": "",
            "final": "", "minimizations": m, "checks": "", "load": round(os.getloadavg()[0], 2)}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dim", type=int, default=2)
    ap.add_argument("--sizes", default="bi:1.4:0.5")
    ap.add_argument("--n", type=int, nargs="+", default=[64, 256, 1024])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    ap.add_argument("--handwritten", type=int, nargs="*", default=[], help="sizes that also run the LAMMPS baseline")
    ap.add_argument("--handwritten-seeds", type=int, nargs="*", default=None, help="seeds of the baseline (default all)")
    ap.add_argument("--process-max", type=int, default=1024, help="whole-process runs only up to this N")
    ap.add_argument("--out", default="docs/speed-table.csv")
    args = ap.parse_args()
    jam(n=16, seed=0)  # numba's cache load outside the in-process timings
    out = Path(args.out)
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.n:
            for seed in args.seeds:
                rows = [jamflow_row(n, args.dim, args.sizes, seed, tmp, n <= args.process_max)]
                if n in args.handwritten and (args.handwritten_seeds is None or seed in args.handwritten_seeds):
                    rows.append(handwritten_row(n, args.dim, args.sizes, seed, tmp))
                for row in rows:
                    print(" ".join(f"{k}={v}" for k, v in row.items()), flush=True)
                new = not out.exists()
                with out.open("a", newline="") as fh:
                    writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
                    if new:
                        writer.writeheader()
                    writer.writerows(rows)


if __name__ == "__main__":
    main()
