"""Shear a jammed packing quasistatically at zero pressure (chapter section 2.2, eq. 2.4): steps
x_i -> x_i + dgamma y_i in the shear-periodic cell, each minimised at fixed strain and brought
back into the energy window by compression/decompression. Writes DIR/STEM.shear.h5 (every
step: gamma, phi_J, pressure tensor, contact network and its changes, the packing; schema: see
the docs, reference/schemas) and the figure DIR/STEM.shear.png."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np

from jamflow.cli.options import add_engine_argument, add_force_argument, add_ftol_argument, add_quiet_argument, add_vtol_argument
from jamflow.engines.choose import engine_name
from jamflow.support.files import check_writable, output_directory, replacing
from jamflow.io.names import derived_path
from jamflow.io.packing_file import load_packing
from jamflow.minimize.settings import MinimizerSettings
from jamflow.cli.progress import ShearProgress
from jamflow.protocols.settings import PROTOCOL_NAMES, PROTOCOLS
from jamflow.protocols.shear import shear, shear_protocol, shear_strains
from jamflow.io.shear_file import ShearFile, path_columns, save_shear_path


def add_arguments(p) -> None:
    p.add_argument("packing", metavar="IN.h5", help="a packing file (jamflow jam --out), in the energy window")
    p.add_argument("--dgamma", type=float, required=True,
                   help="strain step (either sign; the chapter uses Delta gamma / n ~ 1e-3)")
    p.add_argument("--to", type=float, required=True, help="final accumulated strain")
    p.add_argument("--out", default=None, metavar="DIR", help="output directory (created if its parent exists; "
                   "required unless --emit-deck)")
    add_engine_argument(p, help="auto: the compiled engine where it runs the scene")
    p.add_argument("--protocol", choices=PROTOCOL_NAMES, default=None, metavar="{" + ",".join(sorted(PROTOCOLS)) + "}",
                   help="bisection after each step: fast (growing increments, Newton jumps; the default) or chapter "
                        "(the chapter's; the default with --emit-deck, which runs it only)")
    p.add_argument("--dphi0", type=float, default=1e-6, help="initial packing-fraction increment after each step")
    add_vtol_argument(p)
    add_ftol_argument(p)
    add_force_argument(p)
    add_quiet_argument(p)
    p.add_argument("--no-figure", action="store_true", help="do not draw DIR/STEM.shear.png")
    p.add_argument("--list-changes", action="store_true",
                   help="print one line per step whose contact network changed: the contacts removed and added "
                        "(i-j, particle indices from 0), and the floater count when it changed")
    p.add_argument("--emit-deck", default=None, metavar="DECK.lmp",
                   help="write the LAMMPS deck that runs this shear in lmp alone (and its start, DECK.start.data) "
                        "instead of running it; then: cd DIR && lmp -in DECK.lmp")


def settings_from_args(args):
    for name in ("dphi0", "vtol"):
        value = getattr(args, name)
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"--{name} must be a finite positive number, got {value}")
    minimizer = MinimizerSettings(force_tol=args.ftol, v_min=args.vtol)
    if (args.protocol or ("chapter" if args.emit_deck else "fast")) == "chapter":
        return PROTOCOLS["chapter"](dphi0=args.dphi0, v_tol=args.vtol, minimizer=minimizer)
    return shear_protocol(dphi0=args.dphi0, v_tol=args.vtol, minimizer=minimizer)


def output_paths(args) -> tuple[Path, Path]:
    if args.out is None:
        raise ValueError("--out DIR is required (the directory for the path file and its figure)")
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} is a file; give a directory")
    if not out.parent.is_dir():
        raise ValueError(f"cannot create --out {out}: directory {out.parent} does not exist")
    if not out.exists():
        check_writable(out, option="--out")  # its parent must be writable: the command makes the directory
    return out / derived_path(args.packing, "shear").name, out / derived_path(args.packing, "shear", ".png").name


def run(args) -> int:
    settings = settings_from_args(args)
    packing = load_packing(args.packing)
    shear_strains(packing.box.shear_strain, args.dgamma, args.to)  # bad strains refused before work
    engine_name(packing, settings.minimizer.method, args.engine)
    if args.emit_deck:
        return emit(args, packing, settings)
    data, figure = output_paths(args)
    with output_directory(args.out, "--out"):  # removed again if nothing gets written into it
        for out in [data] + ([] if args.no_figure else [figure]):
            check_writable(out, args.force, "--out")
        with warnings.catch_warnings(record=True) as caught, ShearProgress(disable=args.quiet) as progress:
            warnings.simplefilter("always")
            path = shear(packing, args.dgamma, args.to, settings, engine=args.engine, observers=[progress])
        for w in caught:
            print(f"jamflow shear: warning: {w.message}")
        passed = step_checks(path, settings)
        if not passed.all():
            print(f"jamflow shear: warning: {int((~passed).sum())} of {len(passed)} steps failed the packing checks "
                  f"(steps {np.flatnonzero(~passed).tolist()[:10]}; column checks_passed in the path file)")
        with replacing([data, figure] if args.force else []):
            save_shear_path(data, path, source=args.packing, extra_columns={"checks_passed": passed})
            print(f"{path.summary()}  -> {data}")
            if args.list_changes:
                print_changes(data)
            if not args.no_figure:
                from jamflow.plots.shear import shear_path_figure

                print(f"figure -> {shear_path_figure(figure, path_columns(path))}")
    return 0


def print_changes(data) -> None:
    """The contact changes recorded in the shear path file ``data``, one line per changed step."""
    for change in ShearFile(data).changes():
        print(change.line())


def emit(args, packing, settings) -> int:
    """--emit-deck: the shear deck and its start data file, no run."""
    from jamflow.decks.shear import emit_shear_deck

    outputs = [args.emit_deck, Path(args.emit_deck).with_name(Path(args.emit_deck).stem + ".start.data")]
    for out in outputs:
        check_writable(out, args.force, "--emit-deck")
    with replacing(outputs if args.force else []):
        deck, data = emit_shear_deck(args.emit_deck, packing, args.dgamma, args.to, settings,
                                     out=Path(args.packing).stem)
    print(f"wrote {deck} and {data}; run: cd {deck.parent} && lmp -in {deck.name}  "
          f"(writes {Path(args.packing).stem}.data and {Path(args.packing).stem}.protocol.txt)")
    return 0


def step_checks(path, settings) -> np.ndarray:
    """The packing checks of ``jamflow.mechanics.checks`` (window, force balance, contact count) at every step."""
    from jamflow.mechanics.checks import check_packing

    out = []
    for step in path.steps:
        p, jam = step.packing, step.jam
        ftol = settings.minimizer.force_tol_for(p)
        out.append(check_packing(p, jam.energy_per_particle, jam.max_force, settings.v_tol, ftol).passed)
    return np.array(out, dtype=bool)
