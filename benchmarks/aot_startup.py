"""The ahead-of-time compiled disk kernels against numba's (issue 17, item 1; docs/speed-2.md
sections 10 and 12): whole processes and microseconds per FIRE iteration.

Whole processes, alternating run by run so that all see the same load (``/usr/bin/time``: wall,
user + sys), after one warm-up round:

- ``numpy``, ``numpy+h5py``, ``numpy+scipy.spatial``: ``python -c "import numpy[, ...]"``, the floors;
- ``jam``: ``jamflow jam --n 64 --seed S --quiet`` as a user runs it (the AOT kernels, no numba);
- ``jam-numba``: the same with ``JAMFLOW_AOT=0`` (numba's kernels and scipy's cKDTree, as before);
- ``jam --help``.

The two jams must print the same phi_J (checked). Each set runs twice: first with jamflow's own
modules compiled from source in every process (its ``__pycache__`` removed and
``PYTHONDONTWRITEBYTECODE=1``: a fresh clone on a machine that sets it, as this sandbox and its CI
do; ~0.09 s of compile() for ~80 modules), then with their bytecode cached (``compileall``: any
normal Python after the first run); the ``bytecode`` column says which. ``--speed N ...`` times, in one process, FIRE on
the N-particle seed 1 packing compressed by dphi = 0.01 (skin 1: no pair-list rebuild) with the AOT
kernels and with numba's, alternating, on fresh copies, and checks that they end bit-identical.

    OPENBLAS_NUM_THREADS=1 python benchmarks/aot_startup.py --repeats 7 --seed 1 --out docs/aot-startup.csv
    OPENBLAS_NUM_THREADS=1 python benchmarks/aot_startup.py --speed-only --speed 256 1024

(The session-5 rows of ``docs/aot-startup.csv`` came from this script's first form, which built a
module of its own and swapped it into a jam process by stand-ins: ``git show 6ad4af5:benchmarks/aot_startup.py``.)
"""

from __future__ import annotations

import argparse
import compileall
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from speed_accuracy import append_row  # (benchmarks/ is the script's directory)

DPHI, SKIN, STEPS, FTOL = 0.01, 1.0, 100_000, 1e-13


def timed(argv, env) -> tuple[float, float, str]:
    """(wall s, user + sys s, stdout) of one process, from ``/usr/bin/time``."""
    with tempfile.NamedTemporaryFile("r", suffix=".time") as fh:
        out = subprocess.run(["/usr/bin/time", "-o", fh.name, "-f", "%e %U %S", *argv], env=env, check=True,
                             capture_output=True, text=True).stdout
        wall, user, sys_ = map(float, fh.read().split()[-3:])
    return wall, user + sys_, out.strip()


def processes(tmp: Path, seed: int) -> dict:
    """name -> (argv, extra environment) of the whole processes timed (module docstring)."""
    jam = [sys.executable, "-m", "jamflow.cli.app", "jam", "--n", "64", "--seed", str(seed), "--quiet",
           "--out", str(tmp / "p.h5"), "--force"]
    py = [sys.executable, "-c"]
    return {"numpy": (py + ["import numpy"], {}), "numpy+h5py": (py + ["import numpy, h5py"], {}),
            "numpy+scipy.spatial": (py + ["import numpy, scipy.spatial"], {}),
            "jam": (jam, {}), "jam-numba": (jam, {"JAMFLOW_AOT": "0"}),
            "jam --help": ([sys.executable, "-m", "jamflow.cli.app", "jam", "--help"], {})}


def alternate(procs: dict, env: dict, repeats: int) -> tuple[dict, list, bool]:
    """(name -> [(wall, cpu)], loads, same phi_J): a warm-up round, then ``repeats`` rounds."""
    runs, loads, outputs = {k: [] for k in procs}, [], {}
    for k, (argv, extra) in procs.items():
        outputs[k] = timed(argv, {**env, **extra})[2]
    same = outputs["jam"].split()[:3] == outputs["jam-numba"].split()[:3]
    print("jam      :", outputs["jam"].splitlines()[0])
    print("jam-numba:", outputs["jam-numba"].splitlines()[0], "(same phi_J line:", same, ")")
    for _ in range(repeats):
        for k, (argv, extra) in procs.items():
            runs[k].append(timed(argv, {**env, **extra})[:2])
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


def kernel_speed(n: int, repeats: int) -> dict:
    """CPU microseconds per FIRE iteration, AOT and numba, in this process (medians, alternating)."""
    from jamflow.engines.compiled import aot, fire
    from jamflow.engines.compiled.engine import CompiledEngine
    from jamflow.protocols.compression import jam

    jammed = jam(n=n, seed=1).packing
    engine = CompiledEngine(jammed.scaled_to_phi(jammed.phi + DPHI), skin=SKIN)
    model, fld = engine._model(), engine._field
    base = dict(x=engine._x, v=np.zeros_like(engine._x), f=engine._f, o=engine._o, w=np.zeros_like(engine._g),
                tau=engine._tau, g=engine._g, dk=engine._dk, mask=engine._mask, virial=engine._virial,
                ub=np.zeros(0), gb=engine._gb, state=fire.fire_state(0.1), x_built=engine._built_at,
                turned=engine._turned, reach=engine._reach)
    kernels = {"aot": aot.AotKernels(aot.module()).fire, "numba": fire.fire}

    def run(kind):
        arrays = [a.copy() for a in base.values()]
        shift = model.shift.copy()
        t0 = time.process_time()
        it, *_ = kernels[kind](model._replace(shift=shift), fld, *arrays, (SKIN / 2) ** 2, STEPS, FTOL, -np.inf)
        return 1e6 * (time.process_time() - t0) / it, (it, arrays[0].tobytes())

    same = run("aot")[1] == run("numba")[1]  # warm-up, and the same iterations and positions (bits)
    per = {"aot": [], "numba": []}
    for _ in range(repeats):
        for kind in per:
            per[kind].append(run(kind)[0])
    return {k: statistics.median(v) for k, v in per.items()} | {"iterations": run("aot")[1][0], "same": same}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--seed", type=int, default=1, help="seed of the jamflow jam --n 64 process")
    ap.add_argument("--out", default=None, help="CSV to append the rows to")
    ap.add_argument("--speed", type=int, nargs="*", default=[], help="also time the kernels per iteration at these N")
    ap.add_argument("--speed-only", action="store_true", help="only the per-iteration timing (--speed)")
    ap.add_argument("--speed-repeats", type=int, default=5)
    args = ap.parse_args()
    for n in args.speed:
        speed = kernel_speed(n, args.speed_repeats)
        print(f"N = {n}: {speed['iterations']} iterations, bit-identical {speed['same']}; CPU us per iteration: "
              f"AOT {speed['aot']:.2f}, numba {speed['numba']:.2f} (medians of {args.speed_repeats}, alternating; "
              f"load {os.getloadavg()[0]:.2f})")
    if args.speed_only:
        return
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "PYTHONDONTWRITEBYTECODE": "1"}
    for cached in (False, True):
        set_bytecode(cached)
        with tempfile.TemporaryDirectory() as tmp:
            runs, loads, same = alternate(processes(Path(tmp), args.seed), env, args.repeats)
        report(runs, loads, same, cached, args)


def report(runs: dict, loads: list, same: bool, cached: bool, args) -> None:
    for k, r in runs.items():
        walls, cpus = [w for w, _ in r], [c for _, c in r]
        row = {"what": k, "bytecode": "cached" if cached else "none", "seed": args.seed, "target_cpu": "host",
               "wall_median_s": round(statistics.median(walls), 3), "wall_min_s": round(min(walls), 3),
               "cpu_median_s": round(statistics.median(cpus), 3), "cpu_min_s": round(min(cpus), 3), "repeats": len(r),
               "load_median": round(statistics.median(loads), 2), "bit_identical": same, "build_cpu_s": ""}
        print(f"{k:19s} {row['bytecode']:6s} wall {row['wall_median_s']:.3f} s (min {row['wall_min_s']:.3f})  cpu {row['cpu_median_s']:.3f} s "
              f"(min {row['cpu_min_s']:.3f})  load {row['load_median']:.2f}")
        if args.out:
            append_row(Path(args.out), list(row), row)


if __name__ == "__main__":
    main()
