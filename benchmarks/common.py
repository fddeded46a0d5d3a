"""Helpers shared by the benchmark scripts: the only module they import from each other.

Scripts run both as ``python benchmarks/NAME.py ...`` (benchmarks/ is then the script's
directory, so ``from common import ...`` works) and as ``python -m benchmarks run NAME``
(benchmarks/__main__.py puts benchmarks/ on sys.path first).

Sections: paths; CPU, processes and time limits; CSV rows; figures; command lines; shared
rows of the jamming studies (quiet jam, ellipse ensembles, anneal rows, n-mer force limit).
"""

from __future__ import annotations

import argparse
import csv
import multiprocessing as mp
import os
import queue
import resource
import signal
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

# --- paths ----------------------------------------------------------------------------------------
ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs" / "notes"  # curated results: written only when a run names them (--out docs/notes/...)
SCRATCH = Path(os.environ.get("JAMFLOW_BENCHMARK_OUT") or Path(tempfile.gettempdir()) / "jamflow-benchmarks")


def scratch(name: str = "") -> Path:
    """The default output SCRATCH/``name`` of a benchmark (its directory created): a run never
    writes into docs/notes/ unless told to. SCRATCH is $JAMFLOW_BENCHMARK_OUT, else
    TMPDIR/jamflow-benchmarks."""
    path = SCRATCH / name
    (path if not name else path.parent).mkdir(parents=True, exist_ok=True)
    return path


# --- CPU, processes and time limits -----------------------------------------------------------------
def cpu_seconds() -> float:
    """User + system CPU of this process and its waited-for children (lmp, mpirun ranks)."""
    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def run_process(argv, env=None) -> tuple[float, float, str]:
    """(wall s, user + sys CPU s, stdout) of one whole process ``argv`` (waited for; a failing
    process raises). The side-by-side process timings (startup, aot_startup, speed_table)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    out = subprocess.run(list(argv), env=env, check=True, capture_output=True, text=True).stdout
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), out.strip()


def python_process(args, env=None) -> tuple[float, float]:
    """(wall s, CPU s) of ``python ARGS`` with this interpreter."""
    return run_process([sys.executable, *args], env)[:2]


def _child(q, fn, args):
    os.setpgrp()  # own process group: a timeout also stops lmp/mpirun started by fn
    try:
        start = cpu_seconds()
        value = fn(*args)
        q.put(("ok", {**value, "cpu_seconds": f"{cpu_seconds() - start:.3f}"}))
    except Exception as err:  # recorded as the run's status
        q.put((f"failed: {type(err).__name__}: {str(err)[:150]}", None))


def limited(fn, args, limit: float):
    """(status, fn(*args)) with fn run in a forked process stopped after ``limit`` seconds."""
    ctx = mp.get_context("fork")
    q = ctx.Queue()
    proc = ctx.Process(target=_child, args=(q, fn, args))
    proc.start()
    try:
        status, value = q.get(timeout=limit)
    except queue.Empty:
        status, value = f"timeout>{limit:g}s", None
    try:
        os.killpg(proc.pid, signal.SIGTERM)
    except ProcessLookupError:
        pass
    proc.join()
    return status, value


# --- CSV rows -------------------------------------------------------------------------------------
def read_rows(path: Path) -> list[dict]:
    """The rows of a results CSV (empty if it does not exist yet)."""
    path = Path(path)
    if not path.is_file():
        return []
    with path.open() as f:
        return list(csv.DictReader(f))


def merge_rows(path, rows, columns=None, comment: str | None = None) -> Path:
    """Add ``rows`` (dicts) to the results CSV at ``path``, keeping the rows it has: a second run
    adds to the table instead of replacing it. The header is the union of the file's columns and
    ``columns`` (default: the rows' keys); leading ``#`` comment lines are kept and ``comment``
    is added if new. Written atomically."""
    from jamflow.support.files import atomic_path

    path = Path(path)
    comments, old = [], []
    if path.is_file():
        with path.open(newline="") as f:
            lines = f.read().splitlines(keepends=True)
        while lines and lines[0].startswith("#"):
            comments.append(lines.pop(0).rstrip("\r\n"))
        old = list(csv.DictReader(lines))
    if comment is not None and comment not in comments:
        comments.append(comment)
    keys = list(dict.fromkeys([*(k for r in old for k in r), *(columns or []), *(k for r in rows for k in r)]))
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as f:
        for line in comments:
            f.write(line + "\n")
        w = csv.DictWriter(f, keys, restval="")
        w.writeheader()
        w.writerows(old)
        w.writerows(rows)
    return path


def write_rows(path: Path, rows: list[dict], columns) -> None:
    """The whole results CSV again, atomically (an interrupted run keeps the last one)."""
    from jamflow.support.files import atomic_path

    with atomic_path(Path(path)) as tmp:
        with open(tmp, "w", newline="") as f:
            w = csv.DictWriter(f, columns)
            w.writeheader()
            w.writerows(rows)


def check_outputs(*paths) -> None:
    """Exit with a clear message before any work starts if one of the output ``paths`` (None
    skipped) cannot be written (``jamflow.support.files.check_writable``)."""
    from jamflow.support.files import check_writable

    for path in paths:
        if path is None:
            continue
        try:
            check_writable(path)
        except ValueError as err:
            raise SystemExit(f"error: {err}") from None


def append_row(path: Path, columns, row: dict) -> None:
    """Append one row (header first if the file is new) and flush it to disk."""
    path = Path(path)
    new = not path.exists()
    with path.open("a", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=columns)
        if new:
            w.writeheader()
        w.writerow(row)
        fh.flush()
        os.fsync(fh.fileno())


def sweep(path: Path, columns, points: list[dict], fn, limit: float, strict: bool = False) -> None:
    """fn(*point.values()) for every point (dict of the key columns) not yet in the CSV at
    ``path``; one row per run with its status, appended as it ends. ``strict``: raise at the
    end if any run failed or timed out (quick modes), else that is only its row's status."""
    bad = []
    done = {tuple(r[k] for k in points[0]) for r in read_rows(path)} if points else set()
    for point in points:
        if tuple(str(v) for v in point.values()) in done:
            continue
        status, value = limited(fn, tuple(point.values()), limit)
        row = {**point, "status": status, "load": f"{os.getloadavg()[0]:.2f}", **(value or {})}
        append_row(path, columns, row)
        print(row, flush=True)
        if status != "ok":
            bad.append(f"{point}: {status}")
    if strict and bad:
        raise RuntimeError("runs not ok: " + "; ".join(bad))


def stats(values):
    """(mean, standard error, count) of ``values``."""
    v = [float(x) for x in values]
    return statistics.mean(v), (statistics.stdev(v) / len(v) ** 0.5 if len(v) > 1 else float("nan")), len(v)


# --- figures --------------------------------------------------------------------------------------
def pyplot():
    """matplotlib.pyplot on the Agg backend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig, path: Path) -> None:
    """Lay out, write atomically as PNG (120 dpi) and close ``fig``."""
    from jamflow.support.files import atomic_path

    fig.tight_layout()
    with atomic_path(Path(path)) as tmp:
        fig.savefig(tmp, dpi=120, format="png")
    pyplot().close(fig)


# --- command lines --------------------------------------------------------------------------------
def command_line(doc, argv, run, chart, csv_path: Path, add_run_arguments, limit: float = 300.0):
    """``run`` (append rows; --out default: the scratch directory) / ``chart`` (CSV -> PNG; --out
    default ``csv_path``, the curated table) sub-commands of the sweep benchmarks."""
    ap = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="what", required=True)
    r = sub.add_parser("run")
    add_run_arguments(r)
    r.add_argument("--limit", type=float, default=limit, help="seconds per run before it is stopped")
    r.add_argument("--strict", action="store_true", help="fail if any run failed or timed out")
    c = sub.add_parser("chart")
    r.add_argument("--out", type=Path, default=scratch(csv_path.name),
                   help=f"CSV the rows are added to (default: the scratch directory; the curated table is {csv_path})")
    c.add_argument("--out", type=Path, default=csv_path)
    args = ap.parse_args(argv)
    return run(args) if args.what == "run" else chart(args)


def run_or_report(doc: str, add_arguments, run, report, out: str, argv=None) -> None:
    """The command line of a results study: options from ``add_arguments(parser)``, ``--out``
    (default: ``out``'s name in the scratch directory; ``out`` is the curated table, written only
    when named), ``--report CSV``: ``report(Path)`` instead of ``run(args)``."""
    ap = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(ap)
    ap.add_argument("--out", default=str(scratch(Path(out).name)),
                    help=f"CSV the rows are added to (default: the scratch directory; the curated table is {out})")
    ap.add_argument("--report", default=None, metavar="CSV")
    args = ap.parse_args(argv)
    if args.report:
        report(Path(args.report))
    else:
        run(args)


# --- shared rows of the jamming studies -------------------------------------------------------------
def jam_quietly(start, settings):
    """(result, None) from compression.jam with warnings silenced, or (None, the JammingFailed message)."""
    from jamflow.protocols import compression

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return compression.jam(start=start, settings=settings), None
    except compression.JammingFailed as err:
        return None, str(err)


NMER_F_LIMIT = 1e-12  # docs/notes/nmers.md: max force and generalized torque on non-floaters (the reference's), eps/diameter

ELLIPSE_SIZES = "bi:1.4:0.6667"  # 2:1 bidisperse, major-axis ratio 1.4
ELLIPSE_COLUMNS = ["engine", "alpha", "seed", "n", "phi_j", "energy_per_particle", "pressure", "max_force",
                   "max_torque", "minimizations", "iterations", "cpu_seconds", "wall_seconds", "load", "final_reason",
                   "warnings", "brute_energy_per_particle", "brute_max_force", "brute_max_torque",
                   "brute_max_force_kept", "brute_max_torque_kept", "engine_brute_force_diff", "n_floaters", "mean_z",
                   "n_contacts", "isostatic_count"]


def ellipse_settings(engine: str):
    """The default protocol; the LAMMPS route minimises by damped dynamics (the only LAMMPS
    minimiser that turns ellipses)."""
    from jamflow.minimize.settings import MinimizerSettings
    from jamflow.protocols.settings import fast_protocol

    return fast_protocol(minimizer=MinimizerSettings(method="md")) if engine == "lammps" else fast_protocol()


def ellipse_row(engine: str, alpha: float, seed: int, n: int, keep_dir: Path | None) -> dict:
    """One 2D bidisperse ellipse packing jammed on ``engine`` and checked by the independent
    brute-force energy, as a row of ELLIPSE_COLUMNS (kept in ``keep_dir`` if given)."""
    from jamflow import jam
    from jamflow.analysis.independent import independent_check
    from jamflow.io.packing_file import save_packing
    from jamflow.mechanics.contacts import Contacts
    from jamflow.mechanics.reference import energy_forces_pressure
    import numpy as np

    t_cpu, t_wall = time.process_time(), time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = jam(n=n, dim=2, sizes=ELLIPSE_SIZES, shape=f"ellipse:{alpha:g}", seed=seed,
                  settings=ellipse_settings(engine), engine=engine)
    cpu, wall = time.process_time() - t_cpu, time.perf_counter() - t_wall
    p = res.packing
    check = independent_check(p)
    contacts = Contacts().compute(p)
    kept = ~contacts.floater
    if keep_dir is not None:
        save_packing(keep_dir / f"{engine}-alpha{alpha:g}-seed{seed}.h5", p, energy_per_particle=res.energy_per_particle,
                     pressure_tensor=res.pressure_tensor, history=res.history, lammps_version=res.lammps_version)
    return dict(engine=res.engine, alpha=alpha, seed=seed, n=n, phi_j=repr(res.phi_j),
                energy_per_particle=res.energy_per_particle, pressure=res.pressure, max_force=res.max_force,
                max_torque=res.max_torque, minimizations=res.minimizations, iterations=res.iterations,
                cpu_seconds=f"{cpu:.2f}", wall_seconds=f"{wall:.2f}", load=f"{os.getloadavg()[0]:.1f}",
                final_reason=res.history["reason"][-1].decode(), warnings=" | ".join(str(w.message)[:80] for w in caught),
                brute_energy_per_particle=check.energy_per_particle, brute_max_force=check.max_force(),
                brute_max_torque=check.max_generalized_torque(), brute_max_force_kept=check.max_force(kept),
                brute_max_torque_kept=check.max_generalized_torque(kept),
                engine_brute_force_diff=float(np.abs(energy_forces_pressure(p).forces - check.forces).max()),
                n_floaters=contacts.n_floaters, mean_z=contacts.mean_z, n_contacts=contacts.n_contacts,
                isostatic_count=contacts.isostatic_count)


ANNEAL_COLUMNS = ["protocol", "dalpha", "seed", "n", "alpha", "phi_j", "mean_z", "n_floaters", "p2",
                  "energy_per_particle", "max_force", "checks_passed", "cpu_seconds", "load"]


def anneal_row(protocol, dalpha, seed, n, alpha, packing, checks, cpu) -> dict:
    """One packing of the shape-annealing studies (anneal_vs_compression, nematic_protocols)."""
    from jamflow.model.nematic import Nematic

    p2 = Nematic().compute(packing).p2 if packing.shape.oriented else float("nan")
    return dict(protocol=protocol, dalpha=dalpha, seed=seed, n=n, alpha=alpha, phi_j=packing.phi, mean_z=checks.mean_z,
                n_floaters=checks.n_floaters, p2=p2, energy_per_particle=checks.energy_per_particle,
                max_force=checks.max_force, checks_passed=checks.passed, cpu_seconds=round(cpu, 2),
                load=os.getloadavg()[0])
