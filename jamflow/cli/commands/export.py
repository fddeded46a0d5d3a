"""Write a packing in a format OVITO (and other viewers) open with particle radii, shapes and
orientations: a LAMMPS text dump (id type x y z radius [shape, quaternion | mol], triclinic box
bounds) or extended XYZ (Lattice, pbc, species, pos, radius, ...); or as a LAMMPS data file
(atom_style sphere, ellipsoid or hybrid sphere molecular) to start a simulation from; or one
frame of a HOOMD-blue GSD file (jamflow.io.gsd_file). Rigid bodies
are written one row per site. Positions at full float64 precision; 2D packings get z = 0 (see
jamflow.io.export)."""

from __future__ import annotations

from pathlib import Path

from jamflow.cli.options import add_force_argument
from jamflow.io.export import FORMATS, SUFFIXES, export_packing
from jamflow.io.gsd_file import gsd_module
from jamflow.support.files import check_writable, replacing
from jamflow.io.packing_file import load_packing


def add_arguments(p) -> None:
    p.add_argument("file", metavar="IN.h5", help="packing file (jamflow jam --out)")
    p.add_argument("--format", choices=FORMATS, required=True, help="lammps-dump (.dump), extended XYZ (.xyz), lammps-data (.data, a LAMMPS data file) or "
                        "gsd (.gsd, HOOMD-blue; needs pip install 'jamflow[gsd]')")
    p.add_argument("-o", "--out", default=None, help="file to write (default: IN with the format's suffix)")
    add_force_argument(p, "replace an --out that is a symlink, device or read-only file")


def run(args) -> int:
    if args.format == "gsd":
        gsd_module()  # a missing gsd package is refused before work, naming the extra
    out = Path(args.out) if args.out else Path(args.file).with_suffix(SUFFIXES[args.format])
    check_writable(out, args.force, "--out")
    packing = load_packing(args.file)
    with replacing([out] if args.force else []):
        export_packing(packing, out, args.format)
    print(f"{args.file}: {packing.n} particles -> {out} ({args.format})")
    return 0
