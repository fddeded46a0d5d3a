"""The side-by-side speed table (docs/notes/speed-2.md): jamflow's default ``jamflow jam`` as a whole process
and in process, against the hand-written LAMMPS protocol (``handwritten_jam`` below: the speed baseline, formerly
``speed_vs_handwritten.py``), the same seeds and starts, with iterations per phase (compress /
approach / final) and the packing checks.

Baseline: the chapter's protocol written directly on the LAMMPS Python module -- harmonic/cut,
``min_style fire`` with ``min_modify norm max``, ``minimize 0 1e-14 CAP`` after each
``change_box ... remap``, dphi0 = 1e-4 from the chapter protocol's start, halve on crossing, stop at
1e-16 < V < 2e-16.

    python benchmarks/speed_table.py --dim 2 --n 64 256 1024 --seeds 1 2 3 4 5 --handwritten 64 256 1024 --out docs/notes/speed-table.csv
    python benchmarks/speed_table.py --dim 3 --sizes mono --n 512 --seeds 1 2 3 --handwritten 512 --out docs/notes/speed-table.csv
    python benchmarks/speed_table.py --chart docs/notes/speed-table.csv --png docs/notes/speed-2.png
    python benchmarks/speed_table.py --summary docs/notes/speed-table.csv    # the markdown rows of docs/notes/speed-2.md
    timeout 6000 python benchmarks/speed_table.py --n 16384 --seeds 1 --process-max 0 --out docs/notes/speed-table-goals.csv \
        --trace docs/notes/speed-trace-n16384.csv    # a row per minimisation as it ends: the path of a run that is stopped

Whole process: ``python -m jamflow.cli jam ...`` wall and CPU (user + sys) seconds, imports
and numba's cache load included. In process: ``jam()`` with a warm interpreter. Rows are
appended with the load average; run under ``flock /tmp/jamflow-bench.lock``.
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from jamflow.engines.lammps.data_file import write_lammps_data
from jamflow.engines.lammps.library import new_lammps
from jamflow.engines.lammps.pair_styles import harmonic_cut_commands
from jamflow.mechanics.checks import check_packing
from jamflow.protocols.settings import PROTOCOLS, DEFAULT_PROTOCOL
from jamflow.protocols.compression import initial_packing, jam

from common import append_row, check_outputs, run_process, scratch  # (benchmarks/ is the script's directory)


def whole_process(n, dim, sizes, seed, tmp) -> tuple[float, float]:
    return run_process([sys.executable, "-m", "jamflow.cli", "jam", "--n", str(n), "--dim", str(dim), "--sizes",
                        sizes, "--seed", str(seed), "--quiet", "--force", "--out", f"{tmp}/p.h5"])[:2]


def phase_iterations(history: dict, v_tol: float) -> dict:
    """Iterations in the compress / approach / final phases of one run."""
    phi, its, v = history["phi"], history["iterations"], history["energy_per_particle"]
    jammed = np.flatnonzero((v > v_tol) & (history["reason"] != b"energy-below-vmin"))
    first = int(jammed[0]) if len(jammed) else len(phi)
    final = int(np.flatnonzero(phi != phi[-1])[-1]) + 1 if np.any(phi != phi[-1]) else 0
    first = min(first, final)
    return {"compress": int(its[:first].sum()), "approach": int(its[first:final].sum()), "final": int(its[final:].sum())}



def handwritten_jam(packing, data_path, cap=100_000, v_tol=1e-16, dphi0=1e-4):
    """The plain protocol (2D or 3D); returns (phi_J, V, minimisations, seconds)."""
    t0 = time.perf_counter()
    write_lammps_data(data_path, packing)
    lmp = new_lammps()
    dim = packing.dim
    lmp.commands_list(["units lj", f"dimension {dim}", "atom_style sphere", f"read_data {data_path}",
                       "set atom * mass 1.0", *harmonic_cut_commands(packing), "neighbor 0.3 bin",
                       "neigh_modify every 1 delay 0 check yes", "thermo_modify norm no",
                       "min_style fire", "min_modify norm max", "timestep 0.05",
                       *(["fix 2d all enforce2d"] if dim == 2 else [])])
    phi, dphi, side, n = packing.phi, dphi0, None, packing.n
    for step in range(100_000):
        lmp.command(f"minimize 0.0 1e-14 {cap} {10 * cap}")
        v = lmp.get_thermo("pe") / n
        if v_tol < v < 2 * v_tol:
            lmp.close()
            return phi, v, step + 1, time.perf_counter() - t0
        new_side = "below" if v < v_tol else "above"
        if side and new_side != side:
            dphi /= 2
        side = new_side
        new_phi = phi + dphi if side == "below" else phi - dphi
        s = (phi / new_phi) ** (1.0 / dim)
        lmp.command("change_box all " + " ".join(f"{a} scale {s:.17g}" for a in "xyz"[:dim]) + " remap")
        phi = new_phi
    raise RuntimeError("hand-written protocol did not converge")



def tracer(path: Path, n: int, seed: int, c0: float):
    """An observer of ``jam`` appending one row per minimisation to ``path`` as it ends (so a run
    stopped from outside, e.g. by ``timeout``, leaves its path so far)."""
    def observe(step):
        r = step["result"]
        append_row(path, list(TRACE_COLUMNS), {
            "n": n, "seed": seed, "step": step["step"], "phi": f"{step['phi']:.12f}", "dphi": f"{step['dphi']:.4g}",
            "energy_per_particle": f"{r.energy_per_particle:.5g}", "reason": r.reason, "iterations": r.iterations,
            "max_force": f"{r.max_force:.3g}", "creep_steps": r.creep_steps,
            "cpu_s": round(time.process_time() - c0, 1)})
    return observe


TRACE_COLUMNS = ("n", "seed", "step", "phi", "dphi", "energy_per_particle", "reason", "iterations", "max_force",
                 "creep_steps", "cpu_s")


def jamflow_row(n, dim, sizes, seed, tmp, process: bool, trace: Path | None = None) -> dict:
    wall, cpu = whole_process(n, dim, sizes, seed, tmp) if process else (None, None)
    settings = PROTOCOLS[DEFAULT_PROTOCOL]()
    t0, c0 = time.perf_counter(), time.process_time()
    observers = [tracer(trace, n, seed, c0)] if trace else []
    r = jam(n=n, dim=dim, sizes=sizes, seed=seed, settings=settings, observers=observers)
    inproc, inproc_cpu = time.perf_counter() - t0, time.process_time() - c0
    ftol = settings.minimizer.resolved_force_tol(r.packing.box, r.packing.potential.contact_stiffness)
    checks = check_packing(r.packing, r.energy_per_particle, None, settings.v_tol, ftol)
    return {"method": "jamflow", "n": n, "dim": dim, "sizes": sizes, "seed": seed, "phi_j": f"{r.phi_j:.10f}",
            "process_wall_s": "" if wall is None else round(wall, 3),
            "process_cpu_s": "" if cpu is None else round(cpu, 3), "inprocess_wall_s": round(inproc, 3),
            "inprocess_cpu_s": round(inproc_cpu, 3), "iterations": r.iterations,
            **phase_iterations(r.history, settings.v_tol), "minimizations": r.minimizations,
            "checks": checks.passed, "load": round(os.getloadavg()[0], 2)}


def handwritten_row(n, dim, sizes, seed, tmp, cap=100_000) -> dict:
    start = initial_packing(n, dim, sizes, "spring", seed, PROTOCOLS["chapter"]().start_phi(dim))
    c0 = time.process_time()
    phi, v, m, seconds = handwritten_jam(start, Path(tmp) / "start.data", cap=cap)
    return {"method": "handwritten", "n": n, "dim": dim, "sizes": sizes, "seed": seed, "phi_j": f"{phi:.10f}",
            "process_wall_s": "", "process_cpu_s": "", "inprocess_wall_s": round(seconds, 3),
            "inprocess_cpu_s": round(time.process_time() - c0, 3), "iterations": "", "compress": "", "approach": "",
            "final": "", "minimizations": m, "checks": "", "load": round(os.getloadavg()[0], 2)}


PHASES = ("compress", "approach", "final")


def summary(csv_path: str) -> None:
    """Markdown rows: per (dim, N) medians (min-max) of jamflow whole process / in process CPU
    and wall seconds, iterations per phase, the hand-written loop, and the ratio of medians."""
    import statistics

    rows = list(csv.DictReader(open(csv_path)))

    def cell(values, digits=2):
        values = [float(v) for v in values if v != ""]
        if not values:
            return "", None
        med = statistics.median(values)
        return f"{med:.{digits}f} ({min(values):.{digits}f}-{max(values):.{digits}f}, {len(values)})", med

    for dim, n in sorted({(int(r["dim"]), int(r["n"])) for r in rows}):
        mine = [r for r in rows if int(r["dim"]) == dim and int(r["n"]) == n]
        jf = [r for r in mine if r["method"] == "jamflow"]
        hw = [r for r in mine if r["method"] == "handwritten"]
        proc, proc_med = cell(r["process_cpu_s"] for r in jf)
        proc_wall, _ = cell(r["process_wall_s"] for r in jf)
        inproc, jf_med = cell(r["inprocess_cpu_s"] for r in jf)
        hand, hw_med = cell(r["inprocess_cpu_s"] for r in hw)
        phases = " / ".join(f"{statistics.median(int(r[p]) for r in jf):,.0f}" for p in PHASES)
        times = lambda x: f"{x:.1f}x" if x < 10 else f"{x:.0f}x"
        ratio = (times(hw_med / jf_med) if hw_med and jf_med else "") + (
            f" ({times(hw_med / proc_med)})" if hw_med and proc_med else "")
        checks = f"{sum(r['checks'] == 'True' for r in jf)}/{len(jf)}"
        load = f"{min(float(r['load']) for r in mine):.1f}-{max(float(r['load']) for r in mine):.1f}"
        print(f"| {dim}D | {n} | {proc} | {proc_wall} | {inproc} | {phases} | {hand} | {ratio} | {checks} | {load} |")


def chart(csv_paths: list[str], png: str) -> None:
    """Median CPU seconds per packing against N (jamflow in process and whole process, the
    hand-written loop) and jamflow's median iterations per phase, one column per dimension;
    the rows of every CSV together."""
    import statistics

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [row for path in csv_paths for row in csv.DictReader(open(path))]
    dims = sorted({int(r["dim"]) for r in rows})
    fig, axes = plt.subplots(2, len(dims), figsize=(5.5 * len(dims), 8), squeeze=False)
    for col, dim in enumerate(dims):
        mine = [r for r in rows if int(r["dim"]) == dim]
        ax = axes[0, col]
        for method, key, label, marker in (("jamflow", "inprocess_cpu_s", "jamflow jam() in process", "o"),
                                           ("jamflow", "process_cpu_s", "jamflow jam, whole process", "s"),
                                           ("handwritten", "inprocess_cpu_s", "hand-written LAMMPS loop", "^")):
            sizes = sorted({int(r["n"]) for r in mine if r["method"] == method and r[key]})
            med = [statistics.median(float(r[key]) for r in mine if r["method"] == method and int(r["n"]) == n
                                     and r[key]) for n in sizes]
            if sizes:
                ax.loglog(sizes, med, marker=marker, label=label)
        ax.set(xlabel="N", ylabel="median CPU seconds per packing", title=f"{dim}D ({mine[0]['sizes']})")
        ax.legend(fontsize=8)
        ax = axes[1, col]
        sizes = sorted({int(r["n"]) for r in mine if r["method"] == "jamflow"})
        med = np.array([[statistics.median(int(r[phase]) for r in mine if r["method"] == "jamflow"
                                           and int(r["n"]) == n) for n in sizes] for phase in PHASES], float)
        share, bottom = med / med.sum(axis=0), np.zeros(len(sizes))
        for phase, part in zip(PHASES, share):
            ax.bar([str(n) for n in sizes], part, bottom=bottom, label=phase)
            bottom += part
        for k, total in enumerate(med.sum(axis=0)):
            ax.text(k, 1.01, f"{total:,.0f}", ha="center", fontsize=8)
        ax.set(xlabel="N", ylabel="share of the median FIRE iterations", ylim=(0, 1.1))
        ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=3)
    fig.tight_layout()
    fig.savefig(png, dpi=110)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dim", type=int, default=2)
    ap.add_argument("--sizes", default="bi:1.4:0.5")
    ap.add_argument("--n", type=int, nargs="+", default=[64, 256, 1024])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    ap.add_argument("--handwritten", type=int, nargs="*", default=[], help="sizes that also run the LAMMPS baseline")
    ap.add_argument("--handwritten-seeds", type=int, nargs="*", default=None, help="seeds of the baseline (default all)")
    ap.add_argument("--cap", type=int, default=100_000, help="baseline FIRE iteration cap per minimisation")
    ap.add_argument("--process-max", type=int, default=1024, help="whole-process runs only up to this N")
    ap.add_argument("--out", default=str(scratch("speed-table.csv")))
    ap.add_argument("--trace", type=Path, default=None, metavar="CSV", help="also append a row per minimisation of the in-process "
                    "jams (phi, V, stop reason, iterations, CPU s so far) to this CSV")
    ap.add_argument("--chart", default=None, nargs="+", metavar="CSV", help="only draw the chart of these CSVs' rows")
    ap.add_argument("--png", default=str(scratch("speed-2.png")))
    ap.add_argument("--summary", default=None, metavar="CSV", help="only print the markdown rows of this CSV")
    args = ap.parse_args(argv)
    if args.summary:
        return summary(args.summary)
    if args.chart:
        return chart(args.chart, args.png)
    out = Path(args.out)
    check_outputs(out, args.trace)
    jam(n=16, seed=0)  # numba's cache load outside the in-process timings
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.n:
            for seed in args.seeds:
                rows = [jamflow_row(n, args.dim, args.sizes, seed, tmp, n <= args.process_max, args.trace)]
                if n in args.handwritten and (args.handwritten_seeds is None or seed in args.handwritten_seeds):
                    rows.append(handwritten_row(n, args.dim, args.sizes, seed, tmp, args.cap))
                for row in rows:
                    print(" ".join(f"{k}={v}" for k, v in row.items()), flush=True)
                for row in rows:
                    append_row(out, list(rows[0]), row)


if __name__ == "__main__":
    main()
