"""An ensemble of jammed packings and the distribution P(phi_J): a plain loop over seeds
with jamflow.jam, one packing per seed (2D bidisperse disks). The width of P(phi_J)
shrinks with N (O'Hern et al., PRE 68, 011306, 2003; the chapter's section 2.1).

    python examples/ensemble_phi_j.py --n 64 --seeds 20 --out ensemble_phi_j.png
"""

import argparse

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

import jamflow

parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
parser.add_argument("--n", type=int, default=64, help="disks per packing")
parser.add_argument("--seeds", type=int, default=20, help="number of packings (seeds 0 .. SEEDS-1)")
parser.add_argument("--out", default="ensemble_phi_j.png", help="figure (PNG)")
args = parser.parse_args()

phi_j = np.array([jamflow.jam(n=args.n, dim=2, sizes="bi:1.4:0.5", seed=seed).phi_j for seed in range(args.seeds)])
mean, err = phi_j.mean(), phi_j.std(ddof=1) / np.sqrt(len(phi_j)) if len(phi_j) > 1 else float("nan")
print(f"{len(phi_j)} packings of N = {args.n}: phi_J = {mean:.5f} +- {err:.5f} (s.d. {phi_j.std(ddof=1):.5f})")

fig = Figure(figsize=(5.5, 4), layout="constrained")
FigureCanvasAgg(fig)
ax = fig.subplots()
ax.hist(phi_j, bins=max(5, len(phi_j) // 3), density=True, alpha=0.7)
ax.axvline(mean, color="k", ls="--", label=f"mean {mean:.4f} +- {err:.4f}")
ax.set(xlabel=r"$\phi_J$", ylabel=r"$P(\phi_J)$", title=f"{len(phi_j)} packings, N = {args.n} bidisperse disks")
ax.legend(fontsize=8)
fig.savefig(args.out, dpi=120)
print("figure ->", args.out)
