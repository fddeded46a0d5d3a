"""Bias of mean phi_J for each protocol shortcut, so the defaults are chosen from the chart.

Every variant runs on the same seeds (same random start) as the chapter's protocol;
the bias is the paired difference phi_J(variant) - phi_J(seed) averaged over seeds, with
its standard error (s.d. of the differences / sqrt(k)). 2D bidisperse disks (50:50, 1:1.4).

    python benchmarks/shortcut_bias.py run --n 256 --seeds 0 1 2 3 4 5 6    (appends rows)
    python benchmarks/shortcut_bias.py chart                                (CSV -> PNG, table)

A new shortcut is one more entry in VARIANTS (CompressionSettings overrides). Rows go to
docs/notes/shortcut-bias.csv as runs end; rows present are skipped (resumable); runs over the
time limit or failing are recorded with that status.
"""

from __future__ import annotations

import math
import statistics
import sys

from common import DOCS, command_line, pyplot, read_rows, save_figure, sweep

CSV = DOCS / "shortcut-bias.csv"
COLUMNS = ["n", "seed", "variant", "status", "seconds", "cpu_seconds", "phi_j", "v", "minimizations", "iterations", "load"]


def _fast():
    from jamflow.protocols.settings import FAST_PROTOCOL

    return dict(FAST_PROTOCOL)


VARIANTS = {
    "seed": lambda: {},
    "dphi0=3e-4": lambda: {"dphi0": 3e-4},
    "dphi0=1e-3": lambda: {"dphi0": 1e-3},
    "growth x2 to 1e-3": lambda: {"dphi_growth": 2.0, "dphi_max": 1e-3},
    "start above (phi0=0.86)": lambda: {"phi0": 0.86},
    "newton": lambda: {"newton": True},
    "coarse V_min 1e-10": lambda: {"coarse_v_min": 1e-10},
    "loose approach ftol": lambda: {"approach_force_rtol": 1e-5},
    "fast (all)": _fast,
}


def jam_once(n, seed, variant):
    import warnings

    from jamflow import jam
    from jamflow.protocols.settings import CompressionSettings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = jam(n=n, dim=2, sizes="bi:1.4:0.5", seed=seed, settings=CompressionSettings(**VARIANTS[variant]()))
    return dict(seconds=f"{r.seconds:.3f}", phi_j=repr(r.phi_j), v=f"{r.energy_per_particle:.3e}",
                minimizations=r.minimizations, iterations=r.iterations)


def run(args) -> None:
    points = [dict(n=args.n, seed=seed, variant=v) for seed in args.seeds for v in args.variants]
    sweep(args.out, COLUMNS, points, jam_once, args.limit, args.strict)


def summary(rows):
    """{(n, variant): (mean phi_J, s.e., bias vs seed, s.e. of bias, median s, k, not-ok runs)}."""
    ok = {}
    bad = {}
    for r in rows:
        key = (int(r["n"]), r["variant"])
        if r["status"] == "ok":
            ok.setdefault(key, {})[int(r["seed"])] = (float(r["phi_j"]), float(r["cpu_seconds"]))
        else:
            bad[key] = bad.get(key, 0) + 1
    out = {}
    for (n, variant), runs in ok.items():
        phi = [v[0] for v in runs.values()]
        base = ok.get((n, "seed"), {})
        diff = [runs[s][0] - base[s][0] for s in runs if s in base]
        out[(n, variant)] = (statistics.mean(phi), _se(phi), statistics.mean(diff) if diff else math.nan, _se(diff),
                             statistics.median(v[1] for v in runs.values()), len(phi), bad.get((n, variant), 0))
    return out


def _se(values):
    return statistics.stdev(values) / math.sqrt(len(values)) if len(values) > 1 else math.nan


def chart(args) -> None:
    stats = summary(read_rows(args.out))
    plt = pyplot()
    sizes = sorted({k[0] for k in stats})
    names = [v for v in VARIANTS if any((n, v) in stats for n in sizes)]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 4.6))
    for k, (n, color) in enumerate(zip(sizes, ("C0", "C1", "C2"))):
        xs = [i + 0.15 * (k - (len(sizes) - 1) / 2) for i, v in enumerate(names) if (n, v) in stats]
        vs = [v for v in names if (n, v) in stats]
        ax1.errorbar(xs, [stats[(n, v)][2] for v in vs], yerr=[stats[(n, v)][3] for v in vs], fmt="o", capsize=4,
                     color=color, label=f"N = {n} (k = {max(stats[(n, v)][5] for v in vs)} seeds)")
        ax2.plot(xs, [stats[(n, v)][4] for v in vs], "o", color=color, label=f"N = {n}")
    ax1.axhline(0.0, color="gray", lw=0.8)
    ax1.set_ylabel(r"bias: mean paired $\phi_J - \phi_J^{\mathrm{seed}}$ $\pm$ s.e.")
    ax2.set_ylabel("median CPU seconds per packing")
    ax2.set_yscale("log")
    for ax in (ax1, ax2):
        ax.set_xticks(range(len(names)), names, rotation=30, ha="right", fontsize=8)
        ax.legend(fontsize=8)
    fig.suptitle("2D bidisperse disks: protocol shortcuts against the chapter protocol (same starts)")
    fig.tight_layout()
    save_figure(fig, args.out.with_suffix(".png"))
    print("| N | variant | mean phi_J +- s.e. | bias +- s.e. | median s | seeds | failed/timeout |")
    print("|---|---|---|---|---|---|---|")
    for (n, v) in sorted(stats, key=lambda k: (k[0], names.index(k[1]) if k[1] in names else 99)):
        m, se, b, bse, sec, k, bad = stats[(n, v)]
        print(f"| {n} | {v} | {m:.5f} +- {se:.5f} | {b:+.5f} +- {bse:.5f} | {sec:.2f} | {k} | {bad} |")


def _run_arguments(r):
    r.add_argument("--n", type=int, default=256)
    r.add_argument("--seeds", type=int, nargs="+", default=list(range(20)))
    r.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=list(VARIANTS))


def main(argv=None):
    return command_line(__doc__, argv, run, chart, CSV, _run_arguments)


if __name__ == "__main__":
    sys.exit(main())
