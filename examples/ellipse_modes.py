"""Jam bidisperse ellipses (chapter section 2.3.3; sizes 1 : 1.4 with the chapter's 2:1
number ratio) and show their sorted normal modes with rotations as coordinates, coloured by
mode character (Figure 2.17: a zero branch, a rotational branch and a translational branch);
the extra zero (quartic) modes match the missing contacts of these hypostatic packings.

    python examples/ellipse_modes.py --n 64 --alpha 1.2 --seeds 2 --out ellipse_modes.png
"""

import argparse

import jamflow
from jamflow.mechanics.contacts import Contacts
from jamflow.analysis.modes import Spectrum
from jamflow.plots.modes import sorted_modes_figure

parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
parser.add_argument("--n", type=int, default=64, help="ellipses per packing")
parser.add_argument("--alpha", type=float, default=1.2, help="aspect ratio (major / minor axis)")
parser.add_argument("--seeds", type=int, default=2, help="number of packings")
parser.add_argument("--out", default="ellipse_modes.png", help="figure (PNG)")
args = parser.parse_args()

spectrum = Spectrum(e_min=1e-6, method="dense")
spectra = []
for seed in range(args.seeds):
    result = jamflow.jam(n=args.n, dim=2, sizes="bi:1.4:0.6667", shape=f"ellipse:{args.alpha}", seed=seed)
    contacts = Contacts().compute(result.packing)
    s = spectrum.compute(result.packing)
    spectra.append(s)
    missing = contacts.isostatic_count - contacts.n_contacts
    print(f"seed {seed}: phi_J = {result.phi_j:.6f}, <z> = {contacts.mean_z:.3f}, N_c = {contacts.n_contacts} "
          f"(isostatic {contacts.isostatic_count}: {missing} missing), {s.n_extra_zero} extra zero modes")

title = f"{args.seeds} packings of N = {args.n} ellipses, alpha = {args.alpha}"
print("figure ->", sorted_modes_figure(args.out, spectra, title))
