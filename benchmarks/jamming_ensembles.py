"""The acceptance ensembles of jamming: 10 seeds of 2D 50:50 bidisperse disks (ratio 1.4, N=256)
and 10 seeds of 3D monodisperse spheres (N=512), each checked independently of LAMMPS.

    python benchmarks/jamming_ensembles.py --protocol fast --out docs/notes/jamming-ensembles.csv

Per packing: phi_J, V (window 1e-16 < V < 2e-16), max |force| over non-floaters from the
numpy all-pairs reference, isostaticity (jamflow.mechanics.contacts), time, minimisations.
Seed 0 of each system is jammed twice to check reproducibility. Rows are appended and
skipped when present (resumable). Published large-N onsets: 2D bidisperse ~0.842, 3D
monodisperse ~0.639-0.64 (O'Hern, Silbert, Liu & Nagel, PRE 68, 011306, 2003).
"""

from __future__ import annotations

import argparse
import csv
import statistics
from pathlib import Path

import numpy as np

from jamflow import jam
from jamflow.mechanics.contacts import Contacts
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.protocols.settings import PROTOCOL_NAMES, protocol_settings
from common import scratch  # (benchmarks/ is the script's directory)

SYSTEMS = {"2d-bi-256": dict(n=256, dim=2, sizes="bi:1.4:0.5"), "3d-mono-512": dict(n=512, dim=3, sizes="mono")}
COLUMNS = ["system", "protocol", "seed", "repeat", "phi_j", "v", "max_force_nonfloater", "floaters",
           "isostatic", "seconds", "minimizations", "iterations"]


def check(system, protocol, seed, repeat):
    res = jam(**SYSTEMS[system], seed=seed, settings=protocol_settings(protocol))
    contacts = Contacts().compute(res.packing)
    forces = energy_forces_pressure(res.packing).forces[~contacts.floater]
    return [system, protocol, seed, repeat, repr(res.phi_j), res.energy_per_particle, float(np.abs(forces).max()),
            contacts.n_floaters, contacts.is_isostatic, f"{res.seconds:.2f}", res.minimizations, res.iterations]


def summarize(rows):
    for system in SYSTEMS:
        for protocol in sorted({r["protocol"] for r in rows}):
            sel = [r for r in rows if r["system"] == system and r["protocol"] == protocol and r["repeat"] == "0"]
            if len(sel) < 2:
                continue
            phi = [float(r["phi_j"]) for r in sel]
            in_window = sum(1e-16 < float(r["v"]) < 2e-16 for r in sel)
            balanced = sum(float(r["max_force_nonfloater"]) < 1e-13 for r in sel)
            again = [r for r in rows if r["system"] == system and r["protocol"] == protocol and r["repeat"] == "1"]
            repro = [abs(float(a["phi_j"]) - float(b["phi_j"])) for a in again for b in sel if a["seed"] == b["seed"]]
            print(f"{system} {protocol}: {len(sel)} packings, phi_J = {statistics.mean(phi):.5f} +- "
                  f"{statistics.stdev(phi):.5f} (sd), {in_window}/{len(sel)} in the window, {balanced}/{len(sel)} with "
                  f"max|F| < 1e-13 on non-floaters, {sum(r['isostatic'] == 'True' for r in sel)} isostatic, "
                  f"median {statistics.median(float(r['seconds']) for r in sel):.1f} s; same-seed |dphi_J| = "
                  f"{max(repro) if repro else 'n/a'}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--protocol", choices=PROTOCOL_NAMES, default="fast")
    ap.add_argument("--systems", nargs="+", choices=sorted(SYSTEMS), default=list(SYSTEMS))
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--out", default=str(scratch("jamming-ensembles.csv")))
    args = ap.parse_args(argv)
    out = Path(args.out)
    done = {(r["system"], r["protocol"], r["seed"], r["repeat"]) for r in csv.DictReader(out.open())} if out.exists() else set()
    with out.open("a", newline="") as fh:
        w = csv.writer(fh)
        if not done:
            w.writerow(COLUMNS)
        for system in args.systems:
            for seed, repeat in [(s, 0) for s in range(args.seeds)] + [(0, 1)]:
                if (system, args.protocol, str(seed), str(repeat)) not in done:
                    w.writerow(check(system, args.protocol, seed, repeat))
                    fh.flush()
    summarize(list(csv.DictReader(out.open())))


if __name__ == "__main__":
    main()
