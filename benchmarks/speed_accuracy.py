"""Speed against accuracy of the compression protocol: time per packing against the error
in phi_J, one parameter varied at a time around the chapter protocol (dphi0 = 1e-4,
V_tol = 1e-16, force tolerance 1e-14 max(1, L/20), FIRE), for N = 64, 256, 1024 2D
bidisperse disks. The error of a run is |phi_J - phi_J,ref| for the same random start,
phi_J,ref from the reference run (dphi0 = 1e-5, V_tol = V_min = 1e-20).

    python benchmarks/speed_accuracy.py run --n 64 --seeds 0 1 2            (appends rows)
    python benchmarks/speed_accuracy.py run --n 1024 --seeds 0 --variants reference seed cg
    python benchmarks/speed_accuracy.py chart                               (CSV -> PNG)

Rows are appended to docs/notes/speed-accuracy.csv as each run ends and skipped when present,
so an interrupted sweep resumes. Each run has its own process and a time limit; a run
over the limit or failing is recorded with that status (never dropped). ``seconds`` is
the protocol's wall time (JamResult.seconds), ``cpu_seconds`` the CPU time of the run's
process; on this shared 2-core machine wall time inflates with load (the 1-minute load
average is recorded beside each), CPU time much less, so the charts use CPU time.
"""

from __future__ import annotations

import math
import sys
from dataclasses import replace

from common import DOCS, command_line, pyplot, read_rows, save_figure, sweep  # (benchmarks/ is the script's directory)

CSV = DOCS / "speed-accuracy.csv"
COLUMNS = ["n", "seed", "variant", "status", "seconds", "cpu_seconds", "phi_j", "v", "max_force", "minimizations",
           "iterations", "load"]

# name -> (CompressionSettings overrides, MinimizerSettings overrides); one line per point
VARIANTS = {
    "reference": ({"dphi0": 1e-5, "v_tol": 1e-20}, {"v_min": 1e-20}),
    "seed": ({}, {}),
    "dphi0=1e-3": ({"dphi0": 1e-3}, {}),
    "dphi0=3e-4": ({"dphi0": 3e-4}, {}),
    "dphi0=3e-5": ({"dphi0": 3e-5}, {}),
    "dphi0=1e-5": ({"dphi0": 1e-5}, {}),
    "vtol=1e-12": ({"v_tol": 1e-12}, {}),
    "vtol=1e-14": ({"v_tol": 1e-14}, {}),
    "vtol=1e-18": ({"v_tol": 1e-18}, {"v_min": 1e-18}),
    "vtol=1e-20": ({"v_tol": 1e-20}, {"v_min": 1e-20}),
    "ftol=1e-10": ({}, {"force_tol": 1e-10}),
    "ftol=1e-12": ({}, {"force_tol": 1e-12}),
    "cg": ({}, {"method": "cg"}),
    "md": ({}, {"method": "md"}),
}
GROUPS = {"dphi0": ["dphi0=1e-3", "dphi0=3e-4", "seed", "dphi0=3e-5", "dphi0=1e-5"],
          "V_tol": ["vtol=1e-12", "vtol=1e-14", "seed", "vtol=1e-18", "vtol=1e-20"],
          "force tol": ["ftol=1e-10", "ftol=1e-12", "seed"],
          "minimiser": ["seed", "cg", "md"]}


def settings_for(variant: str):
    from jamflow.minimize.settings import MinimizerSettings
    from jamflow.protocols.settings import chapter_protocol

    protocol, minimizer = VARIANTS[variant]
    return chapter_protocol(**protocol, minimizer=replace(MinimizerSettings(), **minimizer))


# --- this benchmark ---------------------------------------------------------------------------------
def jam_once(n, seed, variant):
    import warnings

    from jamflow import jam

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = jam(n=n, dim=2, sizes="bi:1.4:0.5", seed=seed, settings=settings_for(variant))
    return dict(seconds=f"{r.seconds:.3f}", phi_j=repr(r.phi_j), v=f"{r.energy_per_particle:.3e}",
                max_force=f"{r.max_force:.2e}", minimizations=r.minimizations, iterations=r.iterations)


def run(args) -> None:
    points = [dict(n=n, seed=seed, variant=v) for n in args.n for seed in args.seeds for v in args.variants]
    sweep(args.out, COLUMNS, points, jam_once, args.limit, args.strict)


def errors(rows, against: str = "reference"):
    """{(n, variant): [(CPU seconds, |phi_J - phi_J,against|), ...]} over seeds that have the
    ``against`` run (the reference, or the chapter protocol to isolate one parameter)."""
    ref = {(r["n"], r["seed"]): float(r["phi_j"]) for r in rows if r["variant"] == against and r["status"] == "ok"}
    out = {}
    for r in rows:
        key = (r["n"], r["seed"])
        if r["status"] == "ok" and key in ref and r["variant"] != against:
            out.setdefault((int(r["n"]), r["variant"]), []).append(
                (float(r["cpu_seconds"]), abs(float(r["phi_j"]) - ref[key])))
    return out


def summary(rows, against: str = "reference"):
    """{(n, variant): (median CPU s, mean |error|, max |error|, runs, failed/timed-out runs)}."""
    bad = {}
    for r in rows:
        if r["status"] != "ok":
            bad[(int(r["n"]), r["variant"])] = bad.get((int(r["n"]), r["variant"]), 0) + 1
    out = {}
    for key, pairs in errors(rows, against).items():
        secs = sorted(p[0] for p in pairs)
        e = [p[1] for p in pairs]
        out[key] = (secs[len(secs) // 2], sum(e) / len(e), max(e), len(e), bad.get(key, 0))
    for key, count in bad.items():
        out.setdefault(key, (math.nan, math.nan, math.nan, 0, count))
    return out


FLOOR = 1e-13  # an error of exactly 0 (same phi_J to the bit) is drawn at this floor


def chart(args) -> None:
    rows = read_rows(args.out)
    plt = pyplot()
    fig, axes = plt.subplots(2, len(GROUPS), figsize=(4.2 * len(GROUPS), 7.6), sharex=True, sharey=True)
    for row_axes, against in zip(axes, ("reference", "seed")):
        stats = summary(rows, against)
        sizes = sorted({k[0] for k in stats})
        for ax, (group, names) in zip(row_axes, GROUPS.items()):
            for n, marker in zip(sizes, "osD^"):
                pts = [(stats[(n, v)][0], max(stats[(n, v)][1], FLOOR), v) for v in names
                       if (n, v) in stats and stats[(n, v)][3]]
                if pts:
                    ax.plot([p[0] for p in pts], [p[1] for p in pts], marker=marker, ls="none", label=f"N = {n}")
                    for x, y, v in pts:
                        ax.annotate(v.split("=")[-1], (x, y), fontsize=7, xytext=(3, 3), textcoords="offset points")
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.axhline(1e-8, color="gray", lw=0.8, ls=":")
            ax.set_title(f"varying {group}", fontsize=10)
        row_axes[0].set_ylabel(rf"mean $|\phi_J - \phi_J^{{\mathrm{{{against}}}}}|$, same start")
    for ax in axes[1]:
        ax.set_xlabel("median CPU seconds per packing")
    axes[0][0].legend(fontsize=8)
    fig.suptitle("2D bidisperse disks, time against error in phi_J. Top: against the reference run (dphi0 = 1e-5, "
                 "V_tol = 1e-20); bottom: against the chapter protocol (dphi0 = 1e-4, V_tol = 1e-16). "
                 f"Error 0 drawn at {FLOOR:g}.", fontsize=9)
    fig.tight_layout()
    save_figure(fig, args.out.with_suffix(".png"))
    for against in ("reference", "seed"):
        print(f"errors against the {against} run")
        stats = summary(rows, against)
        for key in sorted(stats):
            sec, mean, worst, k, bad = stats[key]
            print(f"N={key[0]:5d} {key[1]:12s} {sec:8.2f} CPU s  mean|err| {mean:.2e}  max|err| {worst:.2e}  runs {k}  "
                  f"failed/timeout {bad}")


def _run_arguments(r):
    r.add_argument("--n", type=int, nargs="+", default=[64])
    r.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    r.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=list(VARIANTS))


def main(argv=None):
    return command_line(__doc__, argv, run, chart, CSV, _run_arguments)


if __name__ == "__main__":
    sys.exit(main())
