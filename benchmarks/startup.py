"""Start-up cost of the ``jamflow`` command (docs/notes/speed-2.md): whole-process wall and CPU
seconds of ``jamflow --help``, ``jamflow jam --help`` and ``jamflow jam --n 64`` (each of
``--seeds``, every repeat), the floors any such process stands on (the bare interpreter,
``import numpy``, and the smallest numba process: one cached njit function called once), and
what a jam's first second is made of (imports, numba's first call, the jam itself).

    python benchmarks/startup.py --repeats 5 --out docs/notes/startup.csv
    python benchmarks/startup.py --repeats 5 --source /tmp/main-src --label main --out docs/notes/startup.csv
    python benchmarks/startup.py --repeats 3 --seeds 1 2 3 4 5 --floors --out docs/notes/startup.csv
    python benchmarks/startup.py --repeats 3 --seeds 1 2 3 4 5 --alternate /tmp/main-src --out docs/notes/startup.csv

``--alternate DIR`` runs, for each repeat and seed in turn, the numba floor, ``jamflow jam --n 64``
of DIR (label ``DIR``) and of the installed jamflow, so that both see the same load (on a
shared machine the load drifts between two separate runs).

``--source DIR`` runs the jamflow found in DIR (e.g. ``git archive main | tar -x -C DIR``)
instead of the installed one, for a before/after table on the same machine and venv.
Rows are appended to the CSV with the load average; take timings under
``flock /tmp/jamflow-bench.lock``.

Since session 6 a disk jam runs ahead-of-time kernels and never starts numba (docs/notes/speed-2.md
section 12): the in-process phases still import numba explicitly, so the "numba" phase is what
importing it would cost, not part of a jam; ``aot_startup.py`` times the jam itself.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from common import append_row, python_process, scratch  # (benchmarks/ is the script's directory)

CLI = ["-m", "jamflow.cli"]
COMMANDS = {"help": CLI + ["--help"], "jam-help": CLI + ["jam", "--help"],
            "jam-n64": CLI + ["jam", "--n", "64", "--seed", "{seed}", "--quiet", "--out", "{tmp}/p.h5", "--force"]}
NUMBA_FLOOR = """import numba, numpy
@numba.njit(cache=True)
def total(x):
    return x.sum()
total(numpy.ones(3))
"""
FLOORS = {"floor: python": ["-c", "pass"], "floor: import numpy": ["-c", "import numpy"],
          "floor: numba cached call": ["{tmp}/numba_floor.py"]}

# in-process phases of one N = 64 jam, each timed after the previous (fresh interpreter)
PHASES = """import time, sys
t = [time.perf_counter()]
def mark(): t.append(time.perf_counter())
import numpy; mark()
import jamflow.cli.commands.jam as jc; mark()
import numba; mark()
import jamflow.engines.compiled.engine; mark()
from jamflow.protocols.compression import jam
jam(n=16, seed=1); mark()
res = jam(n=64, seed=1); mark()
print(*[f"{b - a:.4f}" for a, b in zip(t, t[1:])], res.iterations)
"""
PHASE_NAMES = ["numpy", "jam command (parser)", "numba", "compiled engine + scipy.spatial",
               "first jam (numba cache load, N = 16)", "jam N = 64 warm"]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--source", default=None, help="directory holding the jamflow package to time")
    ap.add_argument("--label", default="branch")
    ap.add_argument("--out", default=str(scratch("startup.csv")))
    ap.add_argument("--seeds", type=int, nargs="+", default=[1], help="seeds of the jam-n64 command")
    ap.add_argument("--floors", action="store_true", help="also time the floors (python, numpy, numba)")
    ap.add_argument("--alternate", default=None, help="directory of another jamflow: jam-n64 of both, alternating")
    ap.add_argument("--other-label", default="main", help="label of the --alternate jamflow")
    args = ap.parse_args(argv)
    if args.alternate:
        return alternate(args)
    env = dict(os.environ)
    if args.source:
        env["PYTHONPATH"] = str(Path(args.source).resolve())
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        Path(tmp, "numba_floor.py").write_text(NUMBA_FLOOR)
        commands = {**(FLOORS if args.floors else {}), **COMMANDS}
        for name, argv in commands.items():
            seeds = args.seeds if any("{seed}" in a for a in argv) else [None]
            variants = [[a.replace("{tmp}", tmp).replace("{seed}", str(seed)) for a in argv] for seed in seeds]
            python_process(variants[0], env)  # warm the file cache and numba's disk cache
            runs = [python_process(v, env) for _ in range(args.repeats) for v in variants]
            name = name if seeds == [None] else f"{name} seeds {'-'.join(map(str, seeds))}"
            rows.append({"label": args.label, "what": name, "wall_median_s": statistics.median(w for w, _ in runs),
                         "wall_min_s": min(w for w, _ in runs), "cpu_median_s": statistics.median(c for _, c in runs),
                         "repeats": len(runs), "load": os.getloadavg()[0]})
            print(f"{args.label:8s} {name:24s} wall {rows[-1]['wall_median_s']:.3f} s (min {rows[-1]['wall_min_s']:.3f})"
                  f"  cpu {rows[-1]['cpu_median_s']:.3f} s  load {rows[-1]['load']:.2f}")
    phases = [subprocess.run([sys.executable, "-c", PHASES], env=env, check=True, capture_output=True,
                             text=True).stdout.split() for _ in range(args.repeats)]
    for i, name in enumerate(PHASE_NAMES):
        value = statistics.median(float(p[i]) for p in phases)
        rows.append({"label": args.label, "what": f"phase: {name}", "wall_median_s": value, "wall_min_s":
                     min(float(p[i]) for p in phases), "cpu_median_s": "", "repeats": args.repeats,
                     "load": os.getloadavg()[0]})
        print(f"{args.label:8s} phase {name:40s} {value:.3f} s")
    for row in rows:
        append_row(Path(args.out), list(rows[0]), row)


def alternate(args) -> None:
    """The numba floor, DIR's jam --n 64 and the installed one's, interleaved run by run."""
    envs = {"floor": dict(os.environ), args.alternate: {**os.environ, "PYTHONPATH": str(Path(args.alternate).resolve())},
            args.label: dict(os.environ)}
    with tempfile.TemporaryDirectory() as tmp:
        Path(tmp, "numba_floor.py").write_text(NUMBA_FLOOR)
        argv = {"floor": FLOORS["floor: numba cached call"], args.alternate: COMMANDS["jam-n64"],
                args.label: COMMANDS["jam-n64"]}
        runs = {k: [] for k in argv}
        for k in argv:  # warm-up: file cache, numba's disk cache of each source tree
            python_process([a.replace("{tmp}", tmp).replace("{seed}", "1") for a in argv[k]], envs[k])
        loads = []
        for _ in range(args.repeats):
            for seed in args.seeds:
                for k in argv:
                    runs[k].append(python_process([a.replace("{tmp}", tmp).replace("{seed}", str(seed)) for a in argv[k]],
                                            envs[k]))
                loads.append(os.getloadavg()[0])
    seeds = "-".join(map(str, args.seeds))
    for k, r in runs.items():
        what = "floor: numba cached call" if k == "floor" else f"jam-n64 seeds {seeds}"
        row = {"label": "alternate " + ("floor" if k == "floor" else (args.label if k == args.label else args.other_label)),
               "what": what, "wall_median_s": statistics.median(w for w, _ in r), "wall_min_s": min(w for w, _ in r),
               "cpu_median_s": statistics.median(c for _, c in r), "repeats": len(r), "load": statistics.median(loads)}
        print(f"{row['label']:18s} {what:26s} wall {row['wall_median_s']:.3f} s (min {row['wall_min_s']:.3f})  "
              f"cpu {row['cpu_median_s']:.3f} s (min {min(c for _, c in r):.3f})  load {row['load']:.2f}")
        append_row(Path(args.out), list(row), row)


if __name__ == "__main__":
    main()
