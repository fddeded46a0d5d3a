"""Jam N particles (disks, spheres, or the shapes of ``--shape``) at onset by isotropic
compression (seed section 2.1) and write the packing as HDF5 (schema: jamflow/io.py).
With --walls the box is bounded by walls on those axes (smooth or rough); with --gravity the
particles settle on the floor instead; with --pressure the box relaxes to a target pressure
(seed section 2.3, jamflow/walls.py, jamflow/protocols/gravity.py, pressure.py). With --above
DPHI the onset packing is compressed affinely by DPHI and minimised again, and that packing is
written (attribute dphi_above; the state jamflow moduli measures, seed section 4.5)."""

from __future__ import annotations

import math
import time

from ..engine.base import ENGINES, engine_name
from ..io import check_writable, save_packing
from ..minimize import METHODS, MinimizerSettings
from ..protocols.compression import (DEFAULT_PROTOCOL, PROTOCOLS, CompressionSettings, JammingFailed,
                                     initial_packing, jam)
from ..progress import CompressionProgress
from ..protocols.above import check_dphi, compress_above
from ..walls import WALL_TYPES, wall_loads


def add_arguments(p) -> None:
    p.add_argument("--dim", type=int, choices=(2, 3), default=2, help="spatial dimension")
    p.add_argument("--n", type=int, default=64, help="number of particles")
    p.add_argument("--sizes", default="bi:1.4:0.5",
                   help="mono | bi:RATIO:FRACTION_SMALL | poly-uniform:WIDTH | poly-normal:WIDTH | poly-lognormal:WIDTH")
    p.add_argument("--potential", default="spring", help="spring | hertz | spring:ALPHA | rlj")
    p.add_argument("--shape", default="disk", help="particle shape: disk | sphere (the same: round particles); "
                   "--sizes scales whole particles")
    p.add_argument("--protocol", choices=sorted(PROTOCOLS), default=None,
                   help=f"seed: the chapter's constant-increment bisection; fast: the same stopping rule with "
                        f"growing increments and Newton jumps (docs/speed.md). Default {DEFAULT_PROTOCOL}; "
                        "seed with --emit-deck (decks run the seed protocol)")
    p.add_argument("--minimizer", choices=METHODS, default="fire", help="energy minimiser")
    p.add_argument("--engine", choices=ENGINES, default="auto",
                   help="auto: the compiled engine (FIRE, in process) wherever it runs the scene, else LAMMPS "
                        "(docs/speed.md). The engines sum forces in different orders, so from one start they "
                        "can reach different minima")
    p.add_argument("--phi0", type=float, default=None, help="initial packing fraction (default 0.80 in 2D, 0.55 in 3D)")
    p.add_argument("--dphi0", type=float, default=1e-4, help="initial packing-fraction increment")
    p.add_argument("--vtol", type=float, default=1e-16, help="energy window V_tol < V < 2 V_tol (per particle)")
    p.add_argument("--ftol", type=float, default=None, help="max force component tolerance (default scales with box)")
    p.add_argument("--seed", type=int, default=0, help="random seed of the initial positions and sizes")
    p.add_argument("--above", type=float, default=None, metavar="DPHI",
                   help="write the packing compressed from its onset by DPHI (phi_J -> phi_J + DPHI, affine) and "
                        "minimised again (attribute dphi_above): the state jamflow moduli measures")
    p.add_argument("--walls", default=None, metavar="AXES",
                   help="walls on these axes (y, x,y, x,y,z): flat walls at both faces, the particles' own law at "
                        "contact distance a_i/2; periodic along the others; phi between the walls")
    p.add_argument("--wall-type", choices=WALL_TYPES, default="smooth",
                   help="smooth: flat walls; rough: rows of fixed particles of the small diameter on the walls")
    p.add_argument("--gravity", type=float, default=0.0, metavar="G",
                   help="settle under gravity G (force per particle along -y in 2D, -z in 3D) on a floor: needs "
                        "--walls y (2D) / z (3D); default phi0 0.5 (2D), 0.35 (3D)")
    p.add_argument("--pressure", type=float, default=None, metavar="P",
                   help="jam at target pressure P with the box as a degree of freedom (enthalpy minimisation), "
                        "reached through decades from 1e-4; FIRE in the compiled engine, CG with fix box/relax in LAMMPS")
    p.add_argument("--stress", choices=("iso", "aniso", "tri"), default="iso",
                   help="with --pressure: iso (box shape kept), aniso (each P_aa = P), tri (shear stresses relaxed to "
                        "0 too: the box tilts)")
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


def check_boundary_args(args) -> None:
    """Refuse bad --gravity / --pressure combinations before any work."""
    if not math.isfinite(args.gravity) or args.gravity < 0:
        raise ValueError(f"--gravity must be a finite number >= 0, got {args.gravity}")
    if args.pressure is not None:
        if not math.isfinite(args.pressure) or args.pressure <= 0:
            raise ValueError(f"--pressure must be a finite positive number, got {args.pressure}")
        if args.walls or args.gravity:
            raise ValueError("--pressure relaxes a periodic box: it does not combine with --walls or --gravity")
    if args.emit_deck and (args.pressure is not None or args.gravity or args.wall_type == "rough"):
        raise ValueError("--emit-deck writes the compression deck (smooth walls at most); the constant-pressure deck "
                         "is lammps_inputs/pressure.lmp")
    if args.above is not None:
        check_dphi(args.above, 0.0)  # not finite, not positive, >= 1: refused before any work
        if args.pressure is not None or args.gravity or args.emit_deck:
            raise ValueError("--above compresses the onset packing at a fixed box: it does not combine with "
                             "--pressure, --gravity or --emit-deck")


def run(args) -> int:
    check_boundary_args(args)
    settings = settings_from_args(args)
    check_writable(args.out)
    start = initial_packing(args.n, args.dim, args.sizes, args.potential, args.seed,
                            settings.start_phi(args.dim, args.gravity), args.shape, args.walls, args.wall_type,
                            args.gravity)
    if args.pressure is not None:
        return run_pressure(args, start, settings)
    engine_name(start, args.minimizer, args.engine)  # refuse --engine numba where it cannot run, before work
    if args.emit_deck:
        return emit(args, start, settings)
    t0 = time.perf_counter()
    with CompressionProgress(disable=args.quiet) as progress:
        result = jam(start=start, settings=settings, observers=[progress], engine=args.engine)
    if args.above is not None:
        return save_above(args, result, settings, t0)
    save_packing(args.out, result.packing, energy_per_particle=result.energy_per_particle,
                 pressure_tensor=result.pressure_tensor, protocol={**settings.as_dict(), "engine": result.engine},
                 history=result.history, lammps_version=result.lammps_version, wall_forces=result.wall_forces)
    print(f"{result.summary()}  -> {args.out} ({time.perf_counter() - t0:.2f} s)")
    return 0


def save_above(args, result, settings, t0) -> int:
    """--above: compress the onset packing by DPHI, minimise, write that packing; the onset's
    phi_J and the minimisation's stop are in the protocol group, its history is the onset's."""
    try:
        above = compress_above(result.packing, args.above, settings.minimizer, engine=args.engine)
    except JammingFailed as err:
        raise ValueError(f"{err} (onset phi_J = {result.phi_j:.10f}; nothing written)") from None
    protocol = {**settings.as_dict(), "engine": above.engine, "phi_onset": result.phi_j, "above_dphi": above.dphi,
                "above_reason": above.minimization.reason, "above_iterations": above.minimization.iterations}
    wall_forces = wall_loads(above.packing) if above.packing.box.walls else None
    save_packing(args.out, above.packing, energy_per_particle=above.energy_per_particle,
                 pressure_tensor=above.pressure_tensor, protocol=protocol, history=result.history,
                 lammps_version=result.lammps_version, wall_forces=wall_forces, dphi_above=above.dphi)
    print(result.summary())
    print(f"{above.summary()}  -> {args.out} ({time.perf_counter() - t0:.2f} s)")
    return 0


def run_pressure(args, start, settings) -> int:
    """--pressure: the enthalpy minimisations of jamflow.protocols.pressure from the random start."""
    from ..protocols.pressure import PressureSettings, check_pressure_start, jam_at_pressure, pressure_sequence

    psettings = PressureSettings(pressure_sequence(args.pressure), args.stress, settings.minimizer)
    check_pressure_start(start, psettings)
    engine_name(start, args.minimizer, args.engine, pressure=True)
    t0 = time.perf_counter()
    with CompressionProgress(disable=args.quiet) as progress:
        result = jam_at_pressure(start, psettings, observers=[progress], engine=args.engine)
    save_packing(args.out, result.packing, energy_per_particle=result.energy_per_particle,
                 pressure_tensor=result.pressure_tensor, protocol={**psettings.as_dict(), "engine": result.engine},
                 history=result.history, lammps_version=result.lammps_version, target_pressure=args.pressure,
                 stress=args.stress)
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
