"""Particle-shape annealing against isotropic compression (chapter section 2.3.3, Figure 2.18):
2D bidisperse ellipses (2:1 mixture, major-axis ratio 1.4), <phi_J> and <z> against alpha.

    python benchmarks/anneal_vs_compression.py --n 64 --seeds 10 --to 2.0 --dalpha 0.05 --out docs/notes/anneal.csv
    python benchmarks/anneal_vs_compression.py --n 64 --seeds 4 --to 1.4 --dalpha 0.005 --out docs/notes/anneal.csv
    python benchmarks/anneal_vs_compression.py --n 64 --seeds 10 --compress 1.0 1.2 1.4 1.6 1.8 2.0 --out docs/notes/anneal.csv
    python benchmarks/anneal_vs_compression.py --n 32 --seeds 2 --to 2.0 --dalpha 0.005 --chunk 0.1 --keep /tmp/anneal \
        --out docs/notes/anneal.csv          # legs of 0.1 in alpha, resumable: the same steps as one run
    python benchmarks/anneal_vs_compression.py --report docs/notes/anneal.csv

Annealing: seed s jams disks (``jam(seed=s)``, the default protocol), then
``jamflow.protocols.anneal.anneal`` grows alpha in steps of dalpha (first directions from seed
s), one row per step. Compression: ``jam(shape="ellipse:ALPHA", seed=s)`` from a random start.
Rows are written as they finish (atomically) and a finished (protocol, seed) is skipped, so a
run resumes. CPU seconds are the process's (load-independent); every row records the 1-minute
load. ``--report`` prints the table of docs/notes/ellipses.md and draws docs/notes/anneal.png.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from jamflow import jam
from jamflow.mechanics.checks import check_packing
from jamflow.io.packing_file import load_packing, save_packing
from jamflow.plots.anneal import anneal_figure
from jamflow.protocols.anneal import anneal

from common import ANNEAL_COLUMNS as COLUMNS, ELLIPSE_SIZES as SIZES, anneal_row as _row, read_rows, run_or_report, stats, write_rows  # (benchmarks/ is the script's directory)



def run_anneal(n, seed, target, dalpha, keep: Path | None = None, chunk: float | None = None, save=None) -> list[dict]:
    """Seed ``seed`` annealed to ``target``; ``save(rows)`` takes the new rows as they come.
    ``chunk``: anneal in legs of this many alpha (a multiple of dalpha: the steps are those of one
    run), the last packing kept in ``keep`` after each leg; a kept packing is resumed from."""
    path = keep / f"anneal-n{n}-d{dalpha:g}-seed{seed}.h5" if keep else None
    rows = []
    if path is not None and path.is_file():
        start = load_packing(path)
    else:
        t = time.process_time()
        disks = jam(n=n, sizes=SIZES, seed=seed)
        rows.append(_row("compression", 0.0, seed, n, 1.0, disks.packing, check_packing(disks.packing),
                         time.process_time() - t))
        start = disks.packing
    clock = [time.process_time()]

    def record(step):
        now = time.process_time()
        rows.append(dict(protocol="anneal", dalpha=dalpha, seed=seed, n=n, alpha=step["alpha"], phi_j=step["phi_j"],
                         mean_z=step["mean_z"], n_floaters=step["n_floaters"], p2=step["p2"],
                         energy_per_particle=step["energy_per_particle"], max_force=step["max_force"],
                         checks_passed=step["checks_passed"], cpu_seconds=round(now - clock[0], 2),
                         load=os.getloadavg()[0]))
        clock[0] = now

    alpha = 1.0 if start.shape.kind == "sphere" else float(start.shape.alpha)
    while alpha < target - 1e-12:
        stop = min(target, round(alpha + chunk, 12)) if chunk else target
        start, alpha = anneal(start, stop, dalpha, seed=seed, observers=[record]).packing, stop
        if path is not None:
            save_packing(path, start)
        if save:
            save(rows)
            rows = []
    return rows


def _key(r) -> tuple:
    return r["protocol"], float(r["dalpha"]), int(r["seed"]), int(r["n"]), float(r["alpha"])


def merged(rows: list[dict], new: list[dict]) -> list[dict]:
    """``rows`` and the rows of ``new`` whose (protocol, dalpha, seed, n, alpha) it lacks; a row
    it has already is compared (phi_J of a rerun step: the protocol is deterministic)."""
    have = {_key(r): r for r in rows}
    for r in new:
        if _key(r) in have and float(have[_key(r)]["phi_j"]) != float(r["phi_j"]):
            tqdm.write(f"rerun of {_key(r)} gives phi_J {float(r['phi_j'])!r}, the CSV has {have[_key(r)]['phi_j']}")
    return rows + [r for r in new if _key(r) not in have]


def run_compress(n, seed, alpha) -> dict:
    t = time.process_time()
    res = jam(n=n, sizes=SIZES, seed=seed, shape=f"ellipse:{alpha:g}")
    cpu = time.process_time() - t
    return _row("compression", 0.0, seed, n, alpha, res.packing, check_packing(res.packing), cpu)


def run(args) -> None:
    out = Path(args.out)
    rows = read_rows(out)
    done = {_key(r) for r in rows}
    if args.compress:
        todo = [(s, a) for a in args.compress for s in range(args.seeds)
                if ("compression", 0.0, s, args.n, a) not in done]
        for seed, alpha in tqdm(todo, desc="compression", unit="packing"):
            rows.append(run_compress(args.n, seed, alpha))
            write_rows(out, rows, COLUMNS)
        return
    todo = [s for s in range(args.seeds) if ("anneal", args.dalpha, s, args.n, args.to) not in done]
    keep = Path(args.keep) if args.keep else None
    if keep:
        keep.mkdir(parents=True, exist_ok=True)

    def save(new):
        rows[:] = merged(rows, new)
        write_rows(out, rows, COLUMNS)

    for seed in tqdm(todo, desc=f"anneal dalpha={args.dalpha:g}", unit="packing"):
        save(run_anneal(args.n, seed, args.to, args.dalpha, keep, args.chunk, save))


# ----- report -------------------------------------------------------------------------------------
def groups_of(rows, alphas=None):
    """{(protocol label, alpha): rows} at the alphas every protocol shares (``alphas``: or these)."""
    groups = {}
    for r in rows:
        label = "compression" if r["protocol"] == "compression" else f"anneal {float(r['dalpha']):g}"
        groups.setdefault((label, round(float(r["alpha"]), 6)), []).append(r)
    return groups


def report(path: Path, every: float = 0.1) -> None:
    rows = read_rows(path)
    groups = groups_of(rows)
    grid = {k: g for k, g in groups.items() if abs(k[1] / every - round(k[1] / every)) < 1e-6}
    print("| protocol | alpha | packings | <phi_J> +- s.e. | <z> +- s.e. (non-floaters) | floaters / N | P2 | checks passed "
          "| median CPU s per step |")
    print("|---|---|---|---|---|---|---|---|---|")
    for (label, alpha), g in sorted(grid.items(), key=lambda kv: (kv[0][1], kv[0][0])):
        phi, phi_se, k = stats(r["phi_j"] for r in g)
        z, z_se, _ = stats(r["mean_z"] for r in g)
        floaters = np.mean([int(r["n_floaters"]) / int(r["n"]) for r in g])
        passed = sum(r["checks_passed"] == "True" for r in g)
        cpu = np.median([float(r["cpu_seconds"]) for r in g])
        p2 = np.mean([float(r["p2"]) for r in g])
        print(f"| {label} | {alpha:g} | {k} | {phi:.4f} +- {phi_se:.4f} | {z:.3f} +- {z_se:.3f} | {floaters:.3f} | "
              f"{p2:.3f} | {passed}/{k} | {cpu:.1f} |")
    paired(rows)
    chart(groups, path.with_suffix(".png"))


def paired(rows) -> None:
    """Annealed minus compressed <phi_J>, <z> at each alpha both have (unpaired: different starts)."""
    groups = groups_of(rows)
    for (label, alpha), g in sorted(groups.items()):
        ref = groups.get(("compression", alpha))
        if label == "compression" or not ref or len(g) < 2 or len(ref) < 2:
            continue
        for column in ("phi_j", "mean_z"):
            a, a_se, _ = stats(r[column] for r in g)
            b, b_se, _ = stats(r[column] for r in ref)
            print(f"{label} - compression at alpha {alpha:g}: {column} {a - b:+.4f} +- {np.hypot(a_se, b_se):.4f}")


def chart(groups, path: Path) -> None:
    n = sorted({r["n"] for g in groups.values() for r in g})
    series = {}
    for label in sorted({lab for lab, _ in groups}):
        alphas = sorted(a for lab, a in groups if lab == label)
        z = [stats(r["mean_z"] for r in groups[label, a]) for a in alphas]
        phi = [stats(r["phi_j"] for r in groups[label, a]) for a in alphas]
        series[label] = (alphas, [m[0] for m in z], [m[1] for m in z], [m[0] for m in phi], [m[1] for m in phi])
    anneal_figure(path, series, title=f"2D bidisperse ellipses, N = {', '.join(n)}: shape annealing vs isotropic "
                                      "compression (cf. chapter Figure 2.18)")


def add_arguments(ap) -> None:
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--to", type=float, default=2.0)
    ap.add_argument("--dalpha", type=float, default=0.05)
    ap.add_argument("--keep", default=None, metavar="DIR", help="keep each seed's last annealed packing here (resume)")
    ap.add_argument("--chunk", type=float, default=None, metavar="A",
                    help="anneal in legs of A in alpha, rows and packing saved after each (with --keep: resumable)")
    ap.add_argument("--compress", type=float, nargs="+", default=None, metavar="ALPHA",
                    help="jam by compression at these alphas instead of annealing")

def main(argv=None) -> None:
    run_or_report(__doc__, add_arguments, run, report, "docs/notes/anneal.csv", argv)


if __name__ == "__main__":
    main()
