"""Jam two packings of nonspherical particles and draw them side by side (chapter section
2.3): bidisperse ellipses with the exact contact distance (convex, Figure 2.18) and rigid
dimers of two fused disks (concave, Figures 2.9 and 2.26), coloured by director angle mod pi;
contacts drawn with width proportional to force.

    python examples/shapes.py --n 64 --alpha 1.5 --out shapes.png
"""

import argparse

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

import jamflow
from jamflow.mechanics.checks import check_packing
from jamflow.plots.drawing import draw_into

parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
parser.add_argument("--n", type=int, default=64, help="particles per packing")
parser.add_argument("--alpha", type=float, default=1.5, help="aspect ratio of both shapes")
parser.add_argument("--seed", type=int, default=1)
parser.add_argument("--out", default="shapes.png", help="figure (PNG)")
args = parser.parse_args()

fig = Figure(figsize=(12, 5.6), layout="constrained")
FigureCanvasAgg(fig)
for ax, shape in zip(fig.subplots(1, 2), (f"ellipse:{args.alpha}", f"nmer:2:{args.alpha}")):
    result = jamflow.jam(n=args.n, dim=2, sizes="bi:1.4:0.5", shape=shape, seed=args.seed)
    checks = check_packing(result.packing, result.energy_per_particle, None, v_tol=result.settings.v_tol)
    print(f"{shape}: {result.summary()}; checks passed: {checks.passed}")
    body, label, _, caption = draw_into(ax, result.packing, color_by="orientation")
    ax.set_title(caption, fontsize=7)
fig.colorbar(body, ax=fig.axes, label=label, shrink=0.8)
fig.savefig(args.out, dpi=110)
print("figure ->", args.out)
