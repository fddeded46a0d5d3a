"""Draw a packing (PNG, SVG or PDF): particles to scale in the periodic cell, contacts as lines with width
proportional to the contact force, floaters hatched, colour by contact number z, local Q6 or
director angle; rigid bodies drawn site by site.
Spheres are drawn as a slice: the cross-sections of the spheres cut by the plane at height
--slice (a fraction of the cell height), with the contacts between cut spheres projected.
IN is a jamflow packing or a LAMMPS data / dump file (the dump's last frame)."""

from __future__ import annotations

from pathlib import Path

from jamflow.cli.inputs import add_input_arguments, load_input, parse_diameters
from jamflow.cli.options import add_force_argument
from jamflow.plots.drawing import COLOR_BY, draw_packing
from jamflow.plots.figure import figure_format
from jamflow.support.files import check_writable, replacing


def add_arguments(p) -> None:
    p.add_argument("file", metavar="IN", help="packing file (jamflow jam --out), LAMMPS data or dump file")
    p.add_argument("-o", "--out", default=None,
                   help="figure to write, PNG, SVG or PDF by its suffix (default: IN.png beside the input)")
    p.add_argument("--color-by", choices=COLOR_BY, default="z", help="colour by contact number, local |Q6| or (particles that turn) director angle")
    p.add_argument("--q6-r-min", type=float, default=None,
                   help="Q6 neighbour cutoff, units of <sigma^2>^1/2 (default: first minimum of g(r))")
    p.add_argument("--slice", type=float, default=0.5, help="3D: height of the slice, fraction of the cell height")
    add_input_arguments(p, dump="its last frame is drawn")
    add_force_argument(p, "replace an --out that is a symlink, device or read-only file")


def run(args) -> int:
    out = Path(args.out) if args.out else Path(args.file).with_suffix(".png")
    figure_format(out)  # the suffix picks PNG, SVG or PDF; another is refused before work
    check_writable(out, args.force, "--out")
    packing = load_input(args.file, args.format, parse_diameters(args.diameters), args.dim)
    with replacing([out] if args.force else []):
        draw_packing(packing, out, color_by=args.color_by, slice_at=args.slice, q6_r_min=args.q6_r_min)
    print(f"{args.file}: {packing.n} {packing.shape.name(packing.dim)} particles -> {out}")
    return 0
