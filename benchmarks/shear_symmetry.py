"""Unit period and mirror symmetry of jamming at fixed strain, over many starts (docs/notes/shear.md).

For each seed, one random start of N bidisperse disks is jammed at gamma, at gamma + 1 (the
same start) and, mirrored x -> -x, at 1 - gamma; the three packings are compared: largest
displacement of a non-floater after removing the mean (a global translation is free), phi_J,
V and the contact network among non-floaters (a floater may touch a neighbour at round-off). Two strain pairs: 0.25 / 1.25 / 0.75 (exactly one apart and exact
mirrors as doubles) and 0.2 / 1.2 / 0.8 (1.2 - 1 = 0.19999999999999996 is 5.6e-17 away from
0.2), with the default (fast) and the chapter protocol, compiled engine.

    python benchmarks/shear_symmetry.py --seeds 20 --out docs/notes/shear-symmetry.csv
"""

from __future__ import annotations

import argparse

import numpy as np

from jamflow.mechanics.contacts import Contacts
from jamflow.protocols.shear import Network
from jamflow.protocols.compression import at_shear_strain, compress, initial_packing
from jamflow.protocols.settings import chapter_protocol, fast_protocol
from common import scratch, merge_rows  # (benchmarks/ is the script's directory)

PROTOCOLS = {"fast": fast_protocol, "chapter": chapter_protocol}


def jammed(n, seed, gamma, protocol, mirror=False):
    start = initial_packing(n, 2, "bi:1.4:0.5", "spring", seed, 0.8)
    if mirror:
        start = start.with_positions(start.positions * [-1.0, 1.0])
    return compress(at_shear_strain(start, gamma), PROTOCOLS[protocol]())


def compare(a, b, mirror=False) -> dict:
    pb = b.packing
    if mirror:
        pb = pb.with_positions(pb.positions * [-1.0, 1.0], box=a.packing.box)
    keep = ~Contacts().compute(a.packing).floater
    d = a.packing.box.minimum_image(pb.positions - a.packing.positions)[keep]
    return dict(max_dx=float(np.abs(d - d.mean(axis=0)).max()), dphi=abs(b.phi_j - a.phi_j),
                dv_rel=abs(b.energy_per_particle - a.energy_per_particle) / a.energy_per_particle,
                same_contacts=Network.of(a.packing).pairs() == Network.of(pb).pairs(),
                same_history=bool(np.array_equal(a.history["phi"], b.history["phi"])))


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=10)
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--out", default=str(scratch("shear-symmetry.csv")))
    args = parser.parse_args(argv)
    rows = []
    for protocol in PROTOCOLS:
        for gamma in (0.25, 0.2):
            for seed in range(args.seeds):
                a = jammed(args.n, seed, gamma, protocol)
                plus = compare(a, jammed(args.n, seed, gamma + 1.0, protocol))
                mirror = compare(a, jammed(args.n, seed, 1.0 - gamma, protocol, mirror=True), mirror=True)
                for kind, r in (("gamma+1", plus), ("1-gamma mirrored", mirror)):
                    rows.append(dict(protocol=protocol, gamma=gamma, seed=seed, check=kind, **r))
    merge_rows(args.out, rows)  # added to the rows of earlier runs
    print("protocol  gamma  check             same contacts  same history  max dx (median, worst)  "
          "|dphi_J| worst  |dV|/V median")
    for protocol in PROTOCOLS:
        for gamma in (0.25, 0.2):
            for kind in ("gamma+1", "1-gamma mirrored"):
                sel = [r for r in rows if r["protocol"] == protocol and r["gamma"] == gamma and r["check"] == kind]
                dx = np.array([r["max_dx"] for r in sel])
                print(f"{protocol:<8}  {gamma:<5}  {kind:<16}  {sum(r['same_contacts'] for r in sel):>3}/{len(sel):<9}  "
                      f"{sum(r['same_history'] for r in sel):>3}/{len(sel):<9}  {np.median(dx):.1e}, {dx.max():.1e}"
                      f"{'':<10}{max(r['dphi'] for r in sel):.1e}        "
                      f"{np.median([r['dv_rel'] for r in sel]):.1e}")
    print(f"-> {args.out}")


if __name__ == "__main__":
    main()
