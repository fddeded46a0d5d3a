"""The numbers docs/notes/shear.md quotes about a family sampling (jamflow families --out DIR).

Reads DIR/points.h5 and prints: how far apart packings of one family lie at one strain (phi_J,
Sigma/P, fabric) and how close distinct families with one signature come; the families by the
number of sampled paths that met them and, per half, how many of them have their mirror image
gamma -> 1 - gamma in the sample; family extents; the count against the number of starts with
its growth exponent; the Chao1 estimate with its standard error; the count against the
joining tolerances on phi_J and Sigma/P (issue 30).

    python benchmarks/families_stats.py fam-n10
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from jamflow.analysis.families import (
    TOL_FABRIC,
    TOL_MU,
    TOL_PHI,
    _text,
    convergence,
    join,
    mirror_by_sightings,
    mirror_check,
    richness,
    symmetric_strain,
)
from jamflow.io.families_file import load_family_points


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
    out = Path((sys.argv[1:] if argv is None else argv)[0])
    plan, pts, failures = load_family_points(out / "points.h5")
    step = float(plan["spacing"]) / int(plan["substeps"])
    fam = join(pts, step, float(plan["gamma_min"]))
    rounds = len(np.unique(pts["start"]))
    print(f"{out}: N = {plan['n']}, {rounds} starts x {round(1 + (float(plan['gamma_max']) - float(plan['gamma_min'])) / float(plan['spacing']))} strains, "
          f"{len(pts['gamma'])} points, {fam.count} families, {len(failures)} failures")
    same, other = neighbour_gaps(pts, fam)
    print(f"one family, one strain (neighbours): max |d phi_J| {same[:, 0].max():.1e}, max |d Sigma/P| "
          f"{same[:, 1].max():.1e}, max |d fabric| {same[:, 2].max():.1e}")
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
    check = mirror_check(fam)
    for lo, hi in ((0.0, 0.5), (0.5, 1.0)):
        rows = mirror_by_sightings(fam, check, fam.met_in(lo, hi))
        print(f"met in [{lo}, {hi}]: mirror found / families by paths: "
              + ", ".join(f"{label}: {found}/{total}" for label, total, found in rows))
    print(f"mirror-matched points: worst |d phi_J| {check.worst_phi:.1e}, |d Sigma/P| {check.worst_mu:.1e}; "
          f"matched families not pairing one to one: {len(check.unpaired)}")
    extent = np.array([r["gamma_max"] - r["gamma_min"] for r in fam.table()])
    print(f"family extents: median {np.median(extent):.3f}, 90th percentile {np.percentile(extent, 90):.3f}, "
          f"max {extent.max():.3f}; families met at one strain only: {int(np.sum(extent == 0))}")
    conv = convergence(pts, step, float(plan["gamma_min"]))
    k, half, total = np.array(conv, float).T
    print("count against starts (K: in [0, 1/2] / all):", ", ".join(f"{int(a)}: {int(b)}/{int(c)}" for a, b, c in conv))
    if np.sum(k >= 4) >= 2:
        slope = np.polyfit(np.log(k[k >= 4]), np.log(total[k >= 4]), 1)[0]
        print(f"growth exponent of the total for K >= 4: {slope:.2f} (1: every start adds as many new families)")
    rich = richness(fam)
    print(f"Chao1 {rich['chao1']:.1f} +- {rich['chao1_se']:.1f} ({100 * rich['chao1_se'] / rich['chao1']:.1f} %); "
          f"observed {rich['observed']} of {rich['sampled']} sampled packings, f1 = {rich['singletons']}, "
          f"f2 = {rich['doubletons']}")
    print(f"families (all) against the joining tolerances (defaults tol_phi {TOL_PHI:g}, tol_mu {TOL_MU:g}, "
          f"tol_fabric {TOL_FABRIC:g}; one varied at a time, then all three):")
    g0 = float(plan["gamma_min"])
    for name, values in (("tol_phi", (1e-10, 1e-9, 1e-7, 1e-6, 1e-5, 1e-4)), ("tol_mu", (1e-6, 1e-5, 1e-3, 1e-2, 1e-1)),
                         ("tol_fabric", (1e-5, 1e-4, 1e-2, 1e-1, 1.0))):
        print(f"  {name}: " + ", ".join(f"{v:g}: {join(pts, step, g0, **{name: v}).count}" for v in values))
    for scale in (0.1, 10.0, 100.0, 1000.0):
        count = join(pts, step, g0, tol_phi=TOL_PHI * scale, tol_mu=TOL_MU * scale, tol_fabric=TOL_FABRIC * scale).count
        print(f"  all three x {scale:g}: {count}")


if __name__ == "__main__":
    main()
