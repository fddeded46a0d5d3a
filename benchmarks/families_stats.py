"""The numbers docs/notes/shear.md quotes about a family sampling (jamflow families --out DIR).

Reads DIR/points.h5 and prints: how far apart packings of one family lie at one strain (phi_J,
Sigma/P, fabric) and how close distinct families with one signature come; the families by the
number of sampled paths that met them and, per half, how many of them have their mirror image
gamma -> 1 - gamma in the sample; family extents; the count against the number of starts with
its growth exponent; the richness estimates (Chao1, first- and second-order jackknife, with
standard errors, and the sample coverage) against the starts, with the starts per strain the
extrapolation needs to find 95 % of the Chao1 estimate; the count against the joining
tolerances on phi_J and Sigma/P. The mirror is gamma -> 2 c - gamma about the middle
c of the sampled range (1/2 for [0, 1], 0 for [-0.24, 0.24]). With --figure, the count and the
estimates against K, one panel per DIR.

    python benchmarks/families_stats.py fam-n10
    python benchmarks/families_stats.py fam-n6 fam-n8 --figure docs/notes/families-richness.png
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from jamflow.analysis.families import (
    TOL_FABRIC,
    TOL_MU,
    TOL_PHI,
    _text,
    by_starts,
    join,
    mirror_by_sightings,
    mirror_check,
    more_samples_needed,
    symmetric_strain,
)
from jamflow.io.families_file import load_family_points
from jamflow.plots.shear import richness_figure

STEP_K = 5  # the richness table's K: every STEP_K starts per strain


def neighbour_gaps(pts, fam):
    """Over neighbouring points (sorted by phi_J) at one strain with one signature, away from
    gamma = k/2: the largest gap within a family and the closest distinct families."""
    sig, j, phi = _text(pts["signature"]), pts["strain_index"], pts["phi_j"]
    key = np.char.add(j.astype(str), sig)
    order = np.lexsort((phi, key))
    same, other = [], []
    for a, b in zip(order[:-1], order[1:]):
        if key[a] != key[b] or symmetric_strain(pts["gamma"][a]):
            continue
        row = (abs(phi[b] - phi[a]), abs(pts["mu"][b] - pts["mu"][a]),
               max(abs(pts["fabric_a"][b] - pts["fabric_a"][a]), abs(pts["fabric_b"][b] - pts["fabric_b"][a])),
               pts["gamma"][a])
        (same if fam.family[a] == fam.family[b] else other).append(row)
    return np.array(same).reshape(-1, 4), np.array(other).reshape(-1, 4)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dirs", nargs="+", type=Path, help="jamflow families --out DIR")
    parser.add_argument("--figure", type=Path, help="PNG of the count and the estimates against K")
    parser.add_argument("--no-tolerances", action="store_true", help="skip the tolerance scan")
    args = parser.parse_args(argv)
    panels = [report(out, not args.no_tolerances) for out in args.dirs]
    if args.figure:
        print(f"-> {richness_figure(args.figure, panels)}")


def report(out: Path, tolerances: bool = True):
    """Print the numbers of one sampling; (panel title, by_starts rows)."""
    plan, pts, failures = load_family_points(out / "points.h5")
    step = float(plan["spacing"]) / int(plan["substeps"])
    g0, g1 = float(plan["gamma_min"]), float(plan["gamma_max"])
    centre = 0.5 * (g0 + g1)
    fam = join(pts, step, g0)
    rounds = len(np.unique(pts["start"]))
    grid = round(1 + (g1 - g0) / float(plan["spacing"]))
    print(f"{out}: N = {plan['n']}, gamma in [{g0:g}, {g1:g}], {rounds} starts x {grid} strains, "
          f"{len(pts['gamma'])} points, {fam.count} families, {len(failures)} failures")
    for line in failures[:5]:
        print(f"  failure: {line}")
    same, other = neighbour_gaps(pts, fam)
    print(f"one family, one strain (neighbours): max |d phi_J| {same[:, 0].max(initial=0):.1e}, max |d Sigma/P| "
          f"{same[:, 1].max(initial=0):.1e}, max |d fabric| {same[:, 2].max(initial=0):.1e}")
    close = other[np.argsort(other[:, 0])[:5]]
    print("closest distinct families with one signature (d phi_J, d Sigma/P, d fabric, gamma):")
    for row in close:
        print(f"  {row[0]:.1e}  {row[1]:.1e}  {row[2]:.1e}  {row[3]:.3f}")
    print(f"distinct neighbours with |d phi_J| < 1e-8: {int(np.sum(other[:, 0] < 1e-8))} "
          f"(told apart by Sigma/P or the fabric)")
    spread = max(row["max_spread"] for row in fam.table())
    print(f"largest phi_J spread of one family at one strain: {spread:.1e}")
    seen = fam.sightings()
    print("families by sampled paths that met them (1, 2, ...):", np.bincount(seen)[1:12].tolist())
    if abs(2 * centre - round(2 * centre)) < 1e-9:
        check = mirror_check(fam, center=centre)
        for lo, hi in ((g0, centre), (centre, g1)):
            rows = mirror_by_sightings(fam, check, fam.met_in(lo, hi))
            print(f"met in [{lo:g}, {hi:g}]: mirror gamma -> {2 * centre:g} - gamma found / families by paths: "
                  + ", ".join(f"{label}: {found}/{total}" for label, total, found in rows))
        print(f"mirror-matched points: worst |d phi_J| {check.worst_phi:.1e}, |d Sigma/P| {check.worst_mu:.1e}; "
              f"matched families not pairing one to one: {len(check.unpaired)}")
    extent = np.array([r["gamma_max"] - r["gamma_min"] for r in fam.table()])
    print(f"family extents: median {np.median(extent):.3f}, 90th percentile {np.percentile(extent, 90):.3f}, "
          f"max {extent.max():.3f}; families met at one strain only: {int(np.sum(extent == 0))}")
    counts = sorted({k for k in (1, 2, 4) if k <= rounds} | {*range(STEP_K, rounds + 1, STEP_K), rounds})
    rows = by_starts(pts, step, g0, counts, lo=g0, hi=centre)
    k, total = np.array([r["starts"] for r in rows], float), np.array([r["total"] for r in rows], float)
    if np.sum(k >= 4) >= 2:
        slope = np.polyfit(np.log(k[k >= 4]), np.log(total[k >= 4]), 1)[0]
        print(f"growth exponent of the total for K >= 4: {slope:.2f} (1: every start adds as many new families)")
    print(f"K: families in [{g0:g}, {g1:g}] / in [{g0:g}, {centre:g}]; Chao1, jackknife 1, jackknife 2 (+- s.e., "
          "relative); coverage 1 - f1/n; f1, f2 of n sampled; starts per strain to find 95 % of Chao1")
    for r in rows:
        more = more_samples_needed(r, 0.95)
        print(f"  {r['starts']:4d}: {r['total']:5d} / {r['half']:5d}; "
              + "; ".join(f"{r[key]:.0f} +- {r[key + '_se']:.0f} ({100 * r[key + '_se'] / r[key]:.1f} %)"
                          for key in ("chao1", "jack1", "jack2"))
              + f"; {r['coverage']:.3f}; {r['singletons']}, {r['doubletons']} of {r['sampled']}; "
              f"{r['starts'] + more / grid:.0f}")
    if tolerances:
        scan(pts, step, g0)
    return f"N = {plan['n']}, gamma in [{g0:g}, {g1:g}] ({grid} strains)", rows


def scan(pts, step, g0) -> None:
    """The count against the joining tolerances, one varied at a time, then all three."""
    print(f"families (all) against the joining tolerances (defaults tol_phi {TOL_PHI:g}, tol_mu {TOL_MU:g}, "
          f"tol_fabric {TOL_FABRIC:g}; one varied at a time, then all three):")
    for name, values in (("tol_phi", (1e-10, 1e-9, 1e-7, 1e-6, 1e-5, 1e-4)), ("tol_mu", (1e-6, 1e-5, 1e-3, 1e-2, 1e-1)),
                         ("tol_fabric", (1e-5, 1e-4, 1e-2, 1e-1, 1.0))):
        print(f"  {name}: " + ", ".join(f"{v:g}: {join(pts, step, g0, **{name: v}).count}" for v in values))
    for scale in (0.1, 10.0, 100.0, 1000.0):
        count = join(pts, step, g0, tol_phi=TOL_PHI * scale, tol_mu=TOL_MU * scale, tol_fabric=TOL_FABRIC * scale).count
        print(f"  all three x {scale:g}: {count}")


if __name__ == "__main__":
    main()
