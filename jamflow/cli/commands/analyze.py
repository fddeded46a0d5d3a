"""Structure of one packing or an ensemble (chapter sections 4.2-4.4): g(r) (partials for
discrete species), S(k), Q6 global/local, G, the g(r) - 1 envelope length and the q6
correlation functions with their length. FILES are jamflow HDF5 packings or LAMMPS data /
dump files (every dump frame counts as one packing); all of them form one ensemble.
Results go to one HDF5 file (NAME.structure.h5 by default, jamflow.io.names; layout in docs/notes/structure.md) and PNG plots. Jamflow packings
are checked for force balance first (a warning for each that is not at an energy minimum;
order/force_balanced is 1, 0, or -1 for LAMMPS inputs, whose potential is unknown)."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import h5py
import numpy as np

from jamflow.analysis.correlations import BondCorrelation, rdf_correlation_length
from jamflow.analysis.order import BondOrder, first_minimum, translational_order
from jamflow.analysis.structure import MAX_SPECIES, RDF, StructureFactor, max_reduced_radius, positive
from jamflow.cli.inputs import add_input_arguments, load_inputs, parse_diameters
from jamflow.ensemble.parallel import add_engine_arguments, expand_inputs, file_mapper
from jamflow.ensemble.pooling import merge_rdf, merge_structure_factor, pooled_bins, structure_sums
from jamflow.io.names import derived_path
from jamflow.io.packing_file import load_packing
from jamflow.io.structure_file import write_results
from jamflow.mechanics.checks import check_packing
from jamflow.model.nematic import Nematic
from jamflow.plots.structure import (
    plot_bond_correlations,
    plot_bond_order_map,
    plot_order,
    plot_rdf,
    plot_structure_factor,
)
from jamflow.support.files import check_writable, output_directory, replacing
from jamflow.support.machine import MAX_BINS, check_bins


def add_arguments(p) -> None:
    p.add_argument("files", nargs="+", help="packing files: jamflow .h5, LAMMPS data or dump; or ensemble store directories")
    p.add_argument("--out", default=None,
                   help="output HDF5 file (default: NAME.structure.h5 beside one input NAME.h5; DIR/DIR.structure.h5 "
                        "for a directory or several files in DIR)")
    p.add_argument("--plots", default=None,
                   help="directory for PNG plots, made if missing (its parent must exist; default: beside --out)")
    add_input_arguments(p)
    p.add_argument("--dr", type=float, default=0.02, help="g(r) bin width, units of <sigma^2>^1/2")
    p.add_argument("--k-max", type=float, default=20.0, help="largest k, units of 1/<sigma^2>^1/2")
    p.add_argument("--r-min", type=float, default=None,
                   help="Q6 neighbour cutoff, units of <sigma^2>^1/2 (default: first minimum of g(r))")
    p.add_argument("--q6-dr", type=float, default=0.1, help="bin width of the q6 correlation functions")
    p.add_argument("--force", action="store_true",
                   help="replace output or plot paths that are symlinks, devices or read-only files")
    add_engine_arguments(p)


def _check_numbers(args) -> None:
    for name in ("dr", "k_max", "q6_dr", "r_min"):
        if getattr(args, name) is not None:
            positive(f"--{name.replace('_', '-')}", getattr(args, name))


def _discrete(packings) -> bool:
    species = [np.unique(p.diameters) for p in packings]
    return len(species[0]) <= MAX_SPECIES and all(np.array_equal(s, species[0]) for s in species)


def analyze(packings, labels, args, files=None) -> dict:
    """Every measurement of the command, as plain result objects and arrays. With ``files``
    (one jamflow packing file each) and --workers/--scheduler, per-packing work runs as one
    Dask task per file and g(r), S(k) are pooled from the tasks (jamflow.ensemble.pooling)."""
    partial = _discrete(packings) and len(np.unique(packings[0].diameters)) > 1
    workers, scheduler = getattr(args, "workers", None), getattr(args, "scheduler", None)
    parallel = files is not None and (workers is not None or scheduler is not None)
    with file_mapper(workers, scheduler) if parallel else file_mapper() as run:
        if parallel:
            r_max, dk = pooled_bins(packings, args.k_max)
            parts = run(structure_sums, files, args.dr, r_max, partial, args.k_max, dk, desc="g(r), S(k)")
            rdf, sk = merge_rdf([p[:2] for p in parts]), merge_structure_factor([p[2] for p in parts])
        else:
            rdf = RDF(dr=args.dr, partial=partial).compute(packings)
            sk = StructureFactor(k_max=args.k_max).compute(packings)
        r_min = args.r_min if args.r_min is not None else first_minimum(rdf)
        orders = run(order_row, files if parallel else packings, r_min, args.dr, desc="Q6, G")
    table = {name: np.array([o[name] for o in orders]) for name in ORDER_COLUMNS}
    table["phi"], table["n"] = np.array([p.phi for p in packings]), np.array([p.n for p in packings])
    table["force_balanced"] = np.array([_force_balanced(p, label) for p, label in zip(packings, labels)], np.int8)
    return dict(rdf=rdf, r_min=float(r_min), table=table, labels=labels,
                G=translational_order(rdf, r_min), g_fit=rdf_correlation_length(rdf, r_min), sk=sk,
                corr=BondCorrelation(r_min=r_min, dr=args.q6_dr).compute(packings))


def _force_balanced(packing, label) -> int:
    """1 or 0 for a jamflow packing (warning when 0); -1 for a LAMMPS input (potential unknown)."""
    if "coordinate_precision" in packing.metadata:  # read from a LAMMPS file (jamflow.io.readers)
        return -1
    checks = check_packing(packing)
    if not checks.force_balanced:
        warnings.warn(f"{label} is {checks.problems()[0]}; its structure is that of a state that is not force "
                      "balanced", stacklevel=2)
    return int(checks.force_balanced)


ORDER_COLUMNS = ("Q6_global", "Q6_local", "G", "n_isolated", "P2")


def order_row(packing, r_min: float, dr: float) -> dict:
    """Per-packing order parameters (``packing`` may be a jamflow packing file); P2 (nematic
    order of the directors) is NaN for particles without an axis (disks, spheres)."""
    if not hasattr(packing, "positions"):
        packing = load_packing(packing)
    order = BondOrder(r_min=r_min).compute(packing)
    return dict(Q6_global=order.global_order, Q6_local=order.local_order, n_isolated=order.n_isolated,
                G=translational_order(RDF(dr=dr).compute(packing), r_min).G,
                P2=Nematic().compute(packing).p2 if packing.shape.oriented else math.nan)




PLOT_SUFFIXES = ("q6map", "rdf", "sk", "q6corr", "order")


def write_plots(directory: Path, stem: str, res: dict, first) -> list[Path]:
    """g(r), S(k), q6 correlations, order parameters; for 2D also the psi_6 map of the first packing."""
    title = f"{res['rdf'].n_packings} packing(s)"
    table = res["table"]
    extra = []
    if first.dim == 2:
        extra.append(plot_bond_order_map(first, BondOrder(r_min=res["r_min"]).compute(first),
                                         directory / f"{stem}-q6map.png", title=f"{res['labels'][0]}:"))
    return extra + [
        plot_rdf(res["rdf"], directory / f"{stem}-rdf.png", r_min=res["r_min"], fit=res["g_fit"], title=title),
        plot_structure_factor(res["sk"], directory / f"{stem}-sk.png", title="S(k)"),
        plot_bond_correlations(res["corr"], directory / f"{stem}-q6corr.png", title=title),
        plot_order(res["labels"], {k: table[k] for k in _plotted(table)},
                   directory / f"{stem}-order.png", title=f"r_min = {res['r_min']:.3f}"),
    ]


def _plotted(table) -> list[str]:
    """The order parameters to draw: P2 only where some packing has it."""
    return ["Q6_global", "Q6_local", "G"] + (["P2"] if np.isfinite(table["P2"]).any() else [])


def run(args) -> int:
    _check_numbers(args)
    diameters = parse_diameters(args.diameters)
    args.out = args.out or str(derived_path(args.files, "structure"))  # named by the inputs as given
    args.files = expand_inputs(args.files)  # a directory (ensemble store) stands for its packing files
    check_writable(args.out, args.force, "--out")
    plots = Path(args.plots) if args.plots else Path(args.out).resolve().parent
    if plots.exists() and not plots.is_dir():
        raise ValueError(f"--plots {plots} is not a directory; give a directory for the PNG plots")
    if not plots.exists():
        check_writable(plots, option="--plots")  # its parent must exist and be writable; the command makes the directory
    with output_directory(plots, "--plots"):  # made here: removed again if the command fails before writing into it
        return _run(args, diameters, plots)


def _run(args, diameters, plots: Path) -> int:
    stem = Path(args.out).stem
    for suffix in PLOT_SUFFIXES:
        check_writable(plots / f"{stem}-{suffix}.png", args.force, "--plots")
    packings, labels = load_inputs(args.files, args.format, diameters, args.dim)
    if len({p.dim for p in packings}) != 1:
        raise ValueError("the input files mix 2D and 3D packings; analyse them separately")
    one_each = len(packings) == len(args.files) and all(h5py.is_hdf5(f) for f in args.files)
    if (args.workers is not None or args.scheduler is not None) and not one_each:
        raise ValueError("--workers/--scheduler run one task per jamflow packing file; LAMMPS inputs run without them")
    radius = max_reduced_radius(packings)  # g(r) and the q6 correlations are binned up to it
    for option, width in (("--dr", args.dr), ("--q6-dr", args.q6_dr)):  # bins that cannot fit: refused now
        if width > 0:
            check_bins(math.floor(radius / width), f"{option} {width:g}", f"use {option} {radius / MAX_BINS:.3g} or larger")
    StructureFactor(k_max=args.k_max).check_memory(packings)  # a --k-max whose S(k) grid cannot fit: refused now
    res = analyze(packings, labels, args, files=args.files if one_each else None)
    with replacing([args.out, *(plots / f"{stem}-{s}.png" for s in PLOT_SUFFIXES)] if args.force else []):
        write_results(args.out, res, args.files)
        written = write_plots(plots, stem, res, packings[0])
    t = res["table"]
    print(f"{len(packings)} packing(s): r_min = {res['r_min']:.3f}  Q6 global = {t['Q6_global'].mean():.3f}  "
          f"Q6 local = {t['Q6_local'].mean():.3f}  G = {res['G'].G:.3g}  first peak g = {res['G'].g_max:.3g}  "
          f"xi(g) = {res['g_fit'].xi:.3g}  xi(q6) = {res['corr'].fit.xi:.3g}"
          + (f"  P2 = {np.nanmean(t['P2']):.3f}" if np.isfinite(t["P2"]).any() else ""))
    print(f"-> {args.out}, " + ", ".join(str(p) for p in written))
    return 0
