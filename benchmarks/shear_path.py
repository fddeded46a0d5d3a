"""One quasistatic shear path, drawn, and what a step costs (docs/notes/shear.md).

Jams N bidisperse disks at gamma0 (default protocol), shears them to --to in steps of
--dgamma (jamflow.protocols.shear, default bisection), writes the path file and the figure
(phi_J, Sigma = -P_xy and Sigma / P against gamma, contact changes marked), and prints each
break (contacts removed and added, the phi_J jump) and the CPU time, minimisations and FIRE
iterations per step (CPU seconds: the machine is shared).

    python benchmarks/shear_path.py --n 10 --seed 0 --gamma0 0.2 --dgamma 0.002 --to 0.5 \
        --out docs/notes/shear-path-n10
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from jamflow.plots.shear import shear_path_figure
from jamflow.protocols.compression import jam
from jamflow.protocols.shear import shear
from jamflow.io.shear_file import path_columns, save_shear_path
from common import scratch  # (benchmarks/ is the script's directory)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=10)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--gamma0", type=float, default=0.2)
    parser.add_argument("--dgamma", type=float, default=0.002)
    parser.add_argument("--to", type=float, default=0.5)
    parser.add_argument("--engine", default="auto")
    parser.add_argument("--out", default=str(scratch("shear-path-n10")), help="prefix: PREFIX.png and PREFIX.shear.h5")
    args = parser.parse_args(argv)
    start = jam(n=args.n, seed=args.seed, gamma=args.gamma0, engine=args.engine)
    cpu = time.process_time()
    path = shear(start.packing, args.dgamma, args.to, engine=args.engine)
    cpu = time.process_time() - cpu
    save_shear_path(args.out + ".shear.h5", path, source=f"jam(n={args.n}, seed={args.seed}, gamma={args.gamma0})")
    shear_path_figure(args.out + ".png", path_columns(path),
                      title=f"N = {args.n} (seed {args.seed}): {len(path.steps) - 1} steps of {args.dgamma:g}, "
                            f"contact network changed at {path.n_changes}")
    print(path.summary())
    for k, s in enumerate(path.steps):
        if s.changed:
            print(f"  step {k} gamma {s.gamma:.4f}: phi_J {path.steps[k - 1].phi_j:.8f} -> {s.phi_j:.8f}, "
                  f"removed {s.removed}, added {s.added}")
    steps = len(path.steps) - 1
    mins = np.array([s.jam.minimizations for s in path.steps[1:]])
    its = np.array([s.jam.iterations for s in path.steps[1:]])
    print(f"per step: {cpu / steps * 1e3:.1f} ms CPU, {mins.mean():.1f} minimisations (max {mins.max()}), "
          f"{its.mean():.0f} FIRE iterations; engine {path.engine}; load average {os.getloadavg()[0]:.1f}")
    print(f"-> {args.out}.png, {args.out}.shear.h5")


if __name__ == "__main__":
    main()
