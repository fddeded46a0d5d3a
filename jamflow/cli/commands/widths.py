"""The widths W(N) of the jamming onsets of several systems on one log-log plot, each with its
fit W ~ N^-nu, from the tables that `jamflow onsets DIR --table T` writes (so a store need not be
kept: e.g. `jamflow widths docs/notes/onsets-2d.csv docs/notes/onsets-3d.csv --labels 2D 3D
--figure widths.png`)."""

from __future__ import annotations

from pathlib import Path

from jamflow.plots.figure import figure_format
from jamflow.support.files import check_writable


def add_arguments(p) -> None:
    p.add_argument("tables", metavar="TABLE", nargs="+", help="onsets tables (CSV of jamflow onsets --table)")
    p.add_argument("--figure", required=True, help="figure, PNG, SVG or PDF by its suffix")
    p.add_argument("--labels", nargs="+", default=None, help="one legend label per table (default: the file names)")


def run(args) -> int:
    from jamflow.ensemble.onsets import read_width_curve, widths_figure

    labels = args.labels or [None] * len(args.tables)
    if len(labels) != len(args.tables):
        raise ValueError(f"--labels gives {len(labels)} label(s) for {len(args.tables)} table(s); give one per table")
    missing = [t for t in args.tables if not Path(t).is_file()]
    if missing:
        raise ValueError(f"no such table: {', '.join(missing)} (write one with jamflow onsets DIR --table FILE)")
    figure_format(args.figure)
    check_writable(args.figure, option="--figure")
    curves = [read_width_curve(t, label) for t, label in zip(args.tables, labels)]
    widths_figure(curves, args.figure)
    for c in curves:
        print(f"{c.label}: N = {', '.join(str(int(n)) for n in c.n)}; nu = {c.nu.value:.3f} +- {c.nu.err:.3f}, "
              f"W = {c.amplitude:.4g} N^-nu, chi2/dof = {c.chi2:.2f}")
    print(f"-> {args.figure}")
    return 0
