"""Regenerate the chapter's figures at small N for the documentation's gallery (docs/gallery.md).

Each ``figure_*`` function below makes the pictures of one chapter figure with jamflow's library
API and its plotting functions (``jamflow.plots``), at the smallest N that still shows the
physics; docs/gallery.md shows the pictures with the code that made them. The PNGs go to
docs/gallery/images/ (not committed: the site build, docs/conf.py, runs this script for the
pictures that are missing, and stops with a message naming it when it cannot make one).

    python docs/gallery/make_gallery.py                   # all figures (about a minute on 2 cores)
    python docs/gallery/make_gallery.py --only 2.16 2.31  # some of them
"""

from __future__ import annotations

import argparse
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

import jamflow
from jamflow.analysis.families import convergence, join, mirror_check, richness
from jamflow.analysis.modes import DensityOfStates, Spectrum, Stability
from jamflow.analysis.order import BondOrder, first_minimum
from jamflow.analysis.structure import RDF, StructureFactor, triangular_packing
from jamflow.mechanics.contacts import Contacts
from jamflow.mechanics.elastic import HessianModuli
from jamflow.model.nematic import Nematic
from jamflow.plots.anneal import anneal_figure
from jamflow.plots.compression import compression_figure
from jamflow.plots.drawing import draw_packing
from jamflow.plots.modes import modes_figure, sorted_modes_figure
from jamflow.plots.moduli import family_figure, scaling_figure
from jamflow.plots.shear import families_figure
from jamflow.plots.structure import plot_bond_order_map, plot_order, plot_rdf, plot_structure_factor
from jamflow.protocols.anneal import anneal
from jamflow.protocols.families import FamilySampling, sample
from jamflow.protocols.moduli import Moduli
from jamflow.protocols.settings import protocol_settings
from jamflow.protocols.sweeps import SweepSettings

IMAGES = Path(__file__).resolve().parent / "images"
FIGURES = {}  # chapter figure number -> function(out directory)
SLOW = ("2.7", "2.33", "2.31", "2.18")  # the figures that take longest (about 10-25 s of CPU each)


def chapter_figure(number: str):
    def register(function):
        FIGURES[number] = function
        return function

    return register


@chapter_figure("2.3")
def figure_2_3(out: Path) -> None:
    """Packing fraction and energy at every minimisation of one compression, the chapter's protocol."""
    res = jamflow.jam(n=64, seed=1, settings=protocol_settings("chapter"))
    compression_figure(out / "fig-2-3.png", res, title=f"N = 64 bidisperse disks, seed 1, protocol 'chapter': "
                                                       f"{res.minimizations} minimisations")


@chapter_figure("2.7")
def figure_2_7(out: Path) -> None:
    """Geometric families: phi_J(gamma) of N = 8 disks, 3 random starts at every strain of a 0.05 grid."""
    plan = FamilySampling(n=8, gamma_min=0.0, gamma_max=1.0, spacing=0.05, substeps=5, starts=3, seed=0)
    points, _ = sample(plan)
    families = join(points, plan.step, plan.gamma_min)
    conv = convergence(points, plan.step, plan.gamma_min, hi=0.5)
    families_figure(out / "fig-2-7.png", families, mirror_check(families), conv, richness(families),
                    title=f"N = 8 bidisperse disks: {families.count} geometric families from 3 starts x "
                          f"{len(plan.grid)} strains")


def _above(n, dphi, seeds, **jam_options):
    """Packings of ``seeds`` compressed ``dphi`` above their onsets."""
    return [jamflow.compress_above(jamflow.jam(n=n, seed=s, **jam_options).packing, dphi).packing for s in seeds]


@chapter_figure("2.16")
def figure_2_16(out: Path) -> None:
    """Sorted frequencies, D(omega), z_i and the lowest mode's energy of 8 packings of N = 64 disks at dphi = 1e-4."""
    spectrum = Spectrum(e_min=1e-6, method="dense")
    packings = _above(64, 1e-4, range(8))
    spectra = [spectrum.compute(p) for p in packings]
    stabilities = [Stability(spectrum=spectrum).compute(p, s) for p, s in zip(packings, spectra)]
    modes_figure(out / "fig-2-16.png", spectra, DensityOfStates(bins=20).compute(spectra),
                 [Contacts().compute(p) for p in packings], stabilities)


@chapter_figure("2.17")
def figure_2_17(out: Path) -> None:
    """Sorted modes with rotations of N = 32 bidisperse ellipse packings at three aspect ratios."""
    spectrum = Spectrum(e_min=1e-6, method="dense")
    spectra = [spectrum.compute(jamflow.jam(n=32, sizes="bi:1.4:0.6667", shape=f"ellipse:{alpha}", seed=1).packing)
               for alpha in (1.1, 1.4, 1.8)]
    sorted_modes_figure(out / "fig-2-17.png", spectra, title="N = 32 ellipses at onset, alpha = 1.1, 1.4, 1.8, seed 1")


@chapter_figure("2.18")
def figure_2_18(out: Path) -> None:
    """<z> and phi_J against alpha: shape annealing (steps of 0.05) against compression, N = 16 ellipses, 2 seeds."""
    sizes, alphas, seeds = "bi:1.4:0.6667", (1.0, 1.2, 1.4), range(2)
    annealed = [anneal(jamflow.jam(n=16, sizes=sizes, seed=s).packing, 1.4, 0.05, seed=s).steps for s in seeds]
    jammed = [_jammed(16, sizes, alpha, seeds) for alpha in alphas]  # one row per alpha
    z = [[Contacts().compute(p).mean_z for p in row] for row in jammed]
    phi = [[p.phi for p in row] for row in jammed]
    series = {"anneal 0.05": (annealed[0]["alpha"], *_mean_error([a["mean_z"] for a in annealed]),
                              *_mean_error([a["phi_j"] for a in annealed])),
              "compression": (np.array(alphas), *_mean_error(np.transpose(z)), *_mean_error(np.transpose(phi)))}
    anneal_figure(out / "fig-2-18.png", series, title="N = 16 bidisperse ellipses (2:1, sizes 1 : 1.4), seeds 0 and 1")


def _jammed(n, sizes, alpha, seeds):
    shape = "disk" if alpha == 1.0 else f"ellipse:{alpha}"
    return [jamflow.jam(n=n, sizes=sizes, shape=shape, seed=s).packing for s in seeds]


def _mean_error(columns):
    """Mean and standard error over the first axis (one row per seed)."""
    a = np.asarray(columns, float)
    return a.mean(0), a.std(0, ddof=1) / np.sqrt(len(a))


@chapter_figure("2.21")
def figure_2_21(out: Path) -> None:
    """g(r) of (b) jammed monodisperse spheres at dphi = 1e-2 (N = 128, seeds 1-4), (c) a triangular crystal."""
    spheres = _above(128, 1e-2, range(1, 5), dim=3, sizes="mono")  # seed 0 unjams at 1e-2 (JammingFailed)
    plot_rdf(RDF(dr=0.02).compute(spheres), out / "fig-2-21b.png",
             title="(b) 128 spheres, dphi = 1e-2:")
    plot_rdf(RDF(dr=0.02, r_max=3.0).compute(triangular_packing(16, 16)), out / "fig-2-21c.png",
             title="(c) crystal:")


@chapter_figure("2.22")
def figure_2_22(out: Path) -> None:
    """S(k) of jammed monodisperse spheres at dphi = 1e-4, N = 128, seeds 1-4."""
    spheres = _above(128, 1e-4, range(1, 5), dim=3, sizes="mono")
    plot_structure_factor(StructureFactor(k_max=20.0).compute(spheres), out / "fig-2-22.png",
                          title="N = 128 spheres, phi - phi_J = 1e-4")


def _polydisperse(width, seeds, n=256):
    return [jamflow.jam(n=n, sizes=f"poly-uniform:{width}", seed=s).packing for s in seeds]


@chapter_figure("2.23")
def figure_2_23(out: Path) -> None:
    """(a, b) Bond-orientational order maps of N = 256 disks at polydispersity p = 1.1 and 1.4, seed 0;
    (c, d) N = 64 ellipses at alpha = 3 jammed from aligned and from random orientations, seed 1."""
    for width, panel in ((0.1, "a"), (0.4, "b")):
        packing = _polydisperse(width, [0])[0]
        plot_bond_order_map(packing, BondOrder().compute(packing), out / f"fig-2-23{panel}.png",
                            title=f"({panel}) p = {1 + width:g}, N = 256:")
    for start, panel in (("aligned", "c"), ("random", "d")):
        packing = jamflow.jam(n=64, shape="ellipse:3", sizes="mono", seed=1, orientations=start).packing
        p2 = Nematic().compute(packing).p2
        draw_packing(packing, out / f"fig-2-23{panel}.png", color_by="orientation",
                     title=f"({panel}) N = 64 ellipses, alpha = 3, {start} start: P2 = {p2:.2f}")


@chapter_figure("2.24")
def figure_2_24(out: Path) -> None:
    """g(r) of N = 256 disks at p = 1.4 (3 seeds) with its first minimum r_min, Q6's neighbour range."""
    rdf = RDF(dr=0.02, r_max=3.0).compute(_polydisperse(0.4, range(3)))
    plot_rdf(rdf, out / "fig-2-24.png", r_min=first_minimum(rdf), title="p = 1.4, N = 256:")


@chapter_figure("2.25")
def figure_2_25(out: Path) -> None:
    """Global Q6 of N = 256 disks against polydispersity p, 2 seeds per p."""
    widths = (0.05, 0.1, 0.2, 0.3, 0.4)
    orders = [[BondOrder().compute(p).global_order for p in _polydisperse(w, range(2))] for w in widths]
    labels = [f"p = {1 + w:g}, seed {s}" for w in widths for s in range(2)]
    plot_order(labels, {"Q6 global": np.ravel(orders)}, out / "fig-2-25.png",
               title="N = 256 disks: global Q6 against polydispersity p")


@chapter_figure("2.31")
def figure_2_31(out: Path) -> None:
    """Shear stress against strain (sweeps) for one N = 64 packing at four phi - phi_J, seed 0."""
    onset = jamflow.jam(n=64, seed=0).packing
    sweeps = SweepSettings(tuple(np.geomspace(1e-7, 1e-2, 11)))
    curves = {}
    for dphi in (1e-4, 1e-3, 1e-2, 1e-1):
        shear = Moduli(sweeps).compute(jamflow.compress_above(onset, dphi).packing).shear
        curves[f"phi - phi_J = {dphi:g}"] = (shear.strains, shear.responses, shear.yield_strain)
    family_figure(out / "fig-2-31.png", curves, title="N = 64 bidisperse disks, seed 0: shear stress against strain")


# disks with springs: P ~ dphi (chapter Figure 2.31b), G ~ dphi^1/2 and B ~ dphi^0 (chapter section 4.5;
# O'Hern et al., Phys. Rev. E 68, 011306 (2003))
SPRING_SLOPES = {"spring": {"G": 0.5, "B": 0.0, "P": 1.0, "G/B": 0.5}}


@chapter_figure("2.33")
def figure_2_33(out: Path) -> None:
    """G, B, P and G/B (Hessian route) against phi - phi_J for N = 256 disks, seeds 0-5 compressed from onset; a
    packing that unjams on the way (JammingFailed, as in benchmarks/moduli_ensemble.py) is left out of its point."""
    dphis = np.array([1e-5, 1e-4, 1e-3, 1e-2, 1e-1])
    onsets = [jamflow.jam(n=256, seed=s).packing for s in range(6)]
    rows, counts = {"G": [], "B": [], "P": [], "G/B": []}, []
    for dphi in dphis:
        moduli = [HessianModuli().compute(p) for p in _compressed(onsets, dphi)]
        counts.append(len(moduli))
        values = {"G": [m.G for m in moduli], "B": [m.B for m in moduli],
                  "P": [np.trace(m.pressure_tensor) / len(m.pressure_tensor) for m in moduli]}
        values["G/B"] = np.divide(values["G"], values["B"])
        for name, column in values.items():
            rows[name].append(_mean_error(column))
    table = {"spring": {name: (dphis, *np.transpose(rows[name])) for name in rows}}
    scaling_figure(out / "fig-2-33.png", table, {}, published=SPRING_SLOPES,
                   title=f"N = 256 bidisperse disks, Hessian route; packings per point (of 6): {counts}")


def _compressed(onsets, dphi):
    """The onset packings compressed ``dphi`` above onset, without those that unjam."""
    done = []
    for packing in onsets:
        try:
            done.append(jamflow.compress_above(packing, dphi).packing)
        except jamflow.JammingFailed:
            continue
    return done


def _make(number: str, out: Path) -> str:
    """Make one chapter figure; its line of the report (wall and CPU seconds)."""
    wall, cpu = time.perf_counter(), time.process_time()
    FIGURES[number](out)
    return f"Figure {number}: {time.perf_counter() - wall:.1f} s ({time.process_time() - cpu:.1f} s CPU)"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, default=IMAGES, help="folder of the PNGs (default docs/gallery/images)")
    parser.add_argument("--only", nargs="+", choices=sorted(FIGURES), metavar="FIGURE",
                        help=f"chapter figures to make (default all: {', '.join(FIGURES)})")
    parser.add_argument("--jobs", type=int, default=2, help="figures made at once, one process each (default 2; 1: in this process)")
    args = parser.parse_args(argv)
    if args.jobs < 1:
        raise SystemExit("--jobs must be a positive integer")
    args.out.mkdir(parents=True, exist_ok=True)
    numbers = sorted(args.only or FIGURES, key=lambda k: k not in SLOW)  # the slow ones first: balanced processes
    wall = time.perf_counter()
    if args.jobs == 1:
        for number in numbers:
            print(_make(number, args.out), flush=True)
    else:
        with ProcessPoolExecutor(args.jobs) as pool:
            for done in as_completed([pool.submit(_make, number, args.out) for number in numbers]):
                print(done.result(), flush=True)
    print(f"gallery: {len(numbers)} figures in {time.perf_counter() - wall:.1f} s with {args.jobs} processes "
          f"-> {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
