"""Jam N particles (disks, spheres, or the shapes of ``--shape``) at onset by isotropic
compression (seed section 2.1) and write the packing as HDF5 (schema: jamflow/io/packing_file.py).
With --walls the box is bounded by walls on those axes (smooth or rough); with --gravity the
particles settle on the floor instead; with --pressure the box relaxes to a target pressure
(seed section 2.3, jamflow/model/walls.py, jamflow/protocols/gravity.py, pressure.py); with --gamma the
periodic cell is sheared to that fixed Lees-Edwards strain (section 2.2, docs/shear.md). With --above
DPHI the onset packing is compressed affinely by DPHI and minimised again, and that packing is
written (attribute dphi_above; the state jamflow moduli measures, seed section 4.5)."""

from __future__ import annotations

import math
import time

from jamflow.engines.choose import ENGINES, engine_name
from jamflow.support.files import check_writable, replacing
from jamflow.io.packing_file import save_packing
from jamflow.minimize.settings import CREEP_METHODS, MD_DAMPINGS, METHODS, MinimizerSettings
from jamflow.protocols.settings import DEFAULT_PROTOCOL, PROTOCOLS, CompressionSettings
from jamflow.protocols.outcome import JammingFailed
from jamflow.protocols.compression import (at_shear_strain, check_resolution, initial_packing, jam,
                                           with_accumulated_strain)
from jamflow.cli.progress import CompressionProgress
from jamflow.protocols.above import check_dphi, compress_above
from jamflow.model.shapes.contact_distance import METHODS as METHODS_CONTACT
from jamflow.model.shapes.parse import parse_shape
from jamflow.model.walls import WALL_TYPES, wall_loads


def add_arguments(p) -> None:
    p.add_argument("--dim", type=int, choices=(2, 3), default=2, help="spatial dimension")
    p.add_argument("--n", type=int, default=64, help="number of particles")
    p.add_argument("--sizes", default="bi:1.4:0.5",
                   help="mono | bi:RATIO:FRACTION_SMALL | poly-uniform:WIDTH | poly-normal:WIDTH | poly-lognormal:WIDTH")
    p.add_argument("--potential", default="spring", help="spring | hertz | spring:ALPHA | rlj")
    p.add_argument("--shape", default="disk", help="particle shape: disk | sphere (the same: round particles) | "
                   "ellipse:ALPHA (2D, ALPHA = a/b >= 1) | spheroid:ALPHA (3D, ALPHA < 1 oblate); ALPHA = 1 is the "
                   "disk/sphere | rigid n-mers of fused sites (docs/nmers.md): nmer:N:ALPHA (linear, ALPHA = L/D), "
                   "dimer:ALPHA:S (asymmetric, S = D2/D1), trimer:ALPHA:C (bent, C = h/L). --sizes scales whole "
                   "particles (b; a = ALPHA b)")
    p.add_argument("--contact", choices=METHODS_CONTACT, default="exact",
                   help="contact distance of ellipses/spheroids (seed section 2.3.2): exact (Perram-Wertheim), "
                        "gaussian (equal sizes only), cleaver, linear, quadratic (3D: equal sizes only); "
                        "docs/contact-distance.md")
    p.add_argument("--protocol", choices=sorted(PROTOCOLS), default=None,
                   help=f"seed: the chapter's constant-increment bisection; fast: the same stopping rule with "
                        f"growing increments and Newton jumps (docs/speed.md). Default {DEFAULT_PROTOCOL}; "
                        "seed with --emit-deck (decks run the seed protocol)")
    p.add_argument("--minimizer", choices=METHODS, default="fire",
                   help="energy minimiser; ellipses/spheroids: fire (compiled engine, over positions and "
                        "orientations) or md (LAMMPS damped dynamics with rotations; no LAMMPS minimiser turns them); "
                        "rigid bodies in LAMMPS: md (damped rigid-body dynamics)")
    p.add_argument("--damping", type=float, default=MinimizerSettings().damping,
                   help="md only: drag coefficient (sqrt(m eps)/diameter); rigid bodies: damping time 1/DAMPING")
    add_md_damping_argument(p)
    p.add_argument("--creep", choices=CREEP_METHODS, default="auto",
                   help="what a creeping minimisation (unconverged after 20 000+ iterations near balance) does between FIRE "
                        "windows: soft-modes (Newton steps along its softest modes, docs/soft-modes.md), polish "
                        "(Gauss-Newton active-set steps, disks/spheres and rigid bodies with the linear spring, "
                        "docs/speed-2.md section 8, docs/nmers.md), off; auto: polish for rigid bodies and 2D disks, "
                        "soft-modes for ellipses and spheroids, in the compiled engine")
    p.add_argument("--engine", choices=ENGINES, default="auto",
                   help="auto: the compiled engine (FIRE, in process) wherever it runs the scene, else LAMMPS "
                        "(docs/speed.md). The engines sum forces in different orders, so from one start they "
                        "can reach different minima and phi_J (seed 0, N = 64: 0.8352519 numba, 0.8355434 lammps)")
    p.add_argument("--phi0", type=float, default=None, help="initial packing fraction (default 0.80 in 2D, 0.55 in 3D; rigid bodies, which "
                        "start without overlaps, 0.45 and 0.25)")
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
    p.add_argument("--gamma", type=float, default=None,
                   help="jam at this fixed Lees-Edwards shear strain (any finite value; seed section 2.2)")
    p.add_argument("--out", default="packing.h5", help="output HDF5 file")
    p.add_argument("--force", action="store_true",
                   help="replace an --out (or --emit-deck files) that is a symlink, device node or read-only file")
    p.add_argument("--quiet", action="store_true", help="no progress display")
    p.add_argument("--emit-deck", default=None, metavar="DECK.lmp",
                   help="write the LAMMPS deck that runs this jam in lmp alone (and its start, DECK.start.data) "
                        "instead of running it; then: cd DIR && lmp -in DECK.lmp")


def add_md_damping_argument(p) -> None:
    p.add_argument("--md-damping", choices=MD_DAMPINGS, default="viscous",
                   help="--minimizer md only: viscous (drag -b v on every particle) or pairwise (seed eq. 2.3: "
                        "-b (v_ij . rhat) rhat on contacting pairs; docs/damped-md.md)")


def settings_from_args(args) -> CompressionSettings:
    for name in ("phi0", "dphi0", "vtol"):
        value = getattr(args, name)
        if value is not None and (not math.isfinite(value) or value <= 0):
            raise ValueError(f"--{name} must be a finite positive number, got {value}")
    if args.md_damping != "viscous" and args.minimizer != "md":
        raise ValueError(f"--md-damping {args.md_damping} applies to --minimizer md only, not {args.minimizer}")
    minimizer = MinimizerSettings(method=args.minimizer, force_tol=args.ftol, v_min=args.vtol,
                                  damping=getattr(args, "damping", MinimizerSettings().damping),  # crosscheck: none
                                  md_damping=args.md_damping, creep=getattr(args, "creep", "auto"))
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
    above = getattr(args, "above", None)  # jamflow ensemble has no --above
    if above is not None:
        check_dphi(above, 0.0)  # not finite, not positive, >= 1: refused before any work
        if args.pressure is not None or args.gravity or args.emit_deck:
            raise ValueError("--above compresses the onset packing at a fixed box: it does not combine with "
                             "--pressure, --gravity or --emit-deck")


def check_contact_arg(args) -> None:
    """Refuse a --contact method other than the default for a shape that has no contact-distance
    approximation (disks, spheres, ellipse:1, rigid bodies of spherical sites): it would be ignored."""
    if args.contact == "exact":
        return
    shape = parse_shape(args.shape, args.dim)
    if shape.kind != "ellipsoid":
        raise ValueError(f"--contact {args.contact} applies to ellipses/spheroids (--shape ellipse:ALPHA or "
                         f"spheroid:ALPHA, ALPHA != 1), not to {shape.name(args.dim)} particles: leave --contact out")


def prepare(args):
    """Validated settings and random start from parsed options: every refusal comes here,
    before any work (shared by ``jamflow jam`` and ``jamflow ensemble``)."""
    check_boundary_args(args)
    check_contact_arg(args)
    settings = settings_from_args(args)
    gamma = getattr(args, "gamma", None)
    if gamma is not None and args.pressure is not None:
        raise ValueError("--gamma fixes the shear strain, --pressure relaxes the box: use one of them")
    start = initial_packing(args.n, args.dim, args.sizes, args.potential, args.seed,
                            settings.start_phi(args.dim, args.gravity, args.shape), args.shape, args.walls, args.wall_type,
                            args.gravity, args.contact)
    if gamma is not None:
        start = at_shear_strain(start, gamma)  # refuses a strain that is not finite, or walls with a shear
    if args.pressure is not None:
        from jamflow.protocols.pressure import PressureSettings, check_pressure_start, pressure_sequence

        psettings = PressureSettings(pressure_sequence(args.pressure), args.stress, settings.minimizer)
        check_pressure_start(start, psettings)
        engine_name(start, args.minimizer, args.engine, pressure=True)
        return psettings, start
    engine_name(start, args.minimizer, args.engine)  # refuse an engine that cannot run the scene, before work
    if start.shape.kind == "rigid" and settings.minimizer.md_damping != "viscous":
        raise ValueError(f"--md-damping {settings.minimizer.md_damping} is for disks and spheres: rigid bodies are "
                         "damped by fix rigid langevin (set its rate with --damping)")
    check_resolution(start, settings)
    return settings, start


def jam_from_args(args, observers=(), engine_options=None):
    """(result, checks) of the jam the parsed options ask for; JammingFailed if the protocol
    fails or the packing fails its checks (``checked``), so nothing unchecked is written."""
    settings, start = prepare(args)
    if args.pressure is not None:
        from jamflow.protocols.pressure import jam_at_pressure

        result = jam_at_pressure(start, settings, observers=observers, engine=args.engine,
                                 engine_options=engine_options)
        return result, checked(result, settings.minimizer, None, args.out)
    result = jam(start=start, settings=settings, observers=observers, engine=args.engine,
                 engine_options=engine_options)
    if getattr(args, "gamma", None) is not None:
        result = with_accumulated_strain(result, args.gamma)  # the file's gamma: the accumulated strain
    window = None if args.gravity else settings.v_tol  # a pile under gravity has no energy window
    return result, checked(result, settings.minimizer, window, args.out)


def save_result(path, result, checks, args, **run_info):
    """Write a checked result as a packing file; ``run_info`` (e.g. seconds) joins the protocol
    attributes; ``args.force`` lets it replace a symlink, device or read-only file."""
    with replacing([path] if getattr(args, "force", False) else []):
        return save_packing(path, result.packing, energy_per_particle=result.energy_per_particle,
                            pressure_tensor=result.pressure_tensor,
                            protocol={**result.settings.as_dict(), "engine": result.engine, **run_info},
                            history=result.history, lammps_version=result.lammps_version,
                            wall_forces=getattr(result, "wall_forces", None), target_pressure=args.pressure,
                            stress=args.stress if args.pressure is not None else None, checks=checks)


def run(args) -> int:
    check_writable(args.out, args.force)
    if args.emit_deck:
        settings, start = prepare(args)
        return emit(args, start, settings)
    t0 = time.perf_counter()
    with CompressionProgress(disable=args.quiet) as progress:
        result, checks = jam_from_args(args, observers=[progress])
    if getattr(args, "above", None) is not None:
        return save_above(args, result, t0)
    save_result(args.out, result, checks, args)
    print(f"{result.summary()}  -> {args.out} ({time.perf_counter() - t0:.2f} s)")
    return 0


def checked(result, minimizer, v_tol, out):
    """The packing checks of a result; JammingFailed (nothing written) if any fails.
    ``v_tol`` None skips the energy-window check (piles under gravity, constant pressure)."""
    from jamflow.mechanics.checks import check_packing  # imported here: its pair search (scipy.spatial) is not needed for --help

    packing = result.packing
    ftol = minimizer.force_tol_for(packing)
    checks = check_packing(packing, result.energy_per_particle, None, v_tol, ftol)
    if not checks.passed:
        reason = result.history["reason"][-1].decode()
        remedy = ("a larger --vtol (stronger contacts) or another --minimizer" if not checks.force_balanced else
                  "a larger --vtol: the contacts at this one are near round-off")
        raise JammingFailed(f"the packing at phi_J = {result.phi_j:.10f} failed its checks: "
                            f"{'; '.join(checks.problems())} (final minimisation stopped by '{reason}'). Nothing "
                            f"was written to {out}; use {remedy}")
    return checks


def save_above(args, result, t0) -> int:
    """--above: compress the checked onset packing by DPHI, minimise, write that packing; the
    onset's phi_J and the minimisation's stop are in the protocol group, its history is the onset's."""
    settings = result.settings
    try:
        above = compress_above(result.packing, args.above, settings.minimizer, engine=args.engine)
    except JammingFailed as err:
        raise ValueError(f"{err} (onset phi_J = {result.phi_j:.10f}; nothing written)") from None
    protocol = {**settings.as_dict(), "engine": above.engine, "phi_onset": result.phi_j, "above_dphi": above.dphi,
                "above_reason": above.minimization.reason, "above_iterations": above.minimization.iterations}
    wall_forces = wall_loads(above.packing) if above.packing.box.walls else None
    with replacing([args.out] if getattr(args, "force", False) else []):
        save_packing(args.out, above.packing, energy_per_particle=above.energy_per_particle,
                     pressure_tensor=above.pressure_tensor, protocol=protocol, history=result.history,
                     lammps_version=result.lammps_version, wall_forces=wall_forces, dphi_above=above.dphi)
    print(result.summary())
    print(f"{above.summary()}  -> {args.out} ({time.perf_counter() - t0:.2f} s)")
    return 0


def emit(args, start, settings) -> int:
    """--emit-deck: the deck and start data file, no LAMMPS run (ellipses/spheroids: the ellipse
    deck, lammps_inputs/jam-ellipses.lmp, which minimises by damped dynamics with rotations)."""
    from pathlib import Path

    from jamflow.decks.jam import emit_deck
    from jamflow.decks.ellipsoids import emit_deck as emit_ellipsoid_deck

    kind = start.shape.kind
    if kind not in ("sphere", "ellipsoid"):
        raise ValueError(f"--emit-deck writes decks for disks/spheres and ellipses/spheroids, not {start.shape.name(start.dim)}")
    outputs = [args.emit_deck, Path(args.emit_deck).with_name(Path(args.emit_deck).stem + ".start.data")]
    for out in outputs:
        check_writable(out, args.force)
    writer = emit_ellipsoid_deck if kind == "ellipsoid" else emit_deck
    with replacing(outputs if args.force else []):
        deck, data = writer(args.emit_deck, start, settings, out=Path(args.out).stem)
    print(f"wrote {deck} and {data}; run: cd {deck.parent} && lmp -in {deck.name}  "
          f"(writes {Path(args.out).stem}.data and {Path(args.out).stem}.protocol.txt)")
    return 0
