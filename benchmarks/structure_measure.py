"""Measured values behind docs/notes/structure.md (run benchmarks/structure_data.py first).

Usage (from the repository root)::

    python benchmarks/structure_measure.py disks --n 1024      # Q6, G, xi for p = 1.1 vs 1.4
    python benchmarks/structure_measure.py spheres --n 1024    # g(r) first peak at Delta phi ~ 1e-2
    python benchmarks/structure_measure.py checks              # crystals and library agreement

Figures go to docs/notes/structure-*.png (override with --figures).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from jamflow.analysis.correlations import BondCorrelation, rdf_correlation_length
from jamflow.analysis.order import BondOrder, first_minimum, particle_bond_order, translational_order
from jamflow.plots.structure import plot_bond_correlations, plot_bond_order_map, plot_rdf, plot_structure_factor
from jamflow.analysis.structure import (RDF, StructureFactor, fcc_packing, rms_contact_distance,
                                        structure_factor_grid, triangular_packing)
from jamflow.io.packing_file import load_packing
from jamflow.model.packing import random_packing
from jamflow.model.sizes import parse_sizes
from common import scratch  # (benchmarks/ is the script's directory)

DATA = Path("/tmp/jamflow-structure-data")


def disks(n: int, figures: Path) -> None:
    for p in ("1.1", "1.4"):
        files = sorted(DATA.glob(f"disks-p{p}-n{n}-s*.h5"))
        if not files:
            print(f"p = {p}: no packings in {DATA}; run benchmarks/structure_data.py disks --n {n}")
            continue
        packings = [load_packing(f) for f in files]
        rdf = RDF(dr=0.02).compute(packings)
        r_min = first_minimum(rdf)
        orders = [BondOrder(r_min=r_min).compute(pk) for pk in packings]
        qg = np.array([o.global_order for o in orders])
        ql = np.array([o.local_order for o in orders])
        G = translational_order(rdf, r_min)
        g_fit = rdf_correlation_length(rdf, r_min)
        corr = BondCorrelation(r_min=r_min, dr=0.1).compute(packings)
        print(f"p = {p}, N = {n}, {len(packings)} packings (phi = {np.mean([q.phi for q in packings]):.4f}): "
              f"r_min = {r_min:.3f}, Q6 global = {qg.mean():.3f} +- {qg.std():.3f} {np.round(qg, 3).tolist()}, "
              f"Q6 local = {ql.mean():.3f} +- {ql.std():.3f}, G = {G.G:.4f} (g_min {G.g_min:.3f} / first peak "
              f"{G.g_max:.2f}), xi(g - 1) = {g_fit.xi:.2f} +- {g_fit.xi_stderr:.2f} ({len(g_fit.r_points)} maxima"
              f"{', ' + g_fit.reason if g_fit.reason else ''}), xi(C) = {corr.fit.xi:.2f} +- {corr.fit.xi_stderr:.2f} "
              f"({len(corr.fit.r_points)} maxima{', ' + corr.fit.reason if corr.fit.reason else ''}), "
              f"q6 all-pairs baseline {corr.baseline:.4f}")
        plot_rdf(rdf, figures / f"structure-disks-p{p}-rdf.png", r_min=r_min, fit=g_fit, title=f"p = {p}")
        plot_bond_correlations(corr, figures / f"structure-disks-p{p}-q6corr.png", title=f"p = {p}, N = {n}")
        plot_bond_order_map(packings[0], orders[0], figures / f"structure-disks-p{p}-map.png",
                            title=f"{files[0].name}:")


def spheres(n: int, figures: Path) -> None:
    files = sorted(DATA.glob(f"spheres-mono-n{n}-s*.h5"))
    if not files:
        print(f"no sphere packings in {DATA}; run benchmarks/structure_data.py spheres --n {n}")
        return
    import h5py

    dphi = []
    for f in files:
        with h5py.File(f) as h:
            dphi.append(float(h["protocol"].attrs["dphi"]))
    packings = [load_packing(f) for f in files]
    print(f"3D monodisperse, N = {n}, {len(files)} packings, measured Delta phi = {np.round(dphi, 5).tolist()}")
    for dr in (0.005, 0.01, 0.02, 0.05):
        rdf = RDF(dr=dr, r_max=2.5).compute(packings)
        r_peak, g_peak = rdf.first_peak(1.2)
        print(f"  dr = {dr}: first peak g = {g_peak:.2f} at r = {r_peak:.4f} (bin [{r_peak - dr / 2:.4f}, "
              f"{r_peak + dr / 2:.4f}))")
    rdf = RDF(dr=0.01).compute(packings)
    r_min = first_minimum(rdf)
    orders = [BondOrder(r_min=r_min).compute(pk) for pk in packings]
    print(f"  r_min = {r_min:.3f}, G = {translational_order(rdf, r_min).G:.4f}, Q6 global = "
          f"{np.mean([o.global_order for o in orders]):.3f}, Q6 local = {np.mean([o.local_order for o in orders]):.3f}")
    sk = StructureFactor(k_max=30.0).compute(packings)
    low = sk.k < 2.0
    print(f"  S(k) at the lowest shells k = {np.round(sk.k[low][:4], 3).tolist()}: {np.round(sk.s[low][:4], 4).tolist()}"
          f"; first peak S = {sk.s.max():.2f} at k = {sk.k[np.argmax(sk.s)]:.2f}")
    plot_rdf(rdf, figures / "structure-spheres-rdf.png", r_min=r_min, title="3D mono")
    plot_structure_factor(sk, figures / "structure-spheres-sk.png", title="3D mono, jammed")


def checks() -> None:
    import freud

    tri = BondOrder().compute(triangular_packing(20, 20, tilted=True))
    fcc = BondOrder().compute(fcc_packing(4))
    print(f"triangular crystal (tilted cell): Q6 global = {tri.global_order:.15f}, local = {tri.local_order:.15f}")
    print(f"FCC crystal: Q6 global = {fcc.global_order:.6f}, local = {fcc.local_order:.6f} (SNR 1983: 0.57452)")
    rng_p = random_packing(1000, 2, parse_sizes("mono"), 0.5, 3)
    p2 = rng_p.with_positions(rng_p.positions, rng_p.box.with_shear_strain(0.3))
    q, n = particle_bond_order(p2, 1.3)
    fbox = p2.box.to_freud()
    pts = fbox.wrap(np.column_stack([p2.positions, np.zeros(p2.n)]).astype(np.float32))
    hexatic = freud.order.Hexatic(k=6)
    hexatic.compute((fbox, pts), {"r_max": 1.3, "exclude_ii": True})
    have = n > 0
    print(f"psi6 vs freud Hexatic (N = 1000, tilted): max |diff| = {np.abs(q[have, 0] - hexatic.particle_order[have]).max():.2e}")
    p3 = random_packing(1000, 3, parse_sizes("mono"), 0.3, 3)
    res = RDF(dr=0.05).compute(p3)
    fr = freud.density.RDF(bins=len(res.g), r_max=res.edges[-1], normalization_mode="finite_size")
    fb3 = p3.box.to_freud()
    fr.compute((fb3, fb3.wrap(p3.positions.astype(np.float32))), neighbors={"r_max": res.edges[-1], "exclude_ii": True})
    print(f"g(r) vs freud RDF (3D, N = 1000): pair counts differ in {int(np.sum(2 * res.counts != fr.bin_counts))} "
          f"of {len(res.g)} bins, max |g diff| = {np.abs(res.g - fr.rdf).max():.2e}")
    sf = freud.diffraction.StaticStructureFactorDirect(bins=30, k_max=8.0, k_min=0.0)
    sf.compute((fb3, fb3.wrap(p3.positions.astype(np.float32))))
    k, s = structure_factor_grid(p3, 8.0)
    octant = np.all(np.rint(k @ p3.box.h / (2 * math.pi)) >= 0, axis=1)
    idx = np.digitize(np.linalg.norm(k, axis=1), sf.bin_edges) - 1
    rel = [abs(s[octant & (idx == b)].mean() / sf.S_k[b] - 1) for b in range(1, 30) if np.any(octant & (idx == b))]
    print(f"S(k) vs freud direct (3D cubic, octant vectors): max relative diff = {max(rel):.2e}")
    jam_like = [f for f in sorted(DATA.glob("disks-p1.4-n*-s*.h5"))][:1]
    if jam_like:
        pk = load_packing(jam_like[0])
        scale = rms_contact_distance(pk.diameters)
        i, j = np.triu_indices(pk.n, 1)
        r = np.linalg.norm(pk.box.minimum_image(pk.positions[i] - pk.positions[j]), axis=1)
        sigma = 0.5 * (pk.diameters[i] + pk.diameters[j])
        r32 = np.linalg.norm(fbox_diff(pk, i, j), axis=1)
        contact = r < sigma
        print(f"{jam_like[0].name}: {contact.sum()} contacts, overlaps 1 - r/sigma in "
              f"[{(1 - r[contact] / sigma[contact]).min():.1e}, {(1 - r[contact] / sigma[contact]).max():.1e}]; "
              f"float32 distances put {int(np.sum((r32 < sigma) != contact))} pairs on the other side of contact "
              f"(scale {scale:.4f})")


def fbox_diff(packing, i, j):
    """Minimum-image separations computed from float32 positions, as freud would see them."""
    fbox = packing.box.to_freud()
    pts = packing.positions if packing.dim == 3 else np.column_stack([packing.positions, np.zeros(packing.n)])
    pts = fbox.wrap(pts.astype(np.float32))
    return np.asarray(fbox.wrap(pts[i] - pts[j]), float)[:, : packing.dim]


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("what", choices=("disks", "spheres", "checks"))
    parser.add_argument("--n", type=int, default=1024)
    parser.add_argument("--figures", type=Path, default=scratch())
    args = parser.parse_args(argv)
    if args.what == "disks":
        disks(args.n, args.figures)
    elif args.what == "spheres":
        spheres(args.n, args.figures)
    else:
        checks()


if __name__ == "__main__":
    main()
