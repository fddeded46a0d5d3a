"""Whole jams of turning shapes against the soft-mode steps' ``creep_after``
(docs/notes/ellipses.md, "FIRE's time unit and the oblate creep").

    python benchmarks/creep_after.py run --dim 3 --sizes mono --shape spheroid:0.6 spheroid:1.5 \\
        --n 64 --seeds 1 2 3 4 5 --creep-after 50000 10000
    python benchmarks/creep_after.py chart        # per shape and creep_after: mean / median iterations

Each run is ``jamflow jam`` (``protocols.spec.prepare`` / ``run_jam``: the same refusals and
checks) with ``MinimizerSettings.creep_after`` set, in a forked process. A row: the summary's
iterations and minimisations, phi_J, whether the checks passed, and the cost of the creep
method: its attempts (one dynamical matrix and one eigensolve each for the soft-mode steps),
the steps kept, and the CPU seconds of the attempts against the whole jam's (one process, so
the ratio is meaningful under load; the seconds themselves are not).
"""

from __future__ import annotations

import dataclasses
import statistics
import time
from pathlib import Path

from common import DOCS, command_line, read_rows, sweep

KEYS = ["shape", "dim", "n", "sizes", "potential", "seed", "creep_after"]
COLUMNS = KEYS + ["status", "load", "iterations", "minimizations", "phi_j", "checks_passed", "attempts", "kept",
                  "attempt_cpu_seconds", "cpu_seconds"]


def one_jam(shape, dim, n, sizes, potential, seed, creep_after) -> dict:
    """One jam with ``creep_after`` (0: the default) and its creep attempts, as a row."""
    from jamflow.minimize.polish import PolishSteps
    from jamflow.minimize.soft_modes import SoftModeSteps
    from jamflow.protocols.spec import JamSpec, prepare, run_jam

    spec = JamSpec(dim=int(dim), n=int(n), sizes=sizes, potential=potential, shape=shape, seed=int(seed))
    settings, start = prepare(spec)
    if int(creep_after):
        settings = dataclasses.replace(settings, minimizer=dataclasses.replace(settings.minimizer,
                                                                               creep_after=int(creep_after)))
    cost = {"attempts": 0, "kept": 0, "cpu": 0.0}
    for strategy in (SoftModeSteps, PolishSteps):  # this forked process only
        strategy.attempt = _counted(strategy.attempt, cost)
    result, checks = run_jam(spec, prepared=(settings, start))
    return dict(iterations=result.iterations, minimizations=result.minimizations, phi_j=f"{result.phi_j:.10f}",
                checks_passed=checks.passed, attempts=cost["attempts"], kept=cost["kept"],
                attempt_cpu_seconds=f"{cost['cpu']:.2f}")


def _counted(attempt, cost):
    def counted(self, engine, number, done):
        t0 = time.process_time()
        kept = attempt(self, engine, number, done)
        cost["attempts"] += 1
        cost["kept"] += kept
        cost["cpu"] += time.process_time() - t0
        return kept
    return counted


def add_run_arguments(p) -> None:
    p.add_argument("--shape", nargs="+", default=["spheroid:0.6", "spheroid:1.5"])
    p.add_argument("--dim", type=int, default=3)
    p.add_argument("--n", type=int, nargs="+", default=[64])
    p.add_argument("--sizes", default="mono")
    p.add_argument("--potential", default="spring")
    p.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    p.add_argument("--creep-after", type=int, nargs="+", default=[50_000, 10_000],
                   help="iterations before (and between) the creep attempts; 0: the default")


def run(args) -> None:
    points = [dict(shape=shape, dim=args.dim, n=n, sizes=args.sizes, potential=args.potential, seed=seed,
                   creep_after=after)
              for n in args.n for shape in args.shape for after in args.creep_after for seed in args.seeds]
    sweep(args.out, COLUMNS, points, one_jam, args.limit, strict=args.strict)


def chart(args) -> None:
    """Mean and median iterations per (shape, dim, n, sizes, potential, creep_after), all seeds' phi_J."""
    groups: dict[tuple, list[dict]] = {}
    for row in read_rows(args.out):
        if row["status"] == "ok":
            groups.setdefault(tuple(row[k] for k in KEYS if k != "seed"), []).append(row)
    for key, rows in sorted(groups.items()):
        its = [int(r["iterations"]) for r in rows]
        print(f"{' '.join(key)}: {len(rows)} jams (checks passed {sum(r['checks_passed'] == 'True' for r in rows)}), "
              f"iterations mean {statistics.mean(its):.0f} median {statistics.median(its):.0f}, attempts "
              f"{sum(int(r['attempts']) for r in rows)} (kept {sum(int(r['kept']) for r in rows)}), attempt CPU share "
              f"{sum(float(r['attempt_cpu_seconds']) for r in rows) / sum(float(r['cpu_seconds']) for r in rows):.3f}, "
              f"phi_J {' '.join(r['phi_j'] for r in sorted(rows, key=lambda r: int(r['seed'])))}")


def main(argv=None) -> int:
    command_line(__doc__, argv, run, chart, DOCS / "creep-after.csv", add_run_arguments, limit=1800.0)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
