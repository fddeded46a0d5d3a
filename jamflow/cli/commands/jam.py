"""Jam N particles (disks, spheres, or the shapes of ``--shape``) at onset by isotropic
compression (chapter section 2.1) and write the packing as HDF5 (schema: see the docs, reference/schemas).
With --walls the box is bounded by walls on those axes (smooth or rough); with --gravity the
particles settle on the floor instead; with --pressure the box relaxes to a target pressure
(chapter section 2.3; see the docs, guide/boundaries); with --gamma the
periodic cell is sheared to that fixed Lees-Edwards strain (section 2.2, docs/notes/shear.md). With --above
DPHI the onset packing is compressed affinely by DPHI and minimised again, and that packing is
written (attribute dphi_above; the state jamflow moduli measures, chapter section 4.5). With --precision
double-double --pressure P the float64 onset is refined to P in double-double (jamflow refine;
see the docs, guide/precision) and written with positions_lo; with --precision double-double --vtol V
(no --pressure) it is refined to the pressure whose double-double energy lands in V < V_dd < 2 V."""

from __future__ import annotations

import time

from jamflow.cli.options import add_quiet_argument, add_spec_arguments, spec_options
from jamflow.cli.progress import CompressionProgress
from jamflow.model.walls import wall_loads
from jamflow.protocols.above import compress_above
from jamflow.protocols.outcome import JammingFailed
from jamflow.protocols.spec import JamSpec, prepare, run_jam
from jamflow.io.names import check_packing_name
from jamflow.support.files import check_writable, replacing


def add_arguments(p) -> None:
    add_spec_arguments(p)
    p.add_argument("--out", default="packing.h5", help="output HDF5 file")
    p.add_argument("--force", action="store_true",
                   help="replace an --out (or --emit-deck files) that is a symlink, device node or read-only file")
    add_quiet_argument(p)
    p.add_argument("--threads", type=int, default=1, metavar="T",
                   help="run FIRE and the forces on T threads (compiled engine; disks/spheres with a spring law in a "
                        "periodic box, other scenes run serial with a warning). Meant for N >= 16384 on free cores; "
                        "the result does not depend on T > 1 but differs from T = 1 (serial, the default) in "
                        "round-off (docs/notes/threads.md)")
    p.add_argument("--emit-deck", default=None, metavar="DECK.lmp",
                   help="write the LAMMPS deck that runs this jam in lmp alone (and its start, DECK.start.data) "
                        "instead of running it; then: cd DIR && lmp -in DECK.lmp")


def spec_from_args(args) -> JamSpec:
    """The jam specification of parsed options (a deck runs the chapter's protocol unless one is named)."""
    options = spec_options(args)
    if options.get("protocol") is None and getattr(args, "emit_deck", None):
        options["protocol"] = "chapter"
    return JamSpec.from_options(**options)


def check_deck_args(spec: JamSpec, args) -> None:
    """Refuse what --emit-deck cannot write, before any work."""
    if not args.emit_deck:
        return
    if spec.pressure is not None or spec.gravity or spec.wall_type == "rough":
        raise ValueError("--emit-deck writes the compression deck (smooth walls at most); the constant-pressure deck "
                         "is lammps_inputs/pressure.lmp")
    if spec.above is not None:
        raise ValueError("--above compresses the onset packing at a fixed box: it does not combine with "
                         "--pressure, --gravity or --emit-deck")


def run(args) -> int:
    check_packing_name(args.out)  # x.shear.h5 would be skipped or refused by every reader of packings
    check_writable(args.out, args.force, "--out")
    spec = spec_from_args(args)
    check_deck_args(spec, args)
    check_threads_value(args)
    prepared = settings, start = prepare(spec)
    if args.emit_deck:
        return emit(args, start, settings)
    engine_options = threads_option(spec, start, args)
    t0 = time.perf_counter()
    build_kernels_first(spec, start)
    with CompressionProgress(disable=args.quiet) as progress:
        result, checks = run_jam(spec, observers=[progress], engine_options=engine_options, prepared=prepared,
                                 destination=args.out)
    if spec.above is not None:
        return save_above(args, result, t0, engine_options)
    if spec.precision == "double-double":
        from jamflow.io.packing_file import save_refined  # h5py: not loaded for --help

        save_refined(result, args.out, force=args.force)
        print(f"{result.summary()}  -> {args.out} ({time.perf_counter() - t0:.2f} s)")
        return 0
    from jamflow.io.packing_file import save_jam_result  # h5py: not loaded for --help

    save_jam_result(args.out, result, checks, target_pressure=spec.pressure, stress=spec.stress, force=args.force,
                    **threads_record(result))
    print(f"{result.summary()}  -> {args.out} ({time.perf_counter() - t0:.2f} s)")
    return 0


def check_threads_value(args) -> None:
    """Refuse a --threads below 1, or with --emit-deck (the deck runs in LAMMPS), before any work."""
    threads = getattr(args, "threads", 1)
    if threads < 1:
        raise ValueError(f"--threads must be an integer >= 1 (1: serial, the default; 2 or more: the compiled "
                         f"engine's FIRE on that many threads), got {threads}")
    if threads > 1 and getattr(args, "emit_deck", None):
        raise ValueError("--threads runs the compiled engine's FIRE in this process; --emit-deck writes a LAMMPS deck "
                         "instead: leave --threads out")


def threads_option(spec: JamSpec, start, args) -> dict | None:
    """The engine options of --threads (None for 1: the serial kernels); refused, before any work, when
    the scene runs in LAMMPS."""
    threads = getattr(args, "threads", 1)
    if threads == 1:
        return None
    from jamflow.engines.choose import engine_name

    if engine_name(start, spec.minimizer, spec.engine, pressure=spec.pressure is not None) != "numba":
        raise ValueError(f"--threads runs the compiled engine's FIRE; this jam runs in LAMMPS (--engine {spec.engine}, "
                         f"--minimizer {spec.minimizer}): leave --threads out, or use --engine numba with "
                         "--minimizer fire")
    return {"threads": threads}


def threads_record(result) -> dict:
    """The protocol attribute of a jam whose FIRE ran on threads (``threads``: how many), else none:
    its packing differs in round-off from the serial kernels'."""
    kernels = getattr(result, "kernels", "")
    if kernels.startswith("numba, ") and kernels.endswith("threads"):
        return {"threads": int(kernels.split()[1])}
    return {}


def build_kernels_first(spec: JamSpec, start) -> None:
    """Build the ahead-of-time disk kernels, if this jam runs them and they are not built yet (once per
    machine, ~20 s, announced by one line on stderr), before the progress bar starts: the bar then
    counts minimisations only, instead of drawing a first "1/1 100%" line after the build."""
    from jamflow.engines.choose import engine_name

    if engine_name(start, spec.minimizer, spec.engine, pressure=spec.pressure is not None) == "numba":
        from jamflow.engines.compiled.aot import kernels_for

        kernels_for(start)


def save_above(args, result, t0, engine_options=None) -> int:
    """--above: compress the checked onset packing by DPHI, minimise, write that packing; the
    onset's phi_J and the minimisation's stop are in the protocol group, its history is the onset's."""
    settings = result.settings
    try:
        above = compress_above(result.packing, args.above, settings.minimizer, engine=args.engine,
                               engine_options=engine_options)
    except JammingFailed as err:
        raise ValueError(f"{err} (onset phi_J = {result.phi_j:.10f}; nothing written)") from None
    protocol = {**settings.as_dict(), "engine": above.engine, "phi_onset": result.phi_j, "above_dphi": above.dphi,
                "above_reason": above.minimization.reason, "above_iterations": above.minimization.iterations,
                **threads_record(result)}
    wall_forces = wall_loads(above.packing) if above.packing.box.walls else None
    from jamflow.io.packing_file import save_packing  # h5py: not loaded for --help

    with replacing([args.out] if getattr(args, "force", False) else []):
        save_packing(args.out, above.packing, energy_per_particle=above.energy_per_particle,
                     pressure_tensor=above.pressure_tensor, protocol=protocol, history=result.history,
                     lammps_version=result.lammps_version, wall_forces=wall_forces, dphi_above=above.dphi,
                     phi_j=result.phi_j)
    print(result.summary())
    print(f"{above.summary()}  -> {args.out} ({time.perf_counter() - t0:.2f} s)")
    return 0


def emit(args, start, settings) -> int:
    """--emit-deck: the deck and start data file, no LAMMPS run (ellipses/spheroids: the ellipse
    deck, lammps_inputs/jam-ellipses.lmp, which minimises by damped dynamics with rotations)."""
    import shlex
    from pathlib import Path

    from jamflow.decks.shapes import JAM_DECKS

    writer = JAM_DECKS.get(start.shape.kind)
    if writer is None:
        raise ValueError(f"--emit-deck writes decks for disks/spheres and ellipses/spheroids, not {start.shape.name(start.dim)}")
    outputs = [args.emit_deck, Path(args.emit_deck).with_name(Path(args.emit_deck).stem + ".start.data")]
    for out in outputs:
        check_writable(out, args.force, "--emit-deck")
    with replacing(outputs if args.force else []):
        deck, data = writer(args.emit_deck, start, settings, out=Path(args.out).stem)
    print(f"wrote {deck} and {data}; run: cd {shlex.quote(str(deck.parent))} && lmp -in {shlex.quote(deck.name)}  "
          f"(writes {Path(args.out).stem}.data and {Path(args.out).stem}.protocol.txt)")
    return 0
