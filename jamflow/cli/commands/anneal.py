"""Particle-shape annealing (chapter section 2.3.3, Figure 2.18): grow the aspect ratio of the
particles of a jammed disk/sphere packing IN.h5 to ALPHA in steps of D, re-jamming at every
step (random major-axis directions at the first one, all along x with --orientations aligned, or
in a cone about x with --orientations nematic:S). The last packing is written to --out
(checked like jamflow jam's), with one row per step (phi_J, <z>, floaters, ...) in its
``anneal`` group; docs/notes/ellipses.md compares the result with compression."""

from __future__ import annotations

import time


from jamflow.cli.options import add_engine_argument, add_force_argument, add_quiet_argument, add_vtol_argument
from jamflow.io.names import check_packing_name
from jamflow.support.files import check_not_input, check_writable, replacing
from jamflow.io.packing_file import load_packing, save_packing
from jamflow.minimize.settings import MinimizerSettings
from jamflow.cli.progress import progress_bar
from jamflow.protocols.anneal import anneal, anneal_alphas, check_anneal
from jamflow.protocols.settings import DEFAULT_PROTOCOL, PROTOCOL_NAMES, PROTOCOLS, protocol_settings
from jamflow.protocols.compression import MAX_SEED
from jamflow.model.shapes.contact_distance import METHODS as METHODS_CONTACT
from jamflow.model.shapes.rotations import START_ORIENTATIONS


def add_arguments(p) -> None:
    p.add_argument("input", metavar="IN.h5", help="a jammed packing of disks/spheres (jamflow jam --out)")
    p.add_argument("--to", type=float, required=True, metavar="ALPHA",
                   help="final aspect ratio a/b (ellipses: > 1; spheroids: > 1 prolate, < 1 oblate)")
    p.add_argument("--dalpha", type=float, required=True, metavar="D",
                   help="aspect-ratio step (the chapter: 0.05 and 0.005)")
    p.add_argument("--contact", choices=METHODS_CONTACT, default=None,
                   help="contact distance (default: the input's, exact for disks/spheres)")
    p.add_argument("--seed", type=int, default=0, help="random seed of the first step's major-axis directions")
    p.add_argument("--orientations", default="random", metavar="{" + ",".join(START_ORIENTATIONS) + "}",
                   help="the first step's major-axis directions: random (uniform), aligned (all along x: a "
                        "nematic start, Figure 2.23(c), docs/validation.md) or nematic:S (in a cone about x, "
                        "P2 = S in (0, 1])")
    p.add_argument("--protocol", choices=PROTOCOL_NAMES, default=DEFAULT_PROTOCOL,
                   metavar="{" + ",".join(sorted(PROTOCOLS)) + "}",
                   help="compression protocol of each re-jam (jamflow jam --protocol)")
    add_vtol_argument(p)
    add_engine_argument(p, help="engine of each re-jam (FIRE: the compiled one)")
    p.add_argument("--out", required=True, help="output HDF5 file (the last packing and the per-step table)")
    add_force_argument(p, "replace an --out that is a symlink, device or read-only file")
    add_quiet_argument(p)


def run(args) -> int:
    check_packing_name(args.out)  # x.shear.h5 would be skipped or refused by every reader of packings
    check_writable(args.out, args.force, "--out")
    check_not_input(args.out, [args.input])
    if not 0 <= args.seed <= MAX_SEED:
        raise ValueError(f"--seed must be a non-negative integer below 2^63 (it is stored as int64), got {args.seed}")
    if not (args.vtol > 0 and args.vtol < 1):
        raise ValueError(f"--vtol must be a positive number below 1, got {args.vtol}")
    start = load_packing(args.input)
    alpha0 = check_anneal(start, args.to, args.dalpha, args.contact, args.orientations)
    settings = protocol_settings(args.protocol, v_tol=args.vtol, minimizer=MinimizerSettings(v_min=args.vtol))
    steps = len(anneal_alphas(alpha0, args.to, args.dalpha))
    t0 = time.perf_counter()
    with progress_bar(total=steps, desc="anneal", unit="step", disable=args.quiet) as bar:
        def progress(row):
            bar.set_postfix_str(f"alpha={row['alpha']:g} phi_J={row['phi_j']:.6f} <z>={row['mean_z']:.3f}",
                                refresh=False)
            bar.update(1)

        result = anneal(start, args.to, args.dalpha, settings, seed=args.seed, contact=args.contact,
                        engine=args.engine, observers=[progress], orientations=args.orientations)
    final = result.final
    protocol = {**final.settings.as_dict(), "engine": final.engine, "anneal_input": str(args.input),
                "anneal_to": float(args.to), "anneal_dalpha": float(args.dalpha), "anneal_seed": int(args.seed),
                "anneal_orientations": args.orientations}
    with replacing([args.out] if args.force else []):
        save_packing(args.out, final.packing, energy_per_particle=final.energy_per_particle,
                     pressure_tensor=final.pressure_tensor, protocol=protocol, history=final.history,
                     lammps_version=final.lammps_version, checks=result.checks, tables={"anneal": result.steps})
    s = result.steps
    print(f"annealed {alpha0:g} -> {args.to:g} in {steps} steps: phi_J = {final.phi_j:.10f}, <z> = "
          f"{s['mean_z'][-1]:.4f}, {int(s['n_floaters'][-1])} floaters  -> {args.out} "
          f"({time.perf_counter() - t0:.1f} s)")
    return 0
