"""Bulk and shear moduli of packings (chapter section 4.5): strain sweeps (B = phi dP/dphi from small
compressions, G = dSigma/dgamma from small simple shears, each relaxed; linear fit, yield) and the
Hessian route (affine term minus the non-affine relaxation) on the packing in each IN.h5 as it is
(make one with jamflow jam --above DPHI). Writes IN.moduli.h5 (schema jamflow.moduli v1: root
attributes G, B, G_hessian, B_hessian, yield_strain, ...; the sweeps as datasets) and the
stress-strain figure IN.moduli.png."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

from jamflow.cli.options import add_engine_argument, add_force_argument, add_quiet_argument
from jamflow.cli.progress import progress_bar
from jamflow.ensemble.parallel import skip_derived
from jamflow.io.moduli_file import save_moduli
from jamflow.io.names import derived_path
from jamflow.io.packing_file import load_packing, read_attrs
from jamflow.mechanics.strains import STRAINS
from jamflow.minimize.settings import MinimizerSettings
from jamflow.protocols.moduli import Moduli
from jamflow.protocols.sweeps import JUMP_TOL, LINEAR_TOL, PAST_YIELD, SweepSettings
from jamflow.support.files import check_distinct, check_writable, replacing


def add_arguments(p) -> None:
    p.add_argument("files", nargs="+", metavar="IN.h5", help="packing files (jamflow jam --above DPHI --out IN.h5)")
    p.add_argument("--min-amplitude", type=float, default=1e-9, help="smallest strain amplitude of the sweeps")
    p.add_argument("--max-amplitude", type=float, default=1e-3, help="largest strain amplitude of the sweeps")
    p.add_argument("--per-decade", type=int, default=2, help="amplitudes per decade (log-spaced), both signs each")
    p.add_argument("--linear-tol", type=float, default=LINEAR_TOL,
                   help="relative deviation of a central slope from the fitted modulus that still counts as linear")
    p.add_argument("--jump-tol", type=float, default=JUMP_TOL,
                   help="relative jump of a one-sided slope that counts as a yield (besides contact changes)")
    p.add_argument("--past-yield", type=int, default=PAST_YIELD, help="amplitudes measured beyond the first yield")
    p.add_argument("--ftol", type=float, default=None,
                   help="force tolerance of the relaxations (default: below the round-off floor, so each one runs "
                        "until it stops making progress)")
    add_engine_argument(p, help="engine of the relaxations")
    p.add_argument("--no-figure", action="store_true", help="do not draw IN.moduli.png")
    add_force_argument(p)
    add_quiet_argument(p)


def results_path(packing_path) -> Path:
    return derived_path(packing_path, "moduli")


def figure_path(packing_path) -> Path:
    return derived_path(packing_path, "moduli", ".png")


def settings_from_args(args) -> SweepSettings:
    lo, hi, per = args.min_amplitude, args.max_amplitude, args.per_decade
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi):
        raise ValueError(f"--min-amplitude and --max-amplitude must be finite with 0 < min < max, got {lo:g}, {hi:g}")
    if per < 1:
        raise ValueError(f"--per-decade must be a positive integer, got {per}")
    count = int(round(per * math.log10(hi / lo))) + 1
    minimizer = None if args.ftol is None else MinimizerSettings(force_tol=args.ftol)
    return SweepSettings(tuple(np.geomspace(lo, hi, max(count, 2))), args.linear_tol, args.jump_tol, args.past_yield,
                         minimizer)


def run(args) -> int:
    moduli = Moduli(settings_from_args(args), engine=args.engine)
    args.files = check_distinct(skip_derived(args.files))  # the same file twice: swept twice onto one output
    packings = [load_packing(f) for f in args.files]  # every input is read before any work
    outputs = [results_path(f) for f in args.files]
    written = outputs + ([] if args.no_figure else [figure_path(f) for f in args.files])
    for out in written:
        check_writable(out, args.force)
    checks = [moduli.check(p) for p in packings]  # every input is refused or accepted before any sweep
    with replacing(written if args.force else []):
        _measure(args, moduli, packings, outputs, checks)
    return 0


def _measure(args, moduli, packings, outputs, checks) -> None:
    """Sweep, write and report each checked packing."""
    for path, packing, out, checked in zip(args.files, packings, outputs, checks):
        with progress_bar(total=moduli.total_relaxations(), desc=Path(path).name, unit="relax",
                          disable=args.quiet) as bar:
            result = moduli.compute(packing, observers=[_progress(bar)], checked=checked)
            bar.total = bar.n  # the sweeps stop a few amplitudes past a yield (drawn on close)
        dphi = float(read_attrs(path).get("dphi_above", math.nan))
        save_moduli(out, path, packing, result, dphi, moduli)
        print(summary_line(path, result))
        for strain in STRAINS:
            if not math.isfinite(result.sweep(strain).modulus):  # the smallest amplitude already yielded
                print(f"jamflow moduli: warning: {path}: no {strain.kind} amplitude stayed linear, so the sweep's "
                      f"{strain.modulus} is NaN (the Hessian route's is kept); use a smaller --min-amplitude",
                      file=sys.stderr)
        if not args.no_figure:
            from jamflow.plots.moduli import stress_strain_figure

            print(f"figure -> {stress_strain_figure(figure_path(path), result, title=f'{Path(path).name}')}")


def _progress(bar):
    def observe(step: dict) -> None:
        point = step["point"]
        bar.set_postfix_str(f"{step['strain'].kind} {step['amplitude']:+.1e}: {point['iterations']} it", refresh=False)
        bar.update(1)

    return observe


def summary_line(path, result) -> str:
    parts = []
    for strain in STRAINS:
        sweep = result.sweep(strain)
        hess = result.hessian.modulus(strain)
        parts.append(f"{strain.modulus} = {sweep.modulus:.8e} +- {sweep.error:.1e} (Hessian {hess:.8e}, "
                     f"{result.agreement(strain):+.1e}; linear to {sweep.linear_max:.0e}, yield "
                     f"{sweep.yield_strain:.1e} {sweep.yield_reason or '-'})")
    return f"{path}: P = {result.pressure:.4e}  " + "  ".join(parts)




