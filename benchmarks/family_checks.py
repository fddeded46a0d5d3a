"""Two checks behind docs/notes/shear.md's family section.

1. How many distinct jammed packings random starts find at one strain (gamma = 0.1), for
   N = 6, 8, 10 bidisperse disks, against the number of starts: whether the sampling of one
   strain saturates (identity: signature, phi_J within 1e-8, Sigma/P within 1e-4, fabric 1e-3).
2. The dynamics through a rearrangement are reproducible and mirror symmetric: packings jammed
   at 0.3 whose path breaks before 0.31 are relabelled and translated 6 times and sheared again
   (one post-break family expected), and their mirror images at 0.7 sheared the other way must
   end in the mirror image of it.

    python benchmarks/family_checks.py --starts 300
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

from jamflow.analysis.families import TOL_FABRIC, TOL_MU, TOL_PHI
from jamflow.protocols.compression import jam
from jamflow.protocols.families import fabric, signature
from jamflow.protocols.shear import Network, shear


def key(packing, phi_j, pressure_tensor):
    net = Network.of(packing)
    return (signature(net, packing.diameters), phi_j, -pressure_tensor[0, 1] / np.trace(pressure_tensor) * 2,
            *fabric(net))


def same(a, b) -> bool:
    return (a[0] == b[0] and abs(a[1] - b[1]) <= TOL_PHI and abs(a[2] - b[2]) <= TOL_MU
            and abs(a[3] - b[3]) <= TOL_FABRIC and abs(a[4] - b[4]) <= TOL_FABRIC)


def distinct_at_one_strain(n: int, starts: int, gamma: float = 0.1):
    seen, counts, curve = [], [], []
    for seed in range(starts):
        r = jam(n=n, seed=seed, gamma=gamma)
        k = key(r.packing, r.phi_j, r.pressure_tensor)
        for m, other in enumerate(seen):
            if same(k, other):
                counts[m] += 1
                break
        else:
            seen.append(k)
            counts.append(1)
        curve.append(len(seen))
    return curve, sorted(counts, reverse=True)


def relabelled(packing, rng):
    perm = rng.permutation(packing.n)
    q = packing.subset(perm)
    return q.with_positions(packing.box.wrap(q.positions + rng.random(packing.dim) * packing.box.lengths))


def mirrored(packing, gamma):
    box = packing.box.with_shear_strain(gamma)
    return packing.with_positions(box.wrap(packing.positions * [-1.0, 1.0]), box=box)


def outcome(path):
    last = path.steps[-1]
    return key(last.packing, last.phi_j, last.jam.pressure_tensor)


def mirror_key(k):
    return (k[0], k[1], -k[2], k[3], -k[4])


def dynamics(cases: int = 8, copies: int = 6):
    rng = np.random.default_rng(5)
    rows = []
    for seed in range(200):
        base = jam(n=10, seed=seed, gamma=0.3).packing
        if shear(base, 0.001, 0.31).n_changes == 0:
            continue
        lower = [outcome(shear(relabelled(base, rng), 0.001, 0.31)) for _ in range(copies)]
        upper = [outcome(shear(relabelled(mirrored(base, 0.7), rng), -0.001, 0.69)) for _ in range(copies)]
        one = all(same(lower[0], k) for k in lower)
        mirror = all(same(mirror_key(lower[0]), k) for k in upper)
        rows.append((seed, one, mirror))
        if len(rows) == cases:
            break
    return rows


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--starts", type=int, default=300)
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore")
    for n in (6, 8, 10):
        curve, counts = distinct_at_one_strain(n, args.starts)
        marks = [k for k in (10, 30, 100, 150, 200, 300) if k <= args.starts]
        print(f"N = {n}: distinct packings at gamma = 0.1 after " + ", ".join(f"{k}: {curve[k - 1]}" for k in marks)
              + f" starts; most frequent found {counts[:5]} times")
    rows = dynamics()
    print(f"rearranging paths (seeds {[r[0] for r in rows]}): one post-break family over 6 relabelled copies "
          f"{sum(r[1] for r in rows)}/{len(rows)}, mirror image from the mirrored copies {sum(r[2] for r in rows)}/{len(rows)}")


if __name__ == "__main__":
    main()
