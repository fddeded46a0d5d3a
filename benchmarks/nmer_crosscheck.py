"""LAMMPS vs compiled engine vs numpy reference for rigid n-mers on random overlapping
configurations (docs/notes/nmers.md): the worst relative differences of energy, body forces, torques and
the molecular pressure tensor, per body, dimension and box.

    python benchmarks/nmer_crosscheck.py --out docs/notes/nmers/crosscheck.csv

Each configuration: 40 (2D) or 100 (3D) bodies, 50:50 sizes 1 and 1.4, random positions and
orientations at phi 0.95 (2D) / 0.75 (3D), linear spring (LAMMPS harmonic/cut) and Hertz (LAMMPS
plugin pair style); orthogonal box and tilt 0.37. tests/test_lammps_bodies.py asserts 1e-12.
"""

from __future__ import annotations

import argparse

import numpy as np

from jamflow.model.box import Box
from jamflow.engines.compiled.engine import CompiledEngine
from jamflow.engines.lammps.engine import LammpsEngine
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.model.packing import random_packing
from jamflow.model.potentials import Spring
from jamflow.model.shapes import parse_shape
from jamflow.model.sizes import parse_sizes
from common import scratch, merge_rows  # (benchmarks/ is the script's directory)

SPECS = ["nmer:2:1.5", "nmer:2:2", "nmer:3:1.5", "dimer:1.5:0.7", "trimer:2:0.3"]


def configuration(spec, dim, tilt, potential, seed=3):
    p = random_packing(40 if dim == 2 else 100, dim, parse_sizes("bi:1.4:0.5"), 0.95 if dim == 2 else 0.75, seed,
                       potential, parse_shape(spec, dim))
    if tilt:
        h = p.box.h.copy()
        h[0, 1] = tilt * h[1, 1]
        p = p.with_positions(Box(h).to_cartesian(p.box.to_fractional(p.positions)), box=Box(h))
    return p


def rel(a, b) -> float:
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / np.max(np.abs(b)))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=str(scratch("nmers/crosscheck.csv")))
    args = ap.parse_args(argv)
    rows = []
    for spec in SPECS:
        for dim in (2, 3):
            for tilt in (0.0, 0.37):
                for pot in (Spring(), Spring(2.5)):
                    p = configuration(spec, dim, tilt, pot)
                    ref = energy_forces_pressure(p)
                    with LammpsEngine(p) as lmp, CompiledEngine(p) as num:
                        states = {"lammps": lmp.evaluate(), "numba": num.evaluate()}
                    for engine, s in states.items():
                        rows.append(dict(shape=spec, dim=dim, tilt=tilt, potential=pot.spec, engine=engine,
                                         energy=f"{abs(s.energy / ref.energy - 1):.2e}",
                                         forces=f"{rel(s.forces, ref.forces):.2e}",
                                         torques=f"{rel(s.torques, ref.torques):.2e}",
                                         pressure=f"{rel(s.pressure_tensor, ref.pressure_tensor):.2e}"))
    merge_rows(args.out, rows)  # added to the rows of earlier runs
    for engine in ("lammps", "numba"):
        worst = {k: max(float(r[k]) for r in rows if r["engine"] == engine) for k in ("energy", "forces", "torques", "pressure")}
        print(engine, "worst relative difference to the reference over", sum(r["engine"] == engine for r in rows),
              "configurations:", "  ".join(f"{k} {v:.1e}" for k, v in worst.items()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
