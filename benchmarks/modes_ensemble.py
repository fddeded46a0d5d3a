"""Ensemble for the stability measurements of docs/notes/modes.md (not a test).

Jams ``--count`` 2D 50:50 bidisperse (ratio 1.4) packings of N disks with
``jamflow.jam(seed=s)`` (chapter section 2.1), caches them in ``--out`` as
onset_n{N}_s{s}.h5, and writes copies compressed affinely to phi_J + ``--dphi`` and
re-minimised with LAMMPS (FIRE, the chapter's stopping rules) as above_n{N}_s{s}.h5; it prints the
time of each step. Then analyse them with

    jamflow modes DIR/onset_n256_s*.h5 --figure docs/notes/modes-onset.png
    jamflow modes DIR/above_n256_s*.h5 --figure docs/notes/modes-above.png

Usage: python benchmarks/modes_ensemble.py [--n 256] [--count 20] [--dphi 1e-4] [--out DIR]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from jamflow.engines.lammps.engine import LammpsEngine
from jamflow.io.packing_file import load_packing, save_packing
from jamflow.protocols.compression import jam
from jamflow.minimize.rules import minimize


def onset(path: Path, n: int, seed: int) -> None:
    if path.exists():
        return
    t0 = time.perf_counter()
    res = jam(n=n, dim=2, sizes="bi:1.4:0.5", seed=seed)
    save_packing(path, res.packing, energy_per_particle=res.energy_per_particle,
                 pressure_tensor=res.pressure_tensor, protocol=res.settings.as_dict(), history=res.history,
                 lammps_version=res.lammps_version)
    print(f"{path.name}: {res.summary()} ({time.perf_counter() - t0:.1f} s)", flush=True)


def above(source: Path, path: Path, dphi: float) -> None:
    if path.exists():
        return
    t0 = time.perf_counter()
    start = load_packing(source)
    with LammpsEngine(start.scaled_to_phi(start.phi + dphi)) as eng:
        result = minimize(eng)
        state = eng.state()
        packing = eng.packing()
    save_packing(path, packing, energy_per_particle=result.energy_per_particle,
                 pressure_tensor=state.pressure_tensor, protocol={"source": str(source), "dphi": dphi,
                                                                  "stop_reason": result.reason})
    print(f"{path.name}: phi = {packing.phi:.10f}  V = {result.energy_per_particle:.3e}  "
          f"max|F| = {result.max_force:.1e}  stop: {result.reason}  ({time.perf_counter() - t0:.1f} s)", flush=True)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=256)
    ap.add_argument("--count", type=int, default=20)
    ap.add_argument("--dphi", type=float, default=1e-4)
    ap.add_argument("--out", default="/tmp/jamflow-modes-data")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for seed in range(args.count):
        onset(out / f"onset_n{args.n}_s{seed}.h5", args.n, seed)
        above(out / f"onset_n{args.n}_s{seed}.h5", out / f"above_n{args.n}_s{seed}.h5", args.dphi)


if __name__ == "__main__":
    main()
