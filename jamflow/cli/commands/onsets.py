"""Distribution of jamming onsets of an ensemble store DIR (jamflow ensemble --out DIR): P(phi_J)
and P(<z>) per N, the width W(N) with bootstrap errors, the fit W ~ N^-nu and <phi_J>(N)
extrapolated to large N (chapter section 2.4). Writes a table (CSV) and a four-panel PNG."""

from __future__ import annotations

from pathlib import Path

from jamflow.plots.figure import figure_format
from jamflow.support.files import check_writable, write_csv
from jamflow.support.machine import check_bins

# large-N phi_J (O'Hern, Silbert, Liu & Nagel, PRE 68, 011306, 2003; quoted by the chapter)
PUBLISHED = {(2, "bi:1.4:0.5"): 0.842, (3, "mono"): 0.639}


def add_arguments(p) -> None:
    p.add_argument("directory", metavar="DIR", help="ensemble store (its summary.csv)")
    p.add_argument("--table", default=None, help="CSV of the per-N statistics (default DIR/onsets.csv)")
    p.add_argument("--figure", default=None, help="figure, PNG, SVG or PDF by its suffix (default DIR/onsets.png)")
    p.add_argument("--bootstrap", type=int, default=1000, help="bootstrap replicates for the errors")
    p.add_argument("--bins", type=int, default=30, help="histogram bins")
    p.add_argument("--n", type=int, nargs="+", default=None, help="only these N (default: all in the store)")


def run(args) -> int:
    from jamflow.ensemble import Store
    from jamflow.ensemble.onsets import onset_statistics, onsets_figure

    store = Store(args.directory)
    rows = store.read_summary()
    if not rows:
        raise ValueError(f"{args.directory} has no summary.csv rows; run jamflow ensemble --out {args.directory} first "
                         "(or --rebuild-summary)")
    if args.n:
        rows = [r for r in rows if int(r["n"]) in set(args.n)]
    if args.bins < 2:
        raise ValueError(f"--bins must be at least 2, got {args.bins}")
    check_bins(args.bins, f"--bins {args.bins}", "give fewer")
    table = Path(args.table or store.dir / "onsets.csv")
    figure = Path(args.figure or store.dir / "onsets.png")
    figure_format(figure)  # PNG, SVG or PDF by the suffix; another is refused before work
    for path, option in ((table, "--table"), (figure, "--figure")):
        check_writable(path, option=option)
    result = onset_statistics(rows, n_bootstrap=args.bootstrap)
    write_table(table, result)
    onsets_figure(result, figure, bins=args.bins, published=published_value(rows, result.dim))
    print(report_text(result, published_value(rows, result.dim)))
    print(f"-> {table}, {figure}")
    return 0


def write_table(path, result) -> Path:
    rows = result.table()
    fit = dict(nu=result.nu.value, nu_err=result.nu.err, nu_chi2_dof=result.width_chi2, phi_inf=result.phi_inf.value,
               phi_inf_err=result.phi_inf.err)
    return write_csv(path, [{**r, **fit} for r in rows])


def published_value(rows, dim):
    """The published large-N onset for this system, if there is one."""
    sizes = {r.get("sizes") for r in rows}
    return PUBLISHED.get((dim, sizes.pop())) if len(sizes) == 1 else None


def report_text(result, published=None) -> str:
    lines = [f"{'N':>6} {'packings':>8} {'failed':>6} {'<phi_J>':>18} {'W':>18} {'<z>':>8} {'isostatic':>9}"]
    for r in result.table():
        lines.append(f"{r['n']:>6} {r['packings']:>8} {r['failed']:>6} {r['mean_phi_j']:.5f} +- {r['mean_phi_j_err']:.5f} "
                     f"{r['width']:.5f} +- {r['width_err']:.5f} {r['mean_z']:8.4f} {r['isostatic_fraction']:9.3f}")
    sizes = len(result.sizes)
    have = f"this store has {sizes} (N = {', '.join(str(s.n) for s in result.sizes)})"
    if sizes < 2:  # a width exponent is a slope against N: one N gives none
        lines.append(f"W ~ N^-nu: nu needs packings at two or more N, {have}; "
                     "add sizes with `jamflow ensemble --n ...` into the same store")
    else:
        lines.append(f"W ~ N^-nu: nu = {result.nu.value:.3f} +- {result.nu.err:.3f} (bootstrap, {result.n_bootstrap} "
                     "replicates); chi2/dof of the power law = "
                     + (f"{result.width_chi2:.2f}" if sizes > 2 else "none (needs three or more N)"))
    if sizes < 3:
        lines.append(f"<phi_J>(N) = phi_inf - a N^-nu: phi_inf needs three or more N, {have}"
                     + (f" (published large-N value about {published})" if published else ""))
    else:
        lines.append(f"<phi_J>(N) = phi_inf - a N^-nu: phi_inf = {result.phi_inf.value:.4f} +- {result.phi_inf.err:.4f}"
                     + (f" (published large-N value about {published})" if published else ""))
    return "\n".join(lines)
