"""Ensembles of jammed packings at several N and the distribution P(phi_J): a plain loop over
seeds with jamflow.jam, one packing per (N, seed) (2D bidisperse disks). The width W of
P(phi_J) shrinks with N, W ~ N^-nu (O'Hern et al., PRE 68, 011306, 2003; the chapter's
section 2.4, Figure 2.14); `jamflow ensemble` and `jamflow onsets` do the same at scale.

    python examples/ensemble_phi_j.py --n 16 32 64 --seeds 40 --out ensemble_phi_j.png
"""

import argparse

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

import jamflow

parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
parser.add_argument("--n", type=int, nargs="+", default=[16, 32, 64], help="disks per packing, one ensemble each")
parser.add_argument("--seeds", type=int, default=40, help="packings per N (seeds 0 .. SEEDS-1)")
parser.add_argument("--out", default="ensemble_phi_j.png", help="figure (PNG)")
args = parser.parse_args()

phi_j = {n: np.array([jamflow.jam(n=n, dim=2, sizes="bi:1.4:0.5", seed=seed).phi_j for seed in range(args.seeds)])
         for n in args.n}
width = {n: values.std(ddof=1) if len(values) > 1 else float("nan") for n, values in phi_j.items()}
for n, values in phi_j.items():
    print(f"N = {n}: {len(values)} packings, phi_J = {values.mean():.5f} +- {width[n] / np.sqrt(len(values)):.5f}, "
          f"W (s.d.) = {width[n]:.5f}")

fig = Figure(figsize=(10, 4), layout="constrained")
FigureCanvasAgg(fig)
hist, scaling = fig.subplots(1, 2)
every = np.concatenate(list(phi_j.values()))
bins = np.linspace(every.min(), every.max(), max(6, min(30, len(every) // 8)) + 1)
for n, values in phi_j.items():
    hist.hist(values, bins=bins, density=True, histtype="step", lw=1.5, label=f"N = {n} (W = {width[n]:.4f})")
hist.set(xlabel=r"$\phi_J$", ylabel=r"$P(\phi_J)$ (normalised)", title=f"{args.seeds} packings per N, bidisperse disks")
hist.legend(fontsize=8)
sizes = np.array(sorted(phi_j))
widths = np.array([width[n] for n in sizes])
errors = widths / np.sqrt(2 * (args.seeds - 1)) if args.seeds > 1 else np.full(len(sizes), np.nan)
scaling.errorbar(sizes, widths, yerr=errors, fmt="o")
if len(sizes) > 1 and np.all(widths > 0):
    slope, offset = np.polyfit(np.log(sizes), np.log(widths), 1)
    scaling.plot(sizes, np.exp(offset) * sizes**slope, "k--", lw=1, label=rf"$W \propto N^{{-{-slope:.2f}}}$")
    scaling.legend(fontsize=8)
scaling.set(xscale="log", yscale="log", xlabel="N", ylabel=r"W = s.d. of $\phi_J$", title="the width narrows with N")
fig.savefig(args.out, dpi=120)
print("figure ->", args.out)
