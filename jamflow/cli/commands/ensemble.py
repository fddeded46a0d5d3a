"""Jam one packing per seed (and per N) on a Dask cluster into a resumable store DIR: one HDF5
packing per task plus DIR/summary.csv (layout: see the docs, reference/schemas).
Every `jamflow jam` option applies to all packings. A rerun of the same command skips what is
done and finishes what is not; a store made with other parameters is refused."""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from jamflow.cli.options import add_force_argument, add_quiet_argument, add_spec_arguments

PER_TASK = ("n", "seed", "above")  # jam options the ensemble sets per task (n, seed) or lacks (--above)


def add_arguments(p) -> None:
    p.add_argument("--seeds", default=None, metavar="A:B", help="seeds A to B-1, e.g. 0:200 (required to run)")
    p.add_argument("--n", type=int, nargs="+", default=[64], metavar="N", help="number(s) of particles: a grid")
    p.add_argument("--out", required=True, metavar="DIR", help="store directory (created if missing)")
    p.add_argument("--workers", type=int, default=None,
                   help="processes of the local Dask cluster (default: all cores)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="use an existing Dask scheduler (tcp://HOST:PORT or a scheduler JSON file), e.g. from "
                        "dask-jobqueue or dask-mpi, instead of a local cluster")
    p.add_argument("--wait-workers", type=float, default=60.0, metavar="SECONDS",
                   help="with --scheduler: stop if no worker has joined after this long (batch queues: raise it)")
    p.add_argument("--mpi-ranks", type=int, default=1, metavar="K",
                   help="run each packing with LAMMPS on K MPI ranks (mpirun; needs --engine lammps and mpi4py); "
                        "size --workers so that workers x K fits the cores")
    p.add_argument("--retry-failed", action="store_true", help="try recorded failed packings again")
    p.add_argument("--rebuild-summary", action="store_true",
                   help="only rebuild DIR/summary.csv from the files in DIR, then exit")
    add_quiet_argument(p)
    add_force_argument(p, "accepted as in `jamflow jam`; the store's files are written anew atomically either way")
    jam_options = p.add_argument_group("jam options (as in `jamflow jam`, for every packing)")
    add_spec_arguments(jam_options, skip=PER_TASK)  # every jam option, present and future, flows into the ensemble


def run(args) -> int:
    from jamflow.ensemble import Store, run_ensemble

    if args.rebuild_summary:
        if not (Store(args.out).dir / "ensemble.json").exists():
            raise ValueError(f"{args.out} is not an ensemble store (no ensemble.json)")
        print(f"summary -> {Store(args.out).rebuild_summary()}")
        return 0
    if args.seeds is None:
        raise ValueError("--seeds A:B is required, e.g. --seeds 0:200 for seeds 0 to 199")
    own = {"seeds", "n", "out", "workers", "scheduler", "wait_workers", "mpi_ranks", "retry_failed", "rebuild_summary",
           "run", "command", "quiet", "force"}
    options = {k: v for k, v in vars(args).items() if k not in own}
    report = run_ensemble(args.out, args.seeds, args.n, workers=args.workers, scheduler=args.scheduler,
                          progress=not args.quiet, retry_failed=args.retry_failed, wait_workers=args.wait_workers,
                          mpi_ranks=args.mpi_ranks, **options)
    print(summary_text(report))
    if report.interrupted:
        print(f"jamflow ensemble: interrupted; {report.done_before + report.made} packings are in {report.directory}, "
              "no partial file; rerun the same command to finish")
        return 130
    if report.stopped:
        print(f"jamflow ensemble: {report.stopped}")
        return 1
    return 0 if not report.errors else 1


def summary_text(report) -> str:
    lines = [f"{report.directory}: {report.done_before + report.made} of {report.requested} packings "
             f"({report.made} made now, {report.done_before} before), {report.failed} failed, "
             f"{len(report.errors)} errors, {report.workers_lost} workers lost, {len(report.corrupt)} corrupt files redone"]
    by_n = defaultdict(list)
    for row in report.rows.values():
        if row["status"] == "ok":
            by_n[int(row["n"])].append(float(row["phi_j"]))
    for n, phi in sorted(by_n.items()):
        known = [p for p in phi if np.isfinite(p)]
        sd = np.std(known, ddof=1) if len(known) > 1 else float("nan")
        text = f"phi_J = {np.mean(known):.5f} (sd {sd:.5f})" if known else "phi_J n/a"
        if len(known) < len(phi):  # one target pressure: no extrapolation to P -> 0
            text += f"; {len(phi) - len(known)} without a phi_J (one pressure; their phi is in column phi)"
        lines.append(f"  N = {n}: {len(phi)} packings, {text}")
    lines += [f"  error: {e}" for e in report.errors[:5]]
    lines.append(f"  summary -> {report.directory / 'summary.csv'}")
    return "\n".join(lines)
