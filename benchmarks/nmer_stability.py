"""Stability of the jammed n-mer ensembles (issue 14): the dynamical matrix with rotational
coordinates (``jamflow.analysis.hessian``, site-pair contacts, floaters removed), its zero modes
against the d trivial translations and the free rotations of bodies touched on one site
(``Contacts.free_rotations``), and Delta V along the lowest nonzero mode (``Stability``).

    OPENBLAS_NUM_THREADS=1 python benchmarks/nmer_stability.py --csv docs/nmers/ensembles.csv \
        --out docs/nmers/stability.csv

One row per packing of the CSV (the ``file`` column): N', N_c (site contacts), the isostatic
count, the free rotations, zero modes (|e| <= 1e-6), extra zero modes (beyond d), how many of
them are flat and carried by one body, quartic ones, the lowest nonzero eigenvalue and the
power of Delta V along it, the class. Appended and resumable like nmer_ensembles.py.
"""

from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

from tqdm import tqdm

from jamflow.analysis.contacts import Contacts
from jamflow.analysis.modes import Spectrum, Stability
from jamflow.io import atomic_path, load_packing

COLUMNS = ["shape", "dim", "n", "seed", "n_kept", "contacts", "isostatic_count", "free_rotations", "n_zero",
           "extra_zero", "flat_one_body", "quartic", "lowest_nonzero", "power_lowest", "label", "cpu_seconds", "file"]


def stability_row(row: dict) -> dict:
    start = time.process_time()
    packing = load_packing(row["file"])
    contacts = Contacts(count="sites").compute(packing)
    spectrum = Spectrum(method="dense").compute(packing)
    result = Stability().compute(packing, spectrum)
    nonzero = [p for p in result.profiles if abs(p.eigenvalue) > spectrum.e_min]
    lowest = nonzero[0] if nonzero else None
    return {"shape": row["shape"], "dim": row["dim"], "n": row["n"], "seed": row["seed"], "n_kept": contacts.n_kept,
            "contacts": contacts.n_contacts, "isostatic_count": contacts.isostatic_count,
            "free_rotations": contacts.free_rotations, "n_zero": spectrum.n_zero, "extra_zero": spectrum.n_extra_zero,
            "flat_one_body": result.n_single_flat, "quartic": result.n_quartic,
            "lowest_nonzero": "" if lowest is None else f"{lowest.eigenvalue:.4e}",
            "power_lowest": "" if lowest is None else f"{lowest.power:.3f}", "label": result.label,
            "cpu_seconds": f"{time.process_time() - start:.1f}", "file": row["file"]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--csv", default="docs/nmers/ensembles.csv")
    ap.add_argument("--shapes", nargs="*", default=None, help="only these shape specs (default: every rigid body)")
    ap.add_argument("--dim", type=int, default=None)
    ap.add_argument("--out", default="docs/nmers/stability.csv")
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
        tqdm.write(f"{row['shape']} {row['dim']}D seed {row['seed']}: zero {result['n_zero']} (extra "
                   f"{result['extra_zero']}, free rotations {result['free_rotations']}), lowest "
                   f"{result['lowest_nonzero']} power {result['power_lowest']} {result['label']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
