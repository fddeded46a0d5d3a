"""Checks and stability of the jammed n-mer ensembles (docs/notes/nmers.md): ``jamflow.mechanics.checks`` on every
packing file (window, force and torque balance, contact count), the dynamical matrix with
rotational coordinates (``jamflow.mechanics.hessian``, site-pair contacts, floaters removed), its
zero modes against the d trivial translations and the free rotations of bodies touched on one
site (``jamflow.analysis.free_rotations``: the known vectors must lie in the zero-mode space and
no zero mode may be left over), and Delta V along the lowest nonzero mode (``Stability``).

    OPENBLAS_NUM_THREADS=1 python benchmarks/nmer_stability.py --csv docs/notes/nmers/ensembles.csv \
        --out docs/notes/nmers/stability.csv

One row per packing of the CSV (the ``file`` column): whether it passed ``jamflow.mechanics.checks`` (and
the problems if not), N', N_c (site contacts), the isostatic count, the free rotations, zero
modes (|e| <= 1e-6), extra zero modes (beyond d), the free rotations found in the matrix's
packing, the distance of the known zero vectors from the zero-mode space, the zero modes left
unexplained, how many are flat and carried by one body, quartic ones, the lowest nonzero
eigenvalue and the power of Delta V along it, the class. Appended and resumable like
nmer_ensembles.py.
"""

from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

from tqdm import tqdm

from jamflow.mechanics.contacts import Contacts
from jamflow.analysis.free_rotations import zero_modes
from jamflow.analysis.modes import Spectrum, Stability
from jamflow.mechanics.checks import check_packing
from jamflow.support.files import atomic_path
from jamflow.io.packing_file import load_packing
from common import scratch  # (benchmarks/ is the script's directory)

COLUMNS = ["shape", "dim", "n", "seed", "checks_passed", "problems", "n_kept", "contacts", "isostatic_count",
           "free_rotations", "n_zero", "extra_zero", "free_in_matrix", "zero_residual", "unexplained_zero",
           "flat_one_body", "quartic", "lowest_nonzero", "power_lowest", "label", "cpu_seconds", "file"]
V_TOL = 1e-16  # the ensembles' window (nmer_ensembles.py runs the protocols' default)


def stability_row(row: dict) -> dict:
    start = time.process_time()
    packing = load_packing(row["file"])
    checks = check_packing(packing, v_tol=V_TOL)
    contacts = Contacts(count="sites").compute(packing)
    spectrum = Spectrum(method="dense").compute(packing)
    zero = zero_modes(spectrum)
    result = Stability().compute(packing, spectrum)
    nonzero = [p for p in result.profiles if abs(p.eigenvalue) > spectrum.e_min]
    lowest = nonzero[0] if nonzero else None
    return {"shape": row["shape"], "dim": row["dim"], "n": row["n"], "seed": row["seed"],
            "checks_passed": checks.passed, "problems": "; ".join(checks.problems()).replace(",", " "),
            "n_kept": contacts.n_kept,
            "contacts": contacts.n_contacts, "isostatic_count": contacts.isostatic_count,
            "free_rotations": contacts.free_rotations, "n_zero": spectrum.n_zero, "extra_zero": spectrum.n_extra_zero,
            "free_in_matrix": zero.n_free, "zero_residual": f"{zero.residual:.2e}", "unexplained_zero": zero.unexplained,
            "flat_one_body": result.n_single_flat, "quartic": result.n_quartic,
            "lowest_nonzero": "" if lowest is None else f"{lowest.eigenvalue:.4e}",
            "power_lowest": "" if lowest is None else f"{lowest.power:.3f}", "label": result.label,
            "cpu_seconds": f"{time.process_time() - start:.1f}", "file": row["file"]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--csv", default="docs/notes/nmers/ensembles.csv")
    ap.add_argument("--shapes", nargs="*", default=None, help="only these shape specs (default: every rigid body)")
    ap.add_argument("--dim", type=int, default=None)
    ap.add_argument("--out", default=str(scratch("nmers/stability.csv")))
    args = ap.parse_args(argv)
    out = Path(args.out)
    with open(args.csv) as fh:
        rows = [r for r in csv.DictReader(fh) if float(r["shape"].split(":")[-1]) != 1.0
                and (args.shapes is None or r["shape"] in args.shapes) and (args.dim is None or int(r["dim"]) == args.dim)]
    done = set()
    if out.exists():
        with open(out) as fh:
            done = {r["file"] for r in csv.DictReader(fh)}
    todo = [r for r in rows if r["file"] not in done]
    for row in tqdm(todo, unit="packing"):
        result = stability_row(row)
        old = out.read_text() if out.exists() else ",".join(COLUMNS) + "\n"
        with atomic_path(out) as tmp:
            tmp.write_text(old + ",".join(str(result[c]) for c in COLUMNS) + "\n")
        tqdm.write(f"{row['shape']} {row['dim']}D seed {row['seed']}: checks {result['checks_passed']}, zero "
                   f"{result['n_zero']} (extra {result['extra_zero']}, free rotations {result['free_rotations']}, "
                   f"unexplained {result['unexplained_zero']}), lowest "
                   f"{result['lowest_nonzero']} power {result['power_lowest']} {result['label']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
