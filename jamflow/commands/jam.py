"""Jam N disks (2D) or spheres (3D) at onset by isotropic compression (seed section 2.1)
and write the packing as HDF5 (schema: jamflow/io.py)."""

from __future__ import annotations

import math
import time

from ..engine.select import ENGINES, engine_name
from ..io import check_writable, save_packing
from ..minimize import METHODS, MinimizerSettings
from ..protocols.compression import DEFAULT_PROTOCOL, PROTOCOLS, CompressionSettings, initial_packing, jam
from ..progress import CompressionProgress


def add_arguments(p) -> None:
    p.add_argument("--dim", type=int, choices=(2, 3), default=2, help="spatial dimension")
    p.add_argument("--n", type=int, default=64, help="number of particles")
    p.add_argument("--sizes", default="bi:1.4:0.5",
                   help="mono | bi:RATIO:FRACTION_SMALL | poly-uniform:WIDTH | poly-normal:WIDTH | poly-lognormal:WIDTH")
    p.add_argument("--potential", default="spring", help="spring | hertz | spring:ALPHA | rlj")
    p.add_argument("--protocol", choices=sorted(PROTOCOLS), default=None,
                   help=f"seed: the chapter's constant-increment bisection; fast: the same stopping rule with "
                        f"growing increments and Newton jumps (docs/speed.md). Default {DEFAULT_PROTOCOL}; "
                        "seed with --emit-deck (decks run the seed protocol)")
    p.add_argument("--minimizer", choices=METHODS, default="fire", help="energy minimiser")
    p.add_argument("--engine", choices=ENGINES, default="auto",
                   help="auto: compiled FIRE for springs in orthogonal boxes, else LAMMPS (docs/speed.md)")
    p.add_argument("--phi0", type=float, default=None, help="initial packing fraction (default 0.80 in 2D, 0.55 in 3D)")
    p.add_argument("--dphi0", type=float, default=1e-4, help="initial packing-fraction increment")
    p.add_argument("--vtol", type=float, default=1e-16, help="energy window V_tol < V < 2 V_tol (per particle)")
    p.add_argument("--ftol", type=float, default=None, help="max force component tolerance (default scales with box)")
    p.add_argument("--seed", type=int, default=0, help="random seed of the initial positions and sizes")
    p.add_argument("--out", default="packing.h5", help="output HDF5 file")
    p.add_argument("--quiet", action="store_true", help="no progress display")
    p.add_argument("--emit-deck", default=None, metavar="DECK.lmp",
                   help="write the LAMMPS deck that runs this jam in lmp alone (and its start, DECK.start.data) "
                        "instead of running it; then: cd DIR && lmp -in DECK.lmp")


def settings_from_args(args) -> CompressionSettings:
    for name in ("phi0", "dphi0", "vtol"):
        value = getattr(args, name)
        if value is not None and (not math.isfinite(value) or value <= 0):
            raise ValueError(f"--{name} must be a finite positive number, got {value}")
    minimizer = MinimizerSettings(method=args.minimizer, force_tol=args.ftol, v_min=args.vtol)
    protocol = args.protocol or ("seed" if args.emit_deck else DEFAULT_PROTOCOL)
    return PROTOCOLS[protocol](phi0=args.phi0, dphi0=args.dphi0, v_tol=args.vtol, minimizer=minimizer)


def prepare(args):
    """Validated settings and random start from parsed options, before any work."""
    settings = settings_from_args(args)
    start = initial_packing(args.n, args.dim, args.sizes, args.potential, args.seed, settings.start_phi(args.dim))
    engine_name(start, args.minimizer, args.engine)  # refuse --engine numba where it cannot run, before work
    return settings, start


def jam_from_args(args, observers=(), engine_options=None):
    """The jam that parsed options ask for (shared by ``jamflow jam`` and ``jamflow ensemble``)."""
    settings, start = prepare(args)
    return jam(start=start, settings=settings, observers=observers, engine=args.engine, engine_options=engine_options)


def save_result(path, result, **run_info):
    """Write a JamResult as a packing file; ``run_info`` (e.g. seconds) joins the protocol attributes."""
    return save_packing(path, result.packing, energy_per_particle=result.energy_per_particle,
                        pressure_tensor=result.pressure_tensor,
                        protocol={**result.settings.as_dict(), "engine": result.engine, **run_info},
                        history=result.history, lammps_version=result.lammps_version)


def run(args) -> int:
    check_writable(args.out)
    if args.emit_deck:
        settings, start = prepare(args)
        return emit(args, start, settings)
    t0 = time.perf_counter()
    with CompressionProgress(disable=args.quiet) as progress:
        result = jam_from_args(args, observers=[progress])
    save_result(args.out, result)
    print(f"{result.summary()}  -> {args.out} ({time.perf_counter() - t0:.2f} s)")
    return 0


def emit(args, start, settings) -> int:
    """--emit-deck: the deck and start data file, no LAMMPS run."""
    from pathlib import Path

    from ..deck import emit_deck

    check_writable(args.emit_deck)
    deck, data = emit_deck(args.emit_deck, start, settings, out=Path(args.out).stem)
    print(f"wrote {deck} and {data}; run: cd {deck.parent} && lmp -in {deck.name}  "
          f"(writes {Path(args.out).stem}.data and {Path(args.out).stem}.protocol.txt)")
    return 0
