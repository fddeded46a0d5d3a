"""Damped MD with the seed's pairwise damping (eq. 2.3) against viscous drag and FIRE.

Jams the same random starts (2D bidisperse 50:50, diameters 1 and 1.4, default `fast`
protocol, LAMMPS engine for all three so iterations are comparable) with

    fire      MinimizerSettings(method="fire")
    viscous   MinimizerSettings(method="md", md_damping="viscous")    (fix viscous)
    pairwise  MinimizerSettings(method="md", md_damping="pairwise")   (fix jamflow/damping)

and checks every packing as tests/test_compression.py does: V_tol < V < 2 V_tol, the numpy
reference energy equal to the engine's (1e-6), max reference force component < 1e-13,
P > 0. One CSV row per packing (appended; rows present are skipped, so a sweep resumes),
then a markdown table (mean phi_J, iterations per method) and a PNG.

    flock /tmp/jamflow-bench.lock python benchmarks/damped_md.py --n 64 --seeds 10
    flock /tmp/jamflow-bench.lock python benchmarks/damped_md.py --n 256 --seeds 3
    python benchmarks/damped_md.py --report        # table + docs/damped-md.png from the CSV
"""

from __future__ import annotations

import argparse
import csv
import os
import statistics
import time
from collections import Counter
from pathlib import Path

import numpy as np
from tqdm import tqdm

from jamflow import jam
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.minimize.settings import MinimizerSettings
from jamflow.protocols.settings import fast_protocol

METHODS = {
    "fire": MinimizerSettings(method="fire"),
    "viscous": MinimizerSettings(method="md", md_damping="viscous"),
    "pairwise": MinimizerSettings(method="md", md_damping="pairwise"),
}
COLUMNS = ["n", "seed", "method", "phi_j", "v", "pressure", "ref_max_force", "checks", "minimizations", "iterations",
           "seconds", "cpu_seconds", "final_reason", "reasons", "load"]
OUT = Path(__file__).resolve().parents[1] / "docs" / "damped-md.csv"


def checks(res) -> str:
    """'ok' or what failed, by the criteria of tests/test_compression.py::assert_jammed."""
    ref = energy_forces_pressure(res.packing)
    failed = []
    if not 1e-16 < res.energy_per_particle < 2e-16:
        failed.append("window")
    if abs(ref.energy / res.packing.n - res.energy_per_particle) > 1e-6 * res.energy_per_particle:
        failed.append("energy")
    if np.max(np.abs(ref.forces)) >= 1e-13:
        failed.append("force")
    if not res.pressure > 0:
        failed.append("pressure")
    return "+".join(failed) or "ok"


def run(n: int, seed: int, method: str) -> list:
    cpu, wall = time.process_time(), time.perf_counter()
    res = jam(n=n, dim=2, sizes="bi:1.4:0.5", seed=seed, settings=fast_protocol(minimizer=METHODS[method]),
              engine="lammps")
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    reasons = Counter(r.decode() for r in res.history["reason"])
    ref_f = float(np.max(np.abs(energy_forces_pressure(res.packing).forces)))
    return [n, seed, method, repr(res.phi_j), res.energy_per_particle, res.pressure, ref_f, checks(res),
            res.minimizations, res.iterations, f"{wall:.2f}", f"{cpu:.2f}", res.history["reason"][-1].decode(),
            " ".join(f"{k}:{v}" for k, v in sorted(reasons.items())), f"{os.getloadavg()[0]:.2f}"]


def mean_se(values) -> str:
    values = list(values)
    se = statistics.stdev(values) / len(values) ** 0.5 if len(values) > 1 else float("nan")
    return f"{statistics.mean(values):+.5f} +- {se:.5f}"


def table(rows) -> str:
    """Markdown: per N and method, mean phi_J +- s.e., its paired difference to FIRE (same
    starts), mean iterations, checks passed."""
    lines = ["| N | method | packings | checks ok | mean phi_J +- s.e. | minus FIRE's (paired) | mean iterations "
             "| median CPU s |", "|---|---|---|---|---|---|---|---|"]
    groups = {}
    for r in rows:
        groups.setdefault((int(r["n"]), r["method"]), []).append(r)
    fire = {(int(r["n"]), r["seed"]): float(r["phi_j"]) for r in rows if r["method"] == "fire"}
    for (n, method), rs in sorted(groups.items(), key=lambda kv: (kv[0][0], list(METHODS).index(kv[0][1]))):
        phi = [float(r["phi_j"]) for r in rs]
        paired = [float(r["phi_j"]) - fire[n, r["seed"]] for r in rs if (n, r["seed"]) in fire]
        ok = sum(r["checks"] == "ok" for r in rs)
        lines.append(f"| {n} | {method} | {len(rs)} | {ok} | {mean_se(phi).lstrip('+')} | "
                     f"{mean_se(paired) if method != 'fire' else ''} | "
                     f"{statistics.mean(int(r['iterations']) for r in rs):,.0f} | "
                     f"{statistics.median(float(r['cpu_seconds']) for r in rs):.1f} |")
    return "\n".join(lines)


def per_seed(rows) -> str:
    """Markdown: phi_J and iterations of the three methods side by side, one line per start;
    a failed check is named after phi_J."""
    by = {}
    for r in rows:
        by.setdefault((int(r["n"]), int(r["seed"])), {})[r["method"]] = r
    head = "| N | seed | " + " | ".join(f"phi_J {m}" for m in METHODS) + " | " + \
        " | ".join(f"iterations {m}" for m in METHODS) + " |"
    lines = [head, "|" + "---|" * (2 + 2 * len(METHODS))]
    for (n, seed), d in sorted(by.items()):
        phis = [f"{float(d[m]['phi_j']):.6f}" + ("" if d[m]["checks"] == "ok" else f" ({d[m]['checks']})")
                if m in d else "" for m in METHODS]
        its = [f"{int(d[m]['iterations']):,}" if m in d else "" for m in METHODS]
        lines.append(f"| {n} | {seed} | " + " | ".join(phis) + " | " + " | ".join(its) + " |")
    return "\n".join(lines)


def chart(rows, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sizes = sorted({int(r["n"]) for r in rows})
    fig, axes = plt.subplots(2, len(sizes), figsize=(5.2 * len(sizes), 7), squeeze=False)
    marks = {"fire": "o", "viscous": "s", "pairwise": "^"}
    for col, n in enumerate(sizes):
        for k, method in enumerate(METHODS):
            rs = sorted((r for r in rows if int(r["n"]) == n and r["method"] == method), key=lambda r: int(r["seed"]))
            for ok in (True, False):  # open markers: the packing failed a check
                sel = [r for r in rs if (r["checks"] == "ok") == ok]
                if not sel:
                    continue
                seeds = [int(r["seed"]) + (k - 1) * 0.15 for r in sel]
                style = dict(color=f"C{k}", mfc=None if ok else "none",
                             label=method if ok else f"{method}, failed a check")
                axes[0, col].plot(seeds, [float(r["phi_j"]) for r in sel], marks[method], **style)
                axes[1, col].plot(seeds, [int(r["iterations"]) for r in sel], marks[method], **style)
        axes[1, col].set_xticks(sorted({int(r["seed"]) for r in rows if int(r["n"]) == n}))
        axes[0, col].set_xticks(axes[1, col].get_xticks())
        axes[0, col].set_title(f"N = {n}, 2D bidisperse, fast protocol")
        axes[0, col].set_ylabel(r"$\phi_J$")
        axes[1, col].set_ylabel("minimiser iterations per packing")
        axes[1, col].set_yscale("log")
        axes[1, col].set_xlabel("seed (random start)")
        axes[0, col].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--methods", nargs="+", default=list(METHODS), choices=list(METHODS))
    ap.add_argument("--out", type=Path, default=OUT)
    ap.add_argument("--report", action="store_true", help="only print the tables and draw the chart")
    args = ap.parse_args()
    if not args.report:
        done = {(r["n"], r["seed"], r["method"]) for r in csv.DictReader(args.out.open())} if args.out.exists() else set()
        todo = [(s, m) for s in range(args.seeds) for m in args.methods if (str(args.n), str(s), m) not in done]
        with args.out.open("a", newline="") as fh:
            w = csv.writer(fh)
            if not done:
                w.writerow(COLUMNS)
            for seed, method in tqdm(todo, desc=f"N = {args.n}", unit="packing"):
                w.writerow(run(args.n, seed, method))
                fh.flush()
    rows = list(csv.DictReader(args.out.open()))
    print(table(rows), "", per_seed(rows), sep="\n")
    chart(rows, args.out.with_suffix(".png"))


if __name__ == "__main__":
    main()
