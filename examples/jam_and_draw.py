"""Jam N bidisperse disks (50:50, diameters 1 and 1.4) and draw the packing: particles to
scale, contacts with width proportional to force, floaters hatched, colour = contact number.

    python examples/jam_and_draw.py --n 256 --out jam_and_draw.png
"""

import argparse

import jamflow
from jamflow.mechanics.checks import check_packing
from jamflow.plots.drawing import draw_packing

parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
parser.add_argument("--n", type=int, default=256, help="number of disks")
parser.add_argument("--seed", type=int, default=1)
parser.add_argument("--out", default="jam_and_draw.png", help="figure (PNG)")
args = parser.parse_args()

result = jamflow.jam(n=args.n, dim=2, sizes="bi:1.4:0.5", seed=args.seed)
checks = check_packing(result.packing, result.energy_per_particle, None, v_tol=result.settings.v_tol)
print(result.summary())
print(f"checks passed: {checks.passed}  N_c = {checks.n_contacts} (isostatic {checks.isostatic_count}), "
      f"{checks.n_floaters} floaters, max net force / mean contact force = {checks.force_ratio:.1e}")
print("figure ->", draw_packing(result.packing, args.out))
