"""Speed of the LAMMPS pair styles jamflow can use, measured side by side in one run.

Usage (from the repository root)::

    python benchmarks/pair_styles.py [--n 1024] [--iterations 2000] [--repeats 3]

For N 2D disks at phi 0.86, relaxed first (so that repulsive LJ starts from moderate
overlaps), it times a fixed number of FIRE iterations (``minimize 0 0 K K``: one force
evaluation each) with
- polydisperse diameters (poly-uniform:0.4): the jamflow plugin vs ``lepton/sphere``,
  for Spring(2), Spring(2.5) and RepulsiveLJ;
- bidisperse diameters (bi:1.4:0.5), Spring(2): built-in ``harmonic/cut`` vs plugin vs lepton.
It prints the best of ``--repeats`` wall times per iteration and the ratios. All styles
start from the same configuration; energies after the run are printed as a sanity check
(they differ only by round-off-driven trajectory differences).
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

from jamflow.engines.lammps.engine import LammpsEngine
from jamflow.engines.lammps.pair_styles import harmonic_cut_commands
from jamflow.engines.lammps.plugin_build import load_plugin, pair_style_commands
from jamflow.model.packing import random_packing
from jamflow.model.potentials import RepulsiveLJ, Spring
from jamflow.model.sizes import parse_sizes

PHI = 0.86


def relaxed_start(n: int, sizes: str, seed: int = 0):
    """Random packing at PHI, relaxed with linear springs (same start for every style)."""
    packing = random_packing(n, 2, parse_sizes(sizes), PHI, seed, Spring(2.0))
    with LammpsEngine(packing) as engine:
        engine.run_commands(["min_style fire", "minimize 0.0 1e-8 5000 50000"])
        return engine.packing()


def time_style(packing, style: str, iterations: int, repeats: int):
    """Best wall time per FIRE iteration (s) and final energy for one pair style."""
    best, energy = float("inf"), None
    for _ in range(repeats):
        with LammpsEngine(packing) as engine:
            if style == "plugin":
                if not load_plugin(engine.lmp):
                    raise SystemExit("the jamflow plugin is unavailable (no C++ compiler)")
                lines = pair_style_commands(packing.potential, packing.diameters.max())
            elif style == "lepton":
                lines = pair_style_commands(packing.potential, packing.diameters.max(), plugin=False)
            else:
                lines = harmonic_cut_commands(packing)
            engine.run_commands([*lines, "min_style fire", "run 0"])
            start = time.perf_counter()
            engine.command(f"minimize 0.0 0.0 {iterations} {iterations}")
            best = min(best, (time.perf_counter() - start) / iterations)
            energy = engine.state().energy
    return best, energy


def report(title: str, packing, styles, iterations: int, repeats: int) -> None:
    results = {s: time_style(packing, s, iterations, repeats) for s in styles}
    base = results["plugin"][0]
    print(f"\n{title}")
    for style, (seconds, energy) in results.items():
        print(f"  {style:13s} {seconds * 1e6:9.1f} us/iteration  {seconds / base:6.2f} x plugin   "
              f"E_final = {energy:.6e}")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=1024)
    parser.add_argument("--iterations", type=int, default=2000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    if args.n < 64 or args.iterations < 1 or args.repeats < 1:
        raise SystemExit("need --n >= 64, --iterations >= 1, --repeats >= 1")

    print(f"N = {args.n} 2D disks, phi = {PHI}, {args.iterations} FIRE iterations, best of {args.repeats}")
    poly = relaxed_start(args.n, "poly-uniform:0.4")
    for potential in (Spring(2.0), Spring(2.5), RepulsiveLJ()):
        report(f"polydisperse poly-uniform:0.4, {potential}", replace(poly, potential=potential),
               ("plugin", "lepton"), args.iterations, args.repeats)
    bi = relaxed_start(args.n, "bi:1.4:0.5")
    report("bidisperse bi:1.4:0.5, Spring(alpha=2.0)", bi, ("plugin", "harmonic/cut", "lepton"),
           args.iterations, args.repeats)


if __name__ == "__main__":
    main()
