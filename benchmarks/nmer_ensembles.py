"""Ensembles of jammed rigid n-mers (docs/notes/nmers.md), each packing checked independently of the engine
that made it.

    python benchmarks/nmer_ensembles.py --shape nmer:2:1.5 --dim 2 --n 128 --seeds 0-19 \
        --packings /tmp/nmers/packings --out docs/notes/nmers/ensembles.csv
    python benchmarks/nmer_ensembles.py ... --engine lammps --minimizer md --damping 0.1   # the LAMMPS route

One row per packing (appended; a row already in the CSV or in ``--rejects`` is skipped, so runs
resume): phi_J, V,
P, the largest force and generalized torque tau_a / d_k on non-floaters from the all-pairs site
sum of the numpy reference (``jamflow.mechanics.reference``, independent of both engines), the
contacts between bodies and between sites (``jamflow.mechanics.contacts``), floaters by the convex
rule d_f + 1, bodies touched on one site only (their free rotations), the isostatic count
N' d_f - d + 1, the engine, CPU seconds and wall seconds (the machine load is in the log), and
the packing file (``--packings``; HDF5, schema jamflow.packing v2) for the figures
(``benchmarks/nmer_figures.py``). With ``--rejects R.csv`` the rows of packings that fail the
checks (``failed_checks``: not stopped by force, unbalanced, outside the energy window, or every body
a floater) go to R.csv instead, so --out holds checked packings only and every failure stays on record.
"""

from __future__ import annotations

import argparse
import csv
import logging
import os
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from jamflow.mechanics.contacts import Contacts
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.support.files import atomic_path, check_writable
from jamflow.io.packing_file import save_packing
from jamflow.minimize.settings import CREEP_METHODS, MinimizerSettings
from jamflow.protocols.settings import PROTOCOL_NAMES, protocol_settings
from jamflow.protocols.compression import compress, initial_packing
from jamflow.mechanics.checks import generalized_torques

from common import NMER_F_LIMIT as F_LIMIT  # (benchmarks/ is the script's directory)

COLUMNS = ["shape", "dim", "n", "sizes", "engine", "minimizer", "damping", "seed", "phi_j", "v", "pressure",
           "max_force", "max_torque", "floaters", "contacts", "body_contacts", "one_site", "free_rotations",
           "isostatic_count", "z", "cpu_seconds", "seconds", "minimizations", "iterations", "reason", "file"]


def failed_checks(row: dict, v_tol: float) -> list[str]:
    """Why a packing's row (``checked_row``, or read back from a CSV) fails the checks; empty if it
    passes: the last minimisation stopped by the force rule (not the iteration cap), max |F| and
    tau_a/d_k on non-floaters below F_LIMIT, V/N in the window (v_tol, 2 v_tol), and at least one
    body not a floater (else the force check is empty)."""
    why = []
    if row["reason"] != "force":
        why.append(f"stopped by {row['reason']}")
    if not (float(row["max_force"]) < F_LIMIT and float(row["max_torque"]) < F_LIMIT):
        why.append(f"max |F| {float(row['max_force']):.1e}, tau/d_k {float(row['max_torque']):.1e} >= {F_LIMIT:g}")
    if not v_tol < float(row["v"]) < 2 * v_tol:
        why.append(f"V/N {float(row['v']):.2e} outside the window")
    if int(row["floaters"]) >= int(row["n"]):
        why.append("every body a floater")
    return why


def seeds(text: str) -> list[int]:
    """'0-19' or '0,3,5' -> seed list."""
    out = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        out += list(range(int(lo), int(hi or lo) + 1))
    return out


def checked_row(packing, result, settings_row: dict, seed: int, cpu: float, path: Path) -> dict:
    """The independent checks of one jammed packing (see module docstring)."""
    contacts = Contacts(count="sites").compute(packing)  # one constraint per site pair
    ref = energy_forces_pressure(packing)
    keep = ~contacts.floater
    g = np.zeros((packing.n, 0)) if ref.torques is None else generalized_torques(packing, ref.torques)
    return {**settings_row, "seed": seed, "phi_j": repr(result.phi_j), "v": result.energy_per_particle,
            "pressure": result.pressure, "max_force": float(np.abs(ref.forces[keep]).max(initial=0.0)),
            "max_torque": float(np.abs(g[keep]).max(initial=0.0)), "floaters": contacts.n_floaters,
            "contacts": contacts.n_contacts, "body_contacts": contacts.n_body_contacts or contacts.n_contacts,
            "one_site": 0 if contacts.one_site is None else int(contacts.one_site.sum()),
            "free_rotations": contacts.free_rotations,
            "isostatic_count": contacts.isostatic_count, "z": contacts.mean_z, "cpu_seconds": f"{cpu:.2f}",
            "seconds": f"{result.seconds:.2f}", "minimizations": result.minimizations,
            "iterations": result.iterations, "reason": result.history["reason"][-1].decode(), "file": str(path)}


def done_keys(out: Path) -> set:
    if not out.exists():
        return set()
    with open(out) as fh:
        return {(r["shape"], r["dim"], r["n"], r["sizes"], r["engine"], r["damping"], r["seed"]) for r in csv.DictReader(fh)}


def append(out: Path, row: dict) -> None:
    """Append one row, rewriting the file atomically (an interrupted run keeps the last good CSV)."""
    old = out.read_text() if out.exists() else ",".join(COLUMNS) + "\n"
    line = ",".join(str(row[c]) for c in COLUMNS) + "\n"
    with atomic_path(out) as tmp:
        tmp.write_text(old + line)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--shape", required=True)
    ap.add_argument("--dim", type=int, choices=(2, 3), default=2)
    ap.add_argument("--n", type=int, default=128)
    ap.add_argument("--sizes", default="bi:1.4:0.5")
    ap.add_argument("--seeds", default="0-19")
    ap.add_argument("--engine", default="numba", choices=("numba", "lammps"))
    ap.add_argument("--minimizer", default="fire")
    ap.add_argument("--damping", type=float, default=MinimizerSettings().damping, help="damped dynamics only")
    ap.add_argument("--protocol", default="fast", choices=PROTOCOL_NAMES)
    ap.add_argument("--packings", required=True, help="directory for the packing files")
    ap.add_argument("--out", required=True, help="CSV, appended")
    ap.add_argument("--rejects", help="CSV for the rows of packings that fail the checks (default: --out)")
    ap.add_argument("--creep", default="auto", choices=CREEP_METHODS,
                    help="MinimizerSettings.creep (docs/notes/soft-modes.md); rows before 2026-12-02 were made without")
    ap.add_argument("--max-iterations", type=int, default=MinimizerSettings().max_iterations,
                    help="per minimisation (a creeping one that reaches it fails its packing)")
    ap.add_argument("--verbose", action="store_true", help="log every soft-mode step and polish")
    args = ap.parse_args(argv)
    if args.verbose:
        logging.basicConfig(level=logging.INFO, format="  %(message)s")
    out, where = Path(args.out), Path(args.packings)
    rejects = Path(args.rejects) if args.rejects else out
    where.mkdir(parents=True, exist_ok=True)
    check_writable(out)
    check_writable(rejects)
    settings = protocol_settings(args.protocol, minimizer=MinimizerSettings(method=args.minimizer, damping=args.damping,
                                                                      creep=args.creep,
                                                                      max_iterations=args.max_iterations))
    base = {"shape": args.shape, "dim": args.dim, "n": args.n, "sizes": args.sizes, "engine": args.engine,
            "minimizer": args.minimizer, "damping": args.damping if args.minimizer == "md" else ""}
    have = done_keys(out) | done_keys(rejects)
    todo = [s for s in seeds(args.seeds) if tuple(str(v) for v in (*[base[k] for k in
            ("shape", "dim", "n", "sizes", "engine", "damping")], s)) not in have]
    print(f"{len(todo)} packings to make; load {os.getloadavg()[0]:.1f}", flush=True)
    for seed in tqdm(todo, unit="packing"):
        start = initial_packing(args.n, args.dim, args.sizes, "spring", seed, settings.start_phi(args.dim, shape=args.shape), args.shape)
        cpu = time.process_time()
        result = compress(start, settings, engine=args.engine)
        cpu = time.process_time() - cpu
        name = f"{args.shape.replace(':', '_')}-{args.dim}d-n{args.n}-{args.engine}-s{seed}.h5"
        path = save_packing(where / name, result.packing, energy_per_particle=result.energy_per_particle,
                            pressure_tensor=result.pressure_tensor, history=result.history,
                            protocol={**settings.as_dict(), "engine": result.engine},
                            lammps_version=result.lammps_version)
        row = checked_row(result.packing, result, base, seed, cpu, path)
        why = failed_checks(row, settings.v_tol)
        append(rejects if why else out, row)
        tqdm.write(f"seed {seed}: phi_J {float(row['phi_j']):.5f} z {row['z']:.3f} max|F| {row['max_force']:.1e} "
                   f"max|g| {row['max_torque']:.1e} cpu {cpu:.1f} s load {os.getloadavg()[0]:.1f}"
                   + (f" FAILED: {'; '.join(why)}" + (f" (row in {rejects})" if args.rejects else "") if why else ""))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
