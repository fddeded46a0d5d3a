"""Side by side, in one run: jamflow's default jamming against a plain hand-written
LAMMPS protocol (issue 7's baseline), on the same seeds and the same initial positions.

Baseline: the seed's protocol written directly on the LAMMPS Python module --
harmonic/cut, ``min_style fire`` with ``min_modify norm max``, ``minimize 0 1e-14 CAP``
after each ``change_box ... remap``, dphi0 = 1e-4 from phi0 = 0.80, halve on crossing,
stop at 1e-16 < V < 2e-16.

    python benchmarks/speed_vs_handwritten.py --n 1024 --seeds 5 --out docs/speed-vs-handwritten.csv

Prints per-seed times, the medians and their ratio; appends rows to the CSV (resumable).
"""

from __future__ import annotations

import argparse
import csv
import statistics
import time
from pathlib import Path

from jamflow import jam
from jamflow.engines.lammps.library import new_lammps
from jamflow.engines.lammps.pair_styles import harmonic_cut_commands
from jamflow.io.packing_file import write_lammps_data
from jamflow.protocols.settings import PROTOCOLS
from jamflow.protocols.compression import initial_packing


def handwritten_jam(packing, data_path, cap=100_000, v_tol=1e-16, dphi0=1e-4):
    """The plain protocol (2D or 3D); returns (phi_J, V, minimisations, seconds)."""
    t0 = time.perf_counter()
    write_lammps_data(data_path, packing)
    lmp = new_lammps()
    dim = packing.dim
    lmp.commands_list(["units lj", f"dimension {dim}", "atom_style sphere", f"read_data {data_path}",
                       "set atom * mass 1.0", *harmonic_cut_commands(packing), "neighbor 0.3 bin",
                       "neigh_modify every 1 delay 0 check yes", "thermo_modify norm no",
                       "min_style fire", "min_modify norm max", "timestep 0.05",
                       *(["fix 2d all enforce2d"] if dim == 2 else [])])
    phi, dphi, side, n = packing.phi, dphi0, None, packing.n
    for step in range(100_000):
        lmp.command(f"minimize 0.0 1e-14 {cap} {10 * cap}")
        v = lmp.get_thermo("pe") / n
        if v_tol < v < 2 * v_tol:
            lmp.close()
            return phi, v, step + 1, time.perf_counter() - t0
        new_side = "below" if v < v_tol else "above"
        if side and new_side != side:
            dphi /= 2
        side = new_side
        new_phi = phi + dphi if side == "below" else phi - dphi
        s = (phi / new_phi) ** (1.0 / dim)
        lmp.command("change_box all " + " ".join(f"{a} scale {s:.17g}" for a in "xyz"[:dim]) + " remap")
        phi = new_phi
    raise RuntimeError("hand-written protocol did not converge")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=1024)
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--cap", type=int, default=100_000, help="baseline FIRE iteration cap per minimisation")
    ap.add_argument("--skip-baseline", action="store_true")
    ap.add_argument("--protocol", choices=sorted(PROTOCOLS), default="fast", help="jamflow protocol preset")
    ap.add_argument("--out", default="docs/speed-vs-handwritten.csv")
    args = ap.parse_args()
    out = Path(args.out)
    done = {(r["method"], int(r["n"]), int(r["seed"])) for r in csv.DictReader(out.open())} if out.exists() else set()
    with out.open("a", newline="") as fh:
        w = csv.writer(fh)
        if not done:
            w.writerow(["method", "n", "seed", "phi_j", "v", "minimizations", "seconds", "iterations", "engine"])
        jam(n=16, seed=0)  # load (or compile) the compiled engine's kernels before timing
        for seed in range(args.seeds):
            start = initial_packing(args.n, 2, "bi:1.4:0.5", "spring", seed, 0.80)
            if ("jamflow", args.n, seed) not in done:  # rows are per method name, not per preset
                r = jam(start=start, settings=PROTOCOLS[args.protocol]())
                w.writerow(["jamflow", args.n, seed, repr(r.phi_j), r.energy_per_particle, r.minimizations,
                            f"{r.seconds:.3f}", r.iterations, r.engine])
                fh.flush()
            if not args.skip_baseline and ("handwritten", args.n, seed) not in done:
                phi, v, m, sec = handwritten_jam(start, out.with_suffix(f".seed{seed}.data"), cap=args.cap)
                out.with_suffix(f".seed{seed}.data").unlink()
                w.writerow(["handwritten", args.n, seed, repr(phi), v, m, f"{sec:.3f}", "", "lammps"])
                fh.flush()
    rows = [r for r in csv.DictReader(out.open()) if int(r["n"]) == args.n]
    med = {m: statistics.median(float(r["seconds"]) for r in rows if r["method"] == m)
           for m in ("jamflow", "handwritten") if any(r["method"] == m for r in rows)}
    for m, t in med.items():
        print(f"N = {args.n}: {m} median {t:.2f} s over {sum(r['method'] == m for r in rows)} seeds")
    if len(med) == 2:
        print(f"ratio handwritten / jamflow = {med['handwritten'] / med['jamflow']:.1f}x")


if __name__ == "__main__":
    main()
