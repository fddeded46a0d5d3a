"""Jammed 2D bidisperse ellipses (2:1 mixture, major-axis ratio 1.4: --sizes bi:1.4:0.6667) at
several aspect ratios, each packing checked by the independent brute-force energy
(jamflow.analysis.independent), with contacts and floaters (jamflow.mechanics.contacts).

    python benchmarks/ellipse_ensembles.py --alphas 1.2 1.6 2.0 --seeds 20 --n 128 --out docs/notes/ellipse-ensembles.csv
    python benchmarks/ellipse_ensembles.py --engine lammps --seeds 5 --out docs/notes/ellipse-ensembles-lammps.csv
    python benchmarks/ellipse_ensembles.py --report docs/notes/ellipse-ensembles.csv docs/notes/ellipse-ensembles-lammps.csv \
        --packings /tmp/ellipses     # (the --keep directory of the runs, one subdirectory per engine)

``--engine numba`` jams with the compiled FIRE over translations and rotations (the default
route), ``--engine lammps`` with LAMMPS damped dynamics (fix nve/asphere + fix langevin at T = 0
with angmom; minimizer md); the same seed is the same random start. Rows are written as they
finish (atomically) and skipped when present, so a run resumes. CPU seconds are the process's
(load-independent); the 1-minute load average is recorded with each row. ``--report`` prints
the table of docs/notes/ellipses.md and draws docs/notes/ellipse-ensembles.png.
"""

from __future__ import annotations

import argparse
import statistics
from pathlib import Path

from tqdm import tqdm

from jamflow.mechanics.contacts import Contacts

from common import ELLIPSE_COLUMNS, ellipse_row, pyplot, read_rows, save_figure, scratch, stats, write_rows  # (benchmarks/ is the script's directory)



def run(args) -> None:
    out = Path(args.out)
    rows = read_rows(out)
    done = {(r["engine"], float(r["alpha"]), int(r["seed"])) for r in rows}
    todo = [(a, s) for a in args.alphas for s in range(args.seeds) if (args.engine, a, s) not in done]
    keep = Path(args.keep) if args.keep else None
    if keep:
        keep.mkdir(parents=True, exist_ok=True)
    for alpha, seed in tqdm(todo, desc=f"{args.engine} ellipses", unit="packing"):
        rows.append(ellipse_row(args.engine, alpha, seed, args.n, keep))
        write_rows(out, rows, ELLIPSE_COLUMNS)


# ----- report -------------------------------------------------------------------------------------
def recount(rows, packings: Path) -> None:
    """Contacts of the kept packings again with the current floater rules (in place): mean_z and
    n_floaters with chapter Figure 2.19's exception, mean_z_rule / n_floaters_rule with d_f + 1 only."""
    from jamflow.io.packing_file import load_packing

    for r in rows:
        p = load_packing(packings / r["engine"] / f"{r['engine']}-alpha{float(r['alpha']):g}-seed{r['seed']}.h5")
        for suffix, contacts in (("", Contacts()), ("_rule", Contacts(balanced_exception=False))):
            c = contacts.compute(p)
            r["mean_z" + suffix], r["n_floaters" + suffix] = c.mean_z, c.n_floaters


def report(paths, packings=None) -> None:
    rows = [r for p in paths for r in read_rows(Path(p))]
    if packings:
        recount(rows, Path(packings))
    groups = {}
    for r in rows:
        groups.setdefault((r["engine"], float(r["alpha"])), []).append(r)
    rule = "mean_z_rule" in rows[0]
    print("| route | alpha | packings | <phi_J> +- s.e. | <z> +- s.e. (non-floaters) | floaters / N | "
          + ("<z>, floaters / N (d_f + 1 rule only) | " if rule else "")
          + "V (brute), min .. max | worst max F, max tau/d_k (brute, all particles) | median CPU s |")
    print("|---|---|---|---|---|---|---|---|---|" + ("---|" if rule else ""))
    for (engine, alpha), g in sorted(groups.items(), key=lambda kv: (kv[0][1], kv[0][0])):
        phi, phi_se, k = stats(r["phi_j"] for r in g)
        z, z_se, _ = stats(r["mean_z"] for r in g)
        floaters = statistics.mean(int(r["n_floaters"]) / int(r["n"]) for r in g)
        v = [float(r["brute_energy_per_particle"]) for r in g]
        f = max(float(r["brute_max_force"]) for r in g)
        t = max(float(r["brute_max_torque"]) for r in g)
        cpu = statistics.median(float(r["cpu_seconds"]) for r in g)
        extra = ""
        if rule:
            z_rule = stats(r["mean_z_rule"] for r in g)[0]
            extra = f"{z_rule:.3f}, {statistics.mean(int(r['n_floaters_rule']) / int(r['n']) for r in g):.3f} | "
        print(f"| {engine} | {alpha:g} | {k} | {phi:.4f} +- {phi_se:.4f} | {z:.3f} +- {z_se:.3f} | {floaters:.3f} | "
              f"{extra}{min(v):.3e} .. {max(v):.3e} | {f:.1e}, {t:.1e} | {cpu:.0f} |")
    chart(groups, Path("docs/notes/ellipse-ensembles.png"))


def chart(groups, path: Path) -> None:
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for engine, marker in (("numba", "o"), ("lammps", "s")):
        keys = sorted(a for e, a in groups if e == engine)
        if not keys:
            continue
        for ax, column in zip(axes, ("phi_j", "mean_z")):
            m = [stats(r[column] for r in groups[engine, a]) for a in keys]
            label = "compiled FIRE" if engine == "numba" else "LAMMPS damped dynamics"
            ax.errorbar(keys, [x[0] for x in m], yerr=[x[1] for x in m], marker=marker, capsize=3, ls="-", label=label)
            for a in keys:
                ax.plot([a] * len(groups[engine, a]), [float(r[column]) for r in groups[engine, a]], marker, ms=2,
                        alpha=0.3, color="gray")
    axes[0].set_ylabel(r"$\phi_J$")
    axes[1].set_ylabel(r"$\langle z \rangle$ (non-floaters)")
    axes[1].axhline(4, ls=":", color="k", lw=0.8)
    axes[1].axhline(6, ls=":", color="k", lw=0.8)
    for ax in axes:
        ax.set_xlabel(r"aspect ratio $\alpha$")
        ax.legend(fontsize=8)
    fig.suptitle("2D bidisperse ellipses (2:1, a_l/a_s = 1.4), N = 128, isotropic compression")
    save_figure(fig, path)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--alphas", type=float, nargs="+", default=[1.2, 1.6, 2.0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--n", type=int, default=128)
    ap.add_argument("--engine", choices=("numba", "lammps"), default="numba")
    ap.add_argument("--out", default=str(scratch("ellipse-ensembles.csv")))
    ap.add_argument("--keep", default=None, help="directory to save every packing (HDF5), one per engine")
    ap.add_argument("--report", nargs="+", default=None, metavar="CSV")
    ap.add_argument("--packings", default=None, help="with --report: recount contacts of the packings kept here")
    args = ap.parse_args(argv)
    if args.report:
        report(args.report, args.packings)
    else:
        run(args)


if __name__ == "__main__":
    main()
