"""The compiled engine's threaded FIRE (``CompiledEngine(..., threads=T)``, jamflow.engines.compiled.threads)
against its serial kernels (the ahead-of-time ones a default jam runs), per FIRE iteration, side by side
in one process on the same state (docs/notes/threads.md).

    python benchmarks/threads.py --out docs/notes/threads.csv

The state: a random start just above a typical onset (2D 'bi:1.4:0.5' at phi = 0.845, 3D 'mono' at
phi = 0.645, seed 1), relaxed by ``--relax`` serial FIRE iterations (untimed). From that same state each kernel runs ``--iterations`` FIRE iterations (one
window, force tolerance 1e-300: no early stop; pair-list rebuilds included, as in a jam), the
kernels alternating ``--repeats`` times. Wall time (time.perf_counter: what threads are for) and
CPU time of the process (time.process_time: all threads) per iteration; ``load`` is the 1-minute
load average as the row starts (the machine's other jobs share its cores) and ``capacity`` how
many cores the process got just before it (``capacity``: independent work on 1 thread against
``--threads``; 2 on two free cores). The threaded path's
first use compiles its kernels (numba, ~15 s once per cache): a warm-up window of each kernel runs
before the timings. The engine sets OMP_WAIT_POLICY=PASSIVE where neither it nor GOMP_SPINCOUNT is
set (``compiled.threads.passive_waits``); run with OMP_WAIT_POLICY=ACTIVE or GOMP_SPINCOUNT=N to
time the others. Run under ``flock /tmp/jamflow-bench.lock``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path

from common import append_row, scratch  # (benchmarks/ is the script's directory)

import numba
import numpy as np

from jamflow.engines.compiled.engine import CompiledEngine
from jamflow.minimize.settings import MinimizerSettings
from jamflow.protocols.compression import initial_packing

COLUMNS = ["dim", "n", "kernels", "threads", "repeat", "iterations", "wall_ms_per_iteration",
           "cpu_ms_per_iteration", "energy", "load", "capacity", "numba_threads", "threading_layer", "omp_wait_policy", "gomp_spincount"]
START = {2: ("bi:1.4:0.5", 0.845), 3: ("mono", 0.645)}


@numba.njit(parallel=True)
def _independent_work(a, out):
    for c in numba.prange(16):
        s = 0.0
        for k in range(c * a.size // 16, (c + 1) * a.size // 16):
            s += np.sqrt(a[k])
        out[c] = s


def capacity(threads: int) -> float:
    """How many cores the machine gives this process now: the wall time of a loop of independent
    work (16 chunks of square roots, no shared writes) on 1 thread over that on ``threads`` (best of
    5 each); ``threads`` on free cores, ~1 when other jobs take them."""
    a, out = np.random.default_rng(0).random(1_000_000), np.zeros(16)
    before = numba.get_num_threads()
    best = {}
    try:
        for count in (1, min(threads, before)):
            numba.set_num_threads(count)
            _independent_work(a, out)
            times = []
            for _ in range(5):
                t0 = time.perf_counter()
                _independent_work(a, out)
                times.append(time.perf_counter() - t0)
            best[count] = min(times)
    finally:
        numba.set_num_threads(before)
    return best[1] / best[min(threads, before)]


def start_state(n: int, dim: int, relax: int, seed: int = 1):
    """The random start, relaxed by ``relax`` serial FIRE iterations (past the first, rebuild-heavy
    iterations of a raw random start: the state a jam's minimisations near onset start from)."""
    sizes, phi = START[dim]
    start = initial_packing(n, dim, sizes, "spring", seed, phi)
    with CompiledEngine(start) as engine:
        with engine.minimizer_session(MinimizerSettings(), 1e-300) as window:
            window(relax)
        return engine.packing()


def timed_window(engine: CompiledEngine, start, iterations: int):
    """(wall s, CPU s, iterations, energy) of one FIRE window of ``iterations`` from ``start``'s positions."""
    engine.set_positions(start.positions)
    with engine.minimizer_session(MinimizerSettings(), 1e-300) as window:
        t0, c0 = time.perf_counter(), time.process_time()
        done = window(iterations)
        return time.perf_counter() - t0, time.process_time() - c0, done.iterations, done.objective


def run_size(dim: int, n: int, threads: int, iterations: int, repeats: int, relax: int, out: Path) -> dict:
    start = start_state(n, dim, relax)
    engines = {"serial": CompiledEngine(start), "threaded": CompiledEngine(start, threads=threads)}
    for engine in engines.values():  # warm-up: compiles (threaded, first use) and loads the kernels
        timed_window(engine, start, 20)
    walls = {name: [] for name in engines}
    cpus = {name: [] for name in engines}
    for repeat in range(repeats):
        for name, engine in engines.items():  # alternating, the same start each time
            load, free = os.getloadavg()[0], capacity(threads)
            wall, cpu, done, energy = timed_window(engine, start, iterations)
            row = {"dim": dim, "n": n, "kernels": engine.kernels, "threads": engine.threads, "repeat": repeat,
                   "iterations": done, "wall_ms_per_iteration": round(wall / done * 1e3, 4),
                   "cpu_ms_per_iteration": round(cpu / done * 1e3, 4), "energy": f"{energy:.12g}",
                   "load": round(load, 2), "capacity": round(free, 2), "numba_threads": numba.get_num_threads(),
                   "threading_layer": _layer(), "omp_wait_policy": os.environ.get("OMP_WAIT_POLICY", ""),
                   "gomp_spincount": os.environ.get("GOMP_SPINCOUNT", "")}
            append_row(out, COLUMNS, row)
            walls[name].append(wall / done)
            cpus[name].append(cpu / done)
            print(" ".join(f"{k}={v}" for k, v in row.items()), flush=True)
    for engine in engines.values():
        engine.close()
    summary = {name: (statistics.median(walls[name]) * 1e3, statistics.median(cpus[name]) * 1e3) for name in walls}
    (ws, cs), (wt, ct) = summary["serial"], summary["threaded"]
    print(f"== {dim}D N={n}: serial {ws:.3f} ms/it wall {cs:.3f} CPU; threaded ({threads}) {wt:.3f} wall "
          f"{ct:.3f} CPU; wall serial/threaded {ws / wt:.2f}, CPU threaded/serial {ct / cs:.2f}", flush=True)
    return summary


def _layer() -> str:
    try:
        return numba.threading_layer()
    except ValueError:  # no parallel region has run yet
        return ""


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="*", default=[4096, 16384, 65536], help="2D N")
    ap.add_argument("--sizes-3d", type=int, nargs="*", default=[4096], help="3D N")
    ap.add_argument("--iterations", type=int, default=2000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--relax", type=int, default=2000, help="serial FIRE iterations from the random start, untimed")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", default=str(scratch("threads.csv")))
    args = ap.parse_args(argv)
    print(f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}, {os.cpu_count()} CPUs, numba "
          f"{numba.__version__} at most {numba.config.NUMBA_NUM_THREADS} threads", flush=True)
    for dim, sizes in ((2, args.sizes), (3, args.sizes_3d)):
        for n in sizes:
            run_size(dim, n, args.threads, args.iterations, args.repeats, args.relax, Path(args.out))
    print(f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}", flush=True)


if __name__ == "__main__":
    main()
