"""Speed against accuracy of the contact-distance methods in packings (docs/notes/contact-distance.md): the
same random starts jammed with each method, CPU time per packing against the bias of phi_J and
<z> relative to the exact contact distance on the same start (paired differences).

    python benchmarks/contact_methods.py --n 64 --alpha 2.0 --seeds 10 --out docs/notes/contact-methods.csv
    python benchmarks/contact_methods.py --report docs/notes/contact-methods.csv

Two mixtures: 2:1 bidisperse ellipses (size ratio 1.4; exact, cleaver, linear, quadratic) and
monodisperse ones (exact, gaussian, linear, quadratic): the Gaussian form (Berne-Pechukas eq. 2.5)
is defined for identical particles only, so jamflow refuses it for the bidisperse mixture
(Cleaver's eq. 2.6 is its generalisation; the chapter's "should not be used" is about that case).
Each row also gives the packing's energy per particle re-evaluated with the exact sigma (how far
an approximate packing is from the exact model's energy window). Rows are written as they
finish and skipped when present (resumable); CPU seconds (time.process_time) and the load.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
import warnings
from dataclasses import replace
from pathlib import Path

from tqdm import tqdm

from jamflow import jam
from jamflow.mechanics.contacts import Contacts
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.model.shapes import Ellipsoid

from common import pyplot, read_rows, save_figure, scratch, write_rows  # (benchmarks/ is the script's directory)

MIXTURES = {"bi:1.4:0.6667": ("exact", "cleaver", "linear", "quadratic"),
            "mono": ("exact", "gaussian", "linear", "quadratic")}
COLUMNS = ["sizes", "contact", "alpha", "seed", "n", "phi_j", "mean_z", "n_floaters", "energy_per_particle",
           "exact_energy_per_particle", "max_force", "max_torque", "iterations", "cpu_seconds", "load", "fallbacks",
           "capped", "approximate"]


def one(sizes, contact, alpha, seed, n) -> dict:
    t = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # fallback warnings: their counts are columns
        res = jam(n=n, dim=2, sizes=sizes, shape=f"ellipse:{alpha:g}", contact=contact, seed=seed)
    cpu = time.process_time() - t
    p = res.packing
    exact = energy_forces_pressure(replace(p, shape=Ellipsoid(p.shape.alpha, "exact"))).energy / p.n
    c = Contacts().compute(p)
    return dict(sizes=sizes, contact=contact, alpha=alpha, seed=seed, n=n, phi_j=repr(res.phi_j), mean_z=c.mean_z,
                n_floaters=c.n_floaters, energy_per_particle=res.energy_per_particle, exact_energy_per_particle=exact,
                max_force=res.max_force, max_torque=res.max_torque, iterations=res.iterations,
                cpu_seconds=f"{cpu:.2f}", load=f"{os.getloadavg()[0]:.1f}",
                **{k: res.counters.get(k, 0) for k in ("fallbacks", "capped", "approximate")})


def run(args) -> None:
    out = Path(args.out)
    rows = read_rows(out)
    done = {(r["sizes"], r["contact"], float(r["alpha"]), int(r["seed"])) for r in rows}
    todo = [(sizes, m, s) for sizes, methods in MIXTURES.items() for s in range(args.seeds) for m in methods
            if (sizes, m, args.alpha, s) not in done]
    for sizes, method, seed in tqdm(todo, desc="contact methods", unit="packing"):
        rows.append(one(sizes, method, args.alpha, seed, args.n))
        write_rows(out, rows, COLUMNS)


def paired(rows, sizes, method, column):
    """(mean, s.e.) of column(method) - column(exact) over the seeds both have."""
    by = {(r["contact"], int(r["seed"])): float(r[column]) for r in rows if r["sizes"] == sizes}
    d = [by[method, s] - by["exact", s] for (m, s) in by if m == method and ("exact", s) in by]
    if len(d) < 2:
        return float("nan"), float("nan"), len(d)
    return statistics.mean(d), statistics.stdev(d) / len(d) ** 0.5, len(d)


def report(path) -> None:
    rows = read_rows(Path(path))
    table = []
    print("| sizes | contact | packings | <phi_J> | bias phi_J +- s.e. | <z> | bias <z> +- s.e. | median CPU s / packing "
          "| V with exact sigma (median) | fallbacks / contacts |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for sizes, methods in MIXTURES.items():
        for m in methods:
            g = [r for r in rows if r["sizes"] == sizes and r["contact"] == m]
            if not g:
                continue
            bphi, sphi, k = paired(rows, sizes, m, "phi_j")
            bz, sz, _ = paired(rows, sizes, m, "mean_z")
            cpu = statistics.median(float(r["cpu_seconds"]) for r in g)
            ve = statistics.median(float(r["exact_energy_per_particle"]) for r in g)
            fb = sum(int(r["fallbacks"]) for r in g) / max(1, sum(int(r["approximate"]) for r in g))
            table.append((sizes, m, cpu, bphi, sphi, bz, sz))
            print(f"| {sizes} | {m} | {len(g)} | {statistics.mean(float(r['phi_j']) for r in g):.4f} | "
                  f"{bphi:+.4f} +- {sphi:.4f} | {statistics.mean(float(r['mean_z']) for r in g):.3f} | "
                  f"{bz:+.3f} +- {sz:.3f} | {cpu:.1f} | {ve:.2e} | {fb:.2g} |")
    chart(table, Path(path).with_suffix(".png"))


def chart(table, path: Path) -> None:
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    colors = {"bi:1.4:0.6667": "C0", "mono": "C3"}
    for sizes, m, cpu, bphi, sphi, bz, sz in table:
        label = f"{m} ({'bidisperse' if sizes != 'mono' else 'monodisperse'})"
        for ax, b, s in ((axes[0], bphi, sphi), (axes[1], bz, sz)):
            ax.errorbar(cpu, b, yerr=s, marker="o" if sizes != "mono" else "s", color=colors[sizes], capsize=3)
            ax.annotate(label, (cpu, b), fontsize=7, xytext=(4, 2), textcoords="offset points")
    for ax, name in zip(axes, (r"$\phi_J - \phi_J^{exact}$", r"$\langle z\rangle - \langle z\rangle^{exact}$")):
        ax.axhline(0, color="k", lw=0.8)
        ax.set_xlabel("median CPU seconds per packing")
        ax.set_ylabel(f"paired bias {name}")
    fig.suptitle("contact-distance methods: same starts, 2D ellipses alpha = 2, N = 64 (mean +- s.e. over seeds)")
    save_figure(fig, path)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--alpha", type=float, default=2.0)
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--out", default=str(scratch("contact-methods.csv")))
    ap.add_argument("--report", default=None, metavar="CSV")
    args = ap.parse_args(argv)
    if args.report:
        report(args.report)
    else:
        run(args)


if __name__ == "__main__":
    main()
