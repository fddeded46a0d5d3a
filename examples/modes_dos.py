"""Normal modes of jammed packings: the eigenvalues of the dynamical matrix over the
non-floaters and the density of states D(omega), averaged over a few packings (chapter
section 3, Figure 2.16: a plateau of low-frequency modes at jamming onset).

    python examples/modes_dos.py --n 128 --seeds 4 --out modes_dos.png
"""

import argparse

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

import jamflow
from jamflow.analysis.modes import DensityOfStates, Spectrum, Stability

parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
parser.add_argument("--n", type=int, default=128, help="disks per packing")
parser.add_argument("--seeds", type=int, default=4, help="number of packings")
parser.add_argument("--out", default="modes_dos.png", help="figure (PNG)")
args = parser.parse_args()

spectrum = Spectrum(e_min=1e-6, method="dense")
spectra = []
for seed in range(args.seeds):
    packing = jamflow.jam(n=args.n, dim=2, sizes="bi:1.4:0.5", seed=seed).packing
    s = spectrum.compute(packing)
    spectra.append(s)
    print(f"seed {seed}: {s.n_zero} zero modes, lowest nonzero e = {s.lowest_nonzero:.3e}, "
          f"{Stability(spectrum=spectrum).compute(packing, s).label}")
dos = DensityOfStates(bins=20).compute(spectra)

fig = Figure(figsize=(10, 4), layout="constrained")
FigureCanvasAgg(fig)
left, right = fig.subplots(1, 2)
for s in spectra:
    left.plot(np.arange(1, len(s.frequencies) + 1) / s.n_dof, s.frequencies, lw=0.8)
left.set(xlabel="i / (d N')", ylabel=r"$\omega_i$", title="sorted frequencies")
right.stairs(dos.density, dos.edges, fill=True, alpha=0.6)
right.set(xlabel=r"$\omega$", ylabel=r"$D(\omega)$ per packing", title=f"D(omega), {dos.n_packings} packings, N = {args.n}")
fig.savefig(args.out, dpi=120)
print("figure ->", args.out)
