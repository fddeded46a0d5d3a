"""Jammed 2D bidisperse ellipses (2:1 mixture, major-axis ratio 1.4: --sizes bi:1.4:0.6667) at
several aspect ratios, each packing checked by the independent brute-force energy
(jamflow.analysis.independent), with contacts and floaters (jamflow.mechanics.contacts).

    python benchmarks/ellipse_ensembles.py --alphas 1.2 1.6 2.0 --seeds 20 --n 128 --out docs/ellipse-ensembles.csv
    python benchmarks/ellipse_ensembles.py --engine lammps --seeds 5 --out docs/ellipse-ensembles-lammps.csv
    python benchmarks/ellipse_ensembles.py --report docs/ellipse-ensembles.csv docs/ellipse-ensembles-lammps.csv \
        --packings /tmp/ellipses     # (the --keep directory of the runs, one subdirectory per engine)

``--engine numba`` jams with the compiled FIRE over translations and rotations (the default
route), ``--engine lammps`` with LAMMPS damped dynamics (fix nve/asphere + fix langevin at T = 0
with angmom; minimizer md); the same seed is the same random start. Rows are written as they
finish (atomically) and skipped when present, so a run resumes. CPU seconds are the process's
(load-independent); the 1-minute load average is recorded with each row. ``--report`` prints
the table of docs/ellipses.md and draws docs/ellipse-ensembles.png.
"""

from __future__ import annotations

import argparse
import csv
import os
import statistics
import time
import warnings
from pathlib import Path

import numpy as np
from tqdm import tqdm

from jamflow import jam
from jamflow.mechanics.contacts import Contacts
from jamflow.analysis.independent import independent_check
from jamflow.support.files import atomic_path
from jamflow.io.packing_file import save_packing
from jamflow.minimize.settings import MinimizerSettings
from jamflow.protocols.settings import fast_protocol

SIZES = "bi:1.4:0.6667"
COLUMNS = ["engine", "alpha", "seed", "n", "phi_j", "energy_per_particle", "pressure", "max_force", "max_torque",
           "minimizations", "iterations", "cpu_seconds", "wall_seconds", "load", "final_reason", "warnings",
           "brute_energy_per_particle", "brute_max_force", "brute_max_torque", "brute_max_force_kept",
           "brute_max_torque_kept", "engine_brute_force_diff", "n_floaters", "mean_z", "n_contacts", "isostatic_count"]


def settings(engine: str):
    """The default protocol; the LAMMPS route minimises by damped dynamics (the only LAMMPS
    minimiser that turns ellipses)."""
    return fast_protocol(minimizer=MinimizerSettings(method="md")) if engine == "lammps" else fast_protocol()


def one(engine: str, alpha: float, seed: int, n: int, keep_dir: Path | None) -> dict:
    t_cpu, t_wall = time.process_time(), time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = jam(n=n, dim=2, sizes=SIZES, shape=f"ellipse:{alpha:g}", seed=seed, settings=settings(engine),
                  engine=engine)
    cpu, wall = time.process_time() - t_cpu, time.perf_counter() - t_wall
    p = res.packing
    check = independent_check(p)
    contacts = Contacts().compute(p)
    kept = ~contacts.floater
    if keep_dir is not None:
        save_packing(keep_dir / f"{engine}-alpha{alpha:g}-seed{seed}.h5", p, energy_per_particle=res.energy_per_particle,
                     pressure_tensor=res.pressure_tensor, history=res.history, lammps_version=res.lammps_version)
    return dict(engine=res.engine, alpha=alpha, seed=seed, n=n, phi_j=repr(res.phi_j),
                energy_per_particle=res.energy_per_particle, pressure=res.pressure, max_force=res.max_force,
                max_torque=res.max_torque, minimizations=res.minimizations, iterations=res.iterations,
                cpu_seconds=f"{cpu:.2f}", wall_seconds=f"{wall:.2f}", load=f"{os.getloadavg()[0]:.1f}",
                final_reason=res.history["reason"][-1].decode(), warnings=" | ".join(str(w.message)[:80] for w in caught),
                brute_energy_per_particle=check.energy_per_particle, brute_max_force=check.max_force(),
                brute_max_torque=check.max_generalized_torque(), brute_max_force_kept=check.max_force(kept),
                brute_max_torque_kept=check.max_generalized_torque(kept),
                engine_brute_force_diff=_force_difference(p, check),
                n_floaters=contacts.n_floaters, mean_z=contacts.mean_z, n_contacts=contacts.n_contacts,
                isostatic_count=contacts.isostatic_count)


def _force_difference(packing, check) -> float:
    from jamflow.mechanics.reference import energy_forces_pressure

    return float(np.abs(energy_forces_pressure(packing).forces - check.forces).max())


def read_rows(path: Path) -> list[dict]:
    """The rows of a results CSV (empty if it does not exist yet)."""
    if not path.is_file():
        return []
    with path.open() as f:
        return list(csv.DictReader(f))


def write_rows(path: Path, rows: list[dict], columns=COLUMNS) -> None:
    """The whole results CSV again, atomically (an interrupted run keeps the last one)."""
    with atomic_path(path) as tmp:
        with open(tmp, "w", newline="") as f:
            w = csv.DictWriter(f, columns)
            w.writeheader()
            w.writerows(rows)


def run(args) -> None:
    out = Path(args.out)
    rows = read_rows(out)
    done = {(r["engine"], float(r["alpha"]), int(r["seed"])) for r in rows}
    todo = [(a, s) for a in args.alphas for s in range(args.seeds) if (args.engine, a, s) not in done]
    keep = Path(args.keep) if args.keep else None
    if keep:
        keep.mkdir(parents=True, exist_ok=True)
    for alpha, seed in tqdm(todo, desc=f"{args.engine} ellipses", unit="packing"):
        rows.append(one(args.engine, alpha, seed, args.n, keep))
        write_rows(out, rows)


# ----- shared by the ellipse benchmarks ----------------------------------------------------------
def pyplot():
    """matplotlib.pyplot on the Agg backend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig, path: Path) -> None:
    """Lay out, write atomically as PNG (120 dpi) and close ``fig``."""
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120, format="png")
    pyplot().close(fig)


def run_or_report(doc: str, add_arguments, run, report, out: str) -> None:
    """The command line of a results benchmark: options from ``add_arguments(parser)``, ``--out``
    (default ``out``), ``--report CSV``: ``report(Path)`` instead of ``run(args)``."""
    ap = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(ap)
    ap.add_argument("--out", default=out)
    ap.add_argument("--report", default=None, metavar="CSV")
    args = ap.parse_args()
    if args.report:
        report(Path(args.report))
    else:
        run(args)


# ----- report -------------------------------------------------------------------------------------
def stats(values):
    v = [float(x) for x in values]
    return statistics.mean(v), (statistics.stdev(v) / len(v) ** 0.5 if len(v) > 1 else float("nan")), len(v)


def recount(rows, packings: Path) -> None:
    """Contacts of the kept packings again with the current floater rules (in place): mean_z and
    n_floaters with seed Figure 2.19's exception, mean_z_rule / n_floaters_rule with d_f + 1 only."""
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
    chart(groups, Path("docs/ellipse-ensembles.png"))


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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--alphas", type=float, nargs="+", default=[1.2, 1.6, 2.0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--n", type=int, default=128)
    ap.add_argument("--engine", choices=("numba", "lammps"), default="numba")
    ap.add_argument("--out", default="docs/ellipse-ensembles.csv")
    ap.add_argument("--keep", default=None, help="directory to save every packing (HDF5), one per engine")
    ap.add_argument("--report", nargs="+", default=None, metavar="CSV")
    ap.add_argument("--packings", default=None, help="with --report: recount contacts of the packings kept here")
    args = ap.parse_args()
    if args.report:
        report(args.report, args.packings)
    else:
        run(args)


if __name__ == "__main__":
    main()
