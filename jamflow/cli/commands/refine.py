"""Refine a jammed packing of disks or spheres (linear spring, periodic orthogonal box) in
double-double arithmetic and walk it to the target pressure P (see the docs, guide/precision):
Newton steps on its contact network with residual forces, overlaps and the virial in double-double,
the box and positions dilated affinely between pressures. The output packing file carries
positions_lo and box_lo beside positions and box (true value = hi + lo) and precision =
"double-double"; its checks group holds the double-double force balance and contact count. A target
below what double-double resolves at that N is refused before any work with the smallest that works."""

from __future__ import annotations

import time

from jamflow.io.names import check_packing_name
from jamflow.support.files import check_not_input, check_writable


def add_arguments(p) -> None:
    p.add_argument("packing", metavar="IN.h5", help="a jammed packing file (jamflow jam --out, or a refined one)")
    p.add_argument("--pressure", type=float, required=True, metavar="P",
                   help="target pressure (eps/diameter^d), down to ~2e-18 for 2D disks at N ~ 300 (lower with a larger --force-tol)")
    p.add_argument("--out", required=True, metavar="OUT.h5", help="output packing file")
    p.add_argument("--force-tol", type=float, default=1e-12,
                   help="converged when the largest net force on a non-floater is below this times the mean "
                        "contact force")
    p.add_argument("--force", action="store_true",
                   help="replace an --out that is a symlink, device node or read-only file")


def run(args) -> int:
    from jamflow.io.packing_file import load_packing, save_refined
    from jamflow.protocols.refine import RefineSettings, refine

    check_packing_name(args.out)  # x.shear.h5 would be skipped or refused by every reader of packings
    check_writable(args.out, args.force, "--out")
    check_not_input(args.out, [args.packing])
    settings = RefineSettings(args.pressure, force_tol=args.force_tol)
    packing = load_packing(args.packing)
    t0 = time.perf_counter()
    result = refine(packing, args.pressure, settings=settings)
    save_refined(result, args.out, force=args.force)
    print(f"{result.summary()}  -> {args.out} ({time.perf_counter() - t0:.2f} s)")
    return 0
