"""Mechanical stability of jammed packings (chapter sections 3 and 4.1): contacts, floaters,
the dynamical matrix's spectrum and the stability class of each PACKING.h5, written to the
sibling results file PACKING.modes.h5 (schema jamflow.modes v2; names by jamflow.io.names, so
that a directory's readers skip it); with several files, D(omega) and the z_i distribution are
averaged and one figure is drawn, with the pooled data beside it as CSV (FIGURE-dos.csv,
FIGURE-packings.csv). Every shape: for particles
that turn, the modes mix translations and rotations d_k theta, each mode's translational
fraction is stored, and the energy is profiled along every extra zero mode (quartic modes
of hypostatic packings against the missing contacts N' d_f - d + 1 - N_c). A PACKING may also be
a LAMMPS data or dump file (the dump's last frame; float32 coordinates through MDAnalysis, so
such a packing is rarely force balanced to jamflow's tolerance, and a warning says so)."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from jamflow.analysis.modes import DensityOfStates, Spectrum, Stability, branches
from jamflow.cli.inputs import add_input_arguments, is_jamflow_file, load_input, parse_diameters
from jamflow.ensemble.parallel import add_engine_arguments, expand_inputs, map_files
from jamflow.io.modes_file import save_modes, save_packing_table, save_pooled_dos
from jamflow.io.names import derived_path
from jamflow.io.packing_file import read_checks
from jamflow.mechanics.checks import check_packing
from jamflow.mechanics.contacts import pooled_contacts
from jamflow.plots.figure import figure_format
from jamflow.plots.modes import COLOURINGS
from jamflow.support.files import check_writable, replacing


def add_arguments(p) -> None:
    p.add_argument("files", nargs="+", metavar="PACKING",
                   help="packing files (jamflow jam --out), LAMMPS data or dump files, or ensemble store directories")
    p.add_argument("--e-min", type=float, default=1e-6, help="zero-mode threshold on eigenvalues (eps/diameter^2)")
    p.add_argument("--mass", type=float, default=None,
                   help="M in omega = sqrt(e/M); default N m with m = 1, as the chapter defines it")
    p.add_argument("--method", choices=("auto", "dense", "sparse"), default="auto",
                   help="eigen-solver: dense (all modes) or sparse shift-invert (lowest modes only)")
    p.add_argument("--bins", type=int, default=40, help="number of D(omega) bins")
    p.add_argument("--omega-max", type=float, default=None, help="upper edge of the D(omega) bins")
    p.add_argument("--figure", default=None,
                   help="figure to draw, PNG, SVG or PDF by its suffix (default: PACKING.modes.png for one file, "
                        "DIR/DIR.modes.png for a directory or several files in DIR)")
    p.add_argument("--colour", "--color", choices=COLOURINGS, default="branches",
                   help="panel (a) for particles that turn: each mode coloured by its branch (the chapter's Figure "
                        "2.17: 1 zero/quartic, 2 rotational, 3 translational; a legend names them) or by its "
                        "translational fraction (a colour bar)")
    p.add_argument("--no-figure", action="store_true", help="do not draw the figure")
    p.add_argument("--save-vectors", action="store_true", help="also store all eigenvectors")
    p.add_argument("--force", action="store_true",
                   help="replace result or figure paths that are symlinks, devices or read-only files")
    add_input_arguments(p, dump="its last frame")
    add_engine_arguments(p)


def results_path(packing_path) -> Path:
    return derived_path(packing_path, "modes")


def figure_path(args) -> Path:
    """--figure, or NAME.modes.png beside one input; DIR/DIRNAME.modes.png for several (``derived_path``)."""
    return Path(args.figure) if args.figure else derived_path(args.inputs, "modes", ".png")


def data_paths(args) -> tuple[Path, Path]:
    """The pooled data beside the figure (also with --no-figure): FIGURE-dos.csv, FIGURE-packings.csv."""
    figure = figure_path(args)
    return figure.with_name(f"{figure.stem}-dos.csv"), figure.with_name(f"{figure.stem}-packings.csv")


def run(args) -> int:
    args.inputs, args.files = args.files, expand_inputs(args.files)  # a directory (ensemble store) stands for its packing files
    spectrum = Spectrum(e_min=args.e_min, mass=args.mass, method=args.method)
    dos = DensityOfStates(args.bins, args.omega_max)
    source = (args.format, parse_diameters(args.diameters), args.dim)
    for f in args.files:  # every input is read before any work
        load_input(f, *source)
    written = [results_path(f) for f in args.files] + list(data_paths(args))
    written += [] if args.no_figure else [figure_path(args)]
    if not args.no_figure:
        figure_format(figure_path(args))  # PNG, SVG or PDF by the suffix; another is refused before work
    for i, out in enumerate(written):  # NAME.modes.h5 beside each input; the pooled files where --figure goes
        check_writable(out, args.force, None if i < len(args.files) else "--figure")
    rows = map_files(analyse_file, args.files, spectrum, args.save_vectors, args.force, source, workers=args.workers,
                     scheduler=args.scheduler, progress=len(args.files) > 1, desc="modes")
    for line, _, _ in rows:
        print(line)
    rows = [(spec, stab) for _, spec, stab in rows]
    spectra = [s for s, _ in rows]
    print(ensemble_summary(spectra, [st for _, st in rows]))
    density = dos.compute(spectra) if all(s.complete for s in spectra) else None
    with replacing(written[len(args.files):] if args.force else []):
        _save_pooled(args, spectra, density)
        if not args.no_figure:
            _draw(args, rows, density)
    return 0


def _save_pooled(args, spectra, density) -> None:
    """D(omega) (complete spectra only) and the per-packing table with its pooled row, as CSV."""
    dos_csv, table_csv = data_paths(args)
    if density is not None:
        save_pooled_dos(dos_csv, density)
    save_packing_table(table_csv, [str(f) for f in args.files], spectra)
    print(f"pooled data -> {table_csv}" + (f", {dos_csv}" if density is not None else ""))


def analyse_file(path, spectrum, save_vectors=False, force=False, source=("auto", None, None)):
    """One packing: checks, spectrum, stability class, results file (``force``: it may replace a
    symlink, device or read-only file); the spectrum comes back without eigenvectors (they stay
    in the results file with --save-vectors) but with their translational fractions, which colour
    the figure's modes by character and split D(omega). ``source``: (format, diameters, dim) of
    the input (``jamflow.cli.inputs.load_input``)."""
    packing = load_input(path, *source)
    checks = checked(path, packing, stored=is_jamflow_file(path, source[0]))
    spec = spectrum.compute(packing)
    stab = Stability(spectrum=spectrum).compute(packing, spec)
    out = results_path(path)
    with replacing([out] if force else []):
        save_modes(out, path, spec, stab, vectors=save_vectors, checks=checks)
    line = summary_line(path, spec, stab) + ("" if checks.force_balanced else "  [NOT FORCE BALANCED]")
    return line, spec.without_vectors(), stab


def checked(path, packing, stored=True):
    """Force balance (and window, if the file records V_tol) of a packing; warns when the
    packing is not at an energy minimum, since its modes then describe no stable state.
    ``stored``: the path is a jamflow packing file, which may record V_tol."""
    stored = read_checks(path) if stored else None
    checks = check_packing(packing, v_tol=stored.v_tol if stored else None)
    if not checks.force_balanced:
        warnings.warn(f"{path} is {checks.problems()[0]}: its spectrum and stability class describe a state that "
                      "is not force balanced; minimise it first (jamflow jam)", stacklevel=2)
    return checks


def _draw(args, rows, density):
    from jamflow.plots.modes import modes_figure

    spectra = [s for s, _ in rows]
    out = modes_figure(figure_path(args), spectra, density, [s.dynamical.contacts for s in spectra],
                       [st for _, st in rows], colour=args.colour)
    print(f"figure -> {out}")


def summary_line(path, spec, stab) -> str:
    """The line printed for one packing: N' and floaters, N_c against the isostatic count, <z>,
    near-contacts, zero and negative modes, the lowest nonzero e and the stability class.

    near-contacts (``ContactsResult.n_near_contact``) counts the pairs within a relative 1e-12 of
    touching, |r/sigma - 1| < 1e-12, on either side, from the float64 positions: a diagnostic of
    pairs whose contact float64 barely resolves, not part of N_c. A double-double packing
    refined to a small pressure (overlaps below 1e-12 sigma, e.g. P = 1e-14) has every contact
    among them, so there it is about N_c: its contacts are found from hi + lo and are not
    affected by the count."""
    c = spec.dynamical.contacts
    turning = spec.dynamical.packing.shape.oriented
    quartic = (f"  quartic modes {stab.n_quartic}, one-particle flat {stab.n_single_flat} (missing contacts "
               f"{max(-c.excess_contacts, 0)})" if turning else "")
    return (f"{path}: N' = {c.n_kept} ({c.n_floaters} floaters)  N_c = {c.n_contacts} (iso {c.isostatic_count}, "
            f"excess {c.excess_contacts:+d})  <z> = {c.mean_z:.4f}  near-contacts {c.n_near_contact}  "
            f"zero modes {spec.n_zero}  negative {spec.n_negative}  lowest e = {spec.lowest_nonzero:.4e}{quartic}  "
            f"-> {stab.label}, Delta V {stab.behaviour}{branch_text(spec)}")


def branch_text(spec) -> str:
    """The three branches of a spectrum with rotations (Figure 2.17), or '' (disks, no vectors)."""
    found = branches(spec)
    if found is None:
        return ""
    parts = [f"{b.name} {b.count}" + (f" (omega {b.omega_low:.2e}..{b.omega_high:.2e}, translational "
                                       f"{b.translational:.2f})" if b.count else "") for b in found]
    return "\n  branches: " + "; ".join(parts)


def ensemble_summary(spectra, stabilities=()) -> str:
    n = len(spectra)
    iso = sum(s.dynamical.contacts.is_isostatic for s in spectra)
    exact = sum(s.n_zero == s.dim and s.n_negative == 0 for s in spectra)
    low = np.array([s.lowest_nonzero for s in spectra])
    line = (f"{n} packing(s): {pooled_contacts(s.dynamical.contacts for s in spectra).summary()}, isostatic "
            f"{iso}/{n}, exactly d zero modes (none negative) {exact}/{n}, "
            f"lowest nonzero e: mean {np.nanmean(low):.4e}, median {np.nanmedian(low):.4e}, "
            f"min {np.nanmin(low):.4e}, max {np.nanmax(low):.4e}")
    if stabilities and any(s.dynamical.packing.shape.oriented for s in spectra):
        missing = [max(-s.dynamical.contacts.excess_contacts, 0) for s in spectra]
        zeros = sum(s.n_extra_zero == m for s, m in zip(spectra, missing))
        match = sum(st.n_quartic == m for st, m in zip(stabilities, missing))
        line += f", extra zero modes = missing contacts {zeros}/{n}, quartic modes = missing contacts {match}/{n}"
    return line








