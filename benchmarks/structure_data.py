"""Generate (and cache) the jammed packings behind docs/notes/structure.md.

Usage (from the repository root)::

    python benchmarks/structure_data.py disks --n 1024 --seeds 0 1 2 3
    python benchmarks/structure_data.py spheres --n 1024 --seeds 0 1 --v-target 2.8e-5

Disks: 2D, sizes poly-uniform:0.1 (p = 1.1) and poly-uniform:0.4 (p = 1.4), linear
springs, jammed at onset by ``jamflow.protocols.compression.jam`` (V_tol = 1e-16).
Spheres: 3D monodisperse, bisected to an energy window V_target < V < 2 V_target, then the
onset of that state is found by decompression, so Delta phi = phi - phi_J is measured
(chapter Figure 2.21(b) uses phi - phi_J = 1e-2).
Files land in /tmp/jamflow-structure-data/ (override with --dir); existing files are kept.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from jamflow.io.packing_file import save_packing
from jamflow.protocols.settings import CompressionSettings
from jamflow.protocols.compression import compress, jam

DISK_SIZES = {"1.1": "poly-uniform:0.1", "1.4": "poly-uniform:0.4"}


def disk_path(directory: Path, p: str, n: int, seed: int) -> Path:
    return directory / f"disks-p{p}-n{n}-s{seed}.h5"


def sphere_path(directory: Path, n: int, seed: int, v_target: float) -> Path:
    return directory / f"spheres-mono-n{n}-s{seed}-V{v_target:g}.h5"


def make_disks(directory: Path, n: int, seeds) -> None:
    for seed in seeds:
        for p, sizes in DISK_SIZES.items():
            path = disk_path(directory, p, n, seed)
            if path.exists():
                continue
            result = jam(n=n, dim=2, sizes=sizes, seed=seed)
            save_packing(path, result.packing, energy_per_particle=result.energy_per_particle,
                         pressure_tensor=result.pressure_tensor, protocol={"phi_j": result.phi_j},
                         lammps_version=result.lammps_version)
            print(f"{path.name}: {result.summary()}", flush=True)


def make_spheres(directory: Path, n: int, seeds, v_target: float) -> None:
    """Bisect (compress/decompress) to V_target < V < 2 V_target, then find the onset of
    that same state by decompressing it to V_tol = 1e-16: Delta phi = phi - phi_J is measured,
    not imposed (an affine jump of 1e-2 from onset unjammed N = 256 packings, see docs)."""
    for seed in seeds:
        path = sphere_path(directory, n, seed, v_target)
        if path.exists():
            continue
        t0 = time.perf_counter()
        squeezed = jam(n=n, dim=3, sizes="mono", seed=seed,
                       settings=CompressionSettings(phi0=0.60, dphi0=1e-3, v_tol=v_target))
        onset = compress(squeezed.packing, CompressionSettings(dphi0=1e-3))
        dphi = squeezed.phi_j - onset.phi_j
        save_packing(path, squeezed.packing, energy_per_particle=squeezed.energy_per_particle,
                     pressure_tensor=squeezed.pressure_tensor,
                     protocol={"phi": squeezed.phi_j, "phi_j": onset.phi_j, "dphi": dphi, "v_target": v_target},
                     lammps_version=squeezed.lammps_version)
        print(f"{path.name}: phi = {squeezed.phi_j:.6f}, V = {squeezed.energy_per_particle:.3e}, "
              f"P = {squeezed.pressure:.3e}; onset of this state phi_J = {onset.phi_j:.6f}: "
              f"Delta phi = {dphi:.4e} ({time.perf_counter() - t0:.1f} s)", flush=True)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("kind", choices=("disks", "spheres"))
    parser.add_argument("--n", type=int, default=1024)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0])
    parser.add_argument("--v-target", type=float, default=2.8e-5,
                        help="spheres: energy per particle window (V, 2V); 2.8e-5 gave Delta phi ~ 1e-2 at N = 256")
    parser.add_argument("--dir", type=Path, default=Path("/tmp/jamflow-structure-data"))
    args = parser.parse_args(argv)
    args.dir.mkdir(parents=True, exist_ok=True)
    if args.kind == "disks":
        make_disks(args.dir, args.n, args.seeds)
    else:
        make_spheres(args.dir, args.n, args.seeds, args.v_target)


if __name__ == "__main__":
    main()
