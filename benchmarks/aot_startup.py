"""The ahead-of-time compiled disk kernels against numba's (docs/notes/speed-2.md
sections 10 and 12): whole processes.

Whole processes, alternating run by run so that all see the same load (wall, and user + sys CPU
of the child from getrusage), after one warm-up round:

- ``numpy``, ``numpy+h5py``, ``numpy+scipy.spatial``: ``python -c "import numpy[, ...]"``, the floors;
- ``jam``: ``jamflow jam --n 64 --seed S --quiet`` as a user runs it (the AOT kernels, no numba);
- ``jam-numba``: the same with ``JAMFLOW_AOT=0`` (numba's kernels and scipy's cKDTree, as before);
- ``jam --help``.

The two jams must print the same phi_J (checked). Each set runs twice (``--bytecode both``): first
with jamflow's own modules compiled from source in every process (its ``__pycache__`` removed and
``PYTHONDONTWRITEBYTECODE=1``: a fresh clone on a machine that sets it, as this sandbox and its CI
do; ~0.09 s of compile() for ~80 modules), then with their bytecode cached (``compileall``: any
normal Python after the first run); the ``bytecode`` column says which.

    OPENBLAS_NUM_THREADS=1 python benchmarks/aot_startup.py --repeats 7 --seed 1 --out docs/notes/aot-startup.csv

The microseconds per FIRE iteration, AOT against numba (``--speed N``, docs/notes/speed-2.md section
12) needed the compiled engine's private arrays and were dropped with the one-entry-point benchmark suite:
``git show 3ba76d2:benchmarks/aot_startup.py`` (benchmarks/ARCHIVE.md).
(The session-5 rows of ``docs/notes/aot-startup.csv`` came from this script's first form, which built a
module of its own and swapped it into a jam process by stand-ins: ``git show 6ad4af5:benchmarks/aot_startup.py``.)
"""

from __future__ import annotations

import argparse
import compileall
import os
import shutil
import statistics
import sys
import tempfile
from pathlib import Path


from common import append_row, run_process  # (benchmarks/ is the script's directory)

DPHI, SKIN, STEPS, FTOL = 0.01, 1.0, 100_000, 1e-13


def processes(tmp: Path, seed: int) -> dict:
    """name -> (argv, extra environment) of the whole processes timed (module docstring)."""
    jam = [sys.executable, "-m", "jamflow.cli", "jam", "--n", "64", "--seed", str(seed), "--quiet",
           "--out", str(tmp / "p.h5"), "--force"]
    py = [sys.executable, "-c"]
    return {"numpy": (py + ["import numpy"], {}), "numpy+h5py": (py + ["import numpy, h5py"], {}),
            "numpy+scipy.spatial": (py + ["import numpy, scipy.spatial"], {}),
            "jam": (jam, {}), "jam-numba": (jam, {"JAMFLOW_AOT": "0"}),
            "jam --help": ([sys.executable, "-m", "jamflow.cli", "jam", "--help"], {})}


def alternate(procs: dict, env: dict, repeats: int) -> tuple[dict, list, bool]:
    """(name -> [(wall, cpu)], loads, same phi_J): a warm-up round, then ``repeats`` rounds."""
    runs, loads, outputs = {k: [] for k in procs}, [], {}
    for k, (argv, extra) in procs.items():
        outputs[k] = run_process(argv, {**env, **extra})[2]
    same = outputs["jam"].split()[:3] == outputs["jam-numba"].split()[:3]
    print("jam      :", outputs["jam"].splitlines()[0])
    print("jam-numba:", outputs["jam-numba"].splitlines()[0], "(same phi_J line:", same, ")")
    for _ in range(repeats):
        for k, (argv, extra) in procs.items():
            runs[k].append(run_process(argv, {**env, **extra})[:2])
        loads.append(os.getloadavg()[0])
    return runs, loads, same


def set_bytecode(cached: bool) -> None:
    """jamflow's modules with their bytecode compiled (True) or none at all (False)."""
    import jamflow

    package = Path(jamflow.__file__).parent
    for cache in package.rglob("__pycache__"):
        shutil.rmtree(cache)
    if cached:
        compileall.compile_dir(package, quiet=1)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--seed", type=int, default=1, help="seed of the jamflow jam --n 64 process")
    ap.add_argument("--out", default=None, help="CSV to append the rows to")
    ap.add_argument("--bytecode", choices=("both", "none", "cached", "asis"), default="both",
                    help="jamflow's bytecode: removed (none), compiled (cached), each in turn (both) or left "
                         "untouched (asis: the quick mode, which must not rewrite an installed package)")
    args = ap.parse_args(argv)
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "PYTHONDONTWRITEBYTECODE": "1"}
    for cached in {"both": (False, True), "none": (False,), "cached": (True,), "asis": (None,)}[args.bytecode]:
        if cached is not None:
            set_bytecode(cached)
        with tempfile.TemporaryDirectory() as tmp:
            runs, loads, same = alternate(processes(Path(tmp), args.seed), env, args.repeats)
        report(runs, loads, same, cached, args)


def report(runs: dict, loads: list, same: bool, cached: bool, args) -> None:
    for k, r in runs.items():
        walls, cpus = [w for w, _ in r], [c for _, c in r]
        row = {"what": k, "bytecode": {True: "cached", False: "none", None: "as is"}[cached], "seed": args.seed, "target_cpu": "host",
               "wall_median_s": round(statistics.median(walls), 3), "wall_min_s": round(min(walls), 3),
               "cpu_median_s": round(statistics.median(cpus), 3), "cpu_min_s": round(min(cpus), 3), "repeats": len(r),
               "load_median": round(statistics.median(loads), 2), "bit_identical": same, "build_cpu_s": ""}
        print(f"{k:19s} {row['bytecode']:6s} wall {row['wall_median_s']:.3f} s (min {row['wall_min_s']:.3f})  cpu {row['cpu_median_s']:.3f} s "
              f"(min {row['cpu_min_s']:.3f})  load {row['load_median']:.2f}")
        if args.out:
            append_row(Path(args.out), list(row), row)


if __name__ == "__main__":
    main()
