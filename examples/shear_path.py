"""Quasistatic shear at zero pressure (chapter section 2.2): jam N bidisperse disks, then
follow the packing by strain steps x_i -> x_i + dgamma y_i, each brought back to the jamming
onset at its strain; plot phi_J, the shear stress Sigma = -P_xy and Sigma / P against gamma with
the steps where the contact network changed marked (continuous geometric families in between).

    python examples/shear_path.py --n 10 --dgamma 0.002 --to 0.1 --out shear_path.png
"""

import argparse

import jamflow
from jamflow.plots.shear import shear_path_figure
from jamflow.protocols.shear import shear
from jamflow.io.shear_file import path_columns

parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
parser.add_argument("--n", type=int, default=10, help="number of disks")
parser.add_argument("--seed", type=int, default=1)
parser.add_argument("--dgamma", type=float, default=0.002, help="strain step")
parser.add_argument("--to", type=float, default=0.1, help="final strain")
parser.add_argument("--out", default="shear_path.png", help="figure (PNG)")
args = parser.parse_args()

start = jamflow.jam(n=args.n, dim=2, sizes="bi:1.4:0.5", seed=args.seed)
print(start.summary())
path = shear(start.packing, args.dgamma, args.to)
print(path.summary())
for k, step in enumerate(path.steps):
    if step.changed:
        print(f"  step {k}, gamma = {step.gamma:.4f}: contacts removed {step.removed}, added {step.added}")
print("figure ->", shear_path_figure(args.out, path_columns(path), title=f"N = {args.n}, seed {args.seed}: {path.n_changes} network changes"))
