"""Gauss-Newton active-set polish for the creep of disk minimisations (issue 17; docs/speed-2.md
section 8), measured against plain FIRE on the same seeds.

Method (``jamflow.minimize.polish``): with the linear spring V = 1/2 sum max(0, delta)^2, delta = 1 - r/sigma,
a nonlinear least-squares objective; each step minimises the convex Gauss-Newton model
m(dx) = 1/2 sum max(0, delta + J dx)^2 by semismooth Newton over an active set that includes the
gaps the step would close (exact line search on m), then Armijo backtracking on the exact energy.
The Hessian's tension terms (~ -P) are left out, so J^T J is positive semidefinite and every step
descends: unlike the Newton on the active set of docs/speed-2.md section 4 (full, indefinite
Hessian: no descent, alpha <= 0.03). Idea: semismooth Newton for squared positive parts, named as
the next method in docs/speed-2.md section 3; the chunked FIRE wrapper follows
benchmarks/saddle_escape.py (minimize.py unchanged).

Trigger (``--trigger``): ``chunk`` runs each minimisation of ``jam()`` in chunks of ``--after``
FIRE iterations and polishes after a chunk that ends near force balance (max force < 1e-9) but
unconverged (the saddle escape's trigger); ``reach`` first runs FIRE to max force < 1e-9 (the
minimiser's rules, with force_tol 1e-9), polishes, then lets FIRE finish with the usual rules;
``none`` is the default protocol; ``soft`` is the default protocol with the lead's soft-mode
Newton steps on (``MinimizerSettings(creep="soft-modes")``, ``jamflow.minimize.soft_modes``), no polish;
``hook`` the polish as jamflow runs it by default (``MinimizerSettings(creep="auto")``: ``jamflow.minimize.polish.Polisher``
inside ``minimize``), no wrapper. Every other trigger runs with ``creep="off"``.
After a polish the plain minimiser always runs once more, so the stopping rule (max force,
V_min) is FIRE's own, applied to the polished state.

    python benchmarks/gauss_newton_polish.py --check
    python benchmarks/gauss_newton_polish.py --n 1024 --seeds 1 2 3 4 5 --trigger none chunk --after 20000 --out docs/gauss-newton-polish.csv
    python benchmarks/gauss_newton_polish.py --n 1024 --seeds 1 2 3 4 5 --trigger chunk --after 10000 --out docs/gauss-newton-polish.csv
    python benchmarks/gauss_newton_polish.py --n 1024 --seeds 1 2 3 4 5 --trigger reach [--newton] --out docs/gauss-newton-polish.csv
    (the same with --n 256; docs/speed-2.md section 8 lists the repeat and the 20-seed runs)
    python benchmarks/gauss_newton_polish.py --n 1024 --seeds 1 --trigger chunk --steps
    python benchmarks/gauss_newton_polish.py --plot docs/gauss-newton-polish.csv --out docs/gauss-newton-polish.png

``--check`` runs the closed cases (two and three overlapping disks, exact minima known; a jammed
N = 256 packing compressed 1e-3 above onset and displaced by 1e-6). ``--steps`` prints every
polish step (active set size, accepted step length, max force before/after). CPU seconds are
process time (one core, OPENBLAS_NUM_THREADS=1).
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

from speed_accuracy import append_row  # (benchmarks/ is the script's directory)

import numpy as np

from jamflow.engines.compiled.engine import CompiledEngine
from jamflow.minimize.settings import MinimizerSettings
from jamflow.minimize.polish import CREEP_FORCE, polish_reason
from jamflow.minimize.polish import polish as gn_polish
from jamflow.minimize.rules import minimize

PLAIN_MINIMIZE = CompiledEngine.minimize


@dataclass
class PolishLog:
    """Every polish step of a run (``jamflow.minimize.polish.PolishStep``), polishes, converged ones, CPU s."""

    steps: list = field(default_factory=list)
    polishes: int = 0
    converged: int = 0
    seconds: float = 0.0


def polish(engine, ftol: float, log: PolishLog, verbose: bool = False, newton: bool = False) -> bool:
    """``jamflow.minimize.polish.polish`` with the steps logged (and printed with ``verbose``)."""

    def on_step(step):
        log.steps.append(step)
        if verbose:
            print(f"    {step.kind} step: active {step.active} (inner {step.inner}), alpha {step.alpha:.3g}, "
                  f"max force {step.force_before:.3e} -> {step.force_after:.3e}", flush=True)

    result = gn_polish(engine, ftol, on_step=on_step, newton=newton)
    log.polishes += 1
    log.converged += int(result.converged)
    log.seconds += result.seconds
    return result.converged


def tolerance(engine, settings: MinimizerSettings) -> float:
    t = engine.template
    return settings.resolved_force_tol(engine.box, t.potential.contact_stiffness, t.shape.force_tol_base)


def install(trigger: str, after: int, log: PolishLog, verbose: bool = False, newton: bool = False) -> None:
    """Make CompiledEngine.minimize polish per ``trigger`` (none | chunk | reach)."""
    plain = PLAIN_MINIMIZE

    def finish(self, settings, done, seconds):
        result = plain(self, replace(settings, max_iterations=max(1, settings.max_iterations - done)))
        return replace(result, iterations=done + result.iterations, seconds=seconds + result.seconds)

    def minimize(self, settings=None):
        settings = settings or MinimizerSettings()
        if trigger in ("none", "soft", "hook") or settings.pressure is not None or polish_reason(self.template):
            return plain(self, settings)
        ftol = tolerance(self, settings)
        if trigger == "reach":
            if ftol >= CREEP_FORCE:
                return plain(self, settings)
            first = plain(self, replace(settings, force_tol=CREEP_FORCE))
            if first.reason != "force":  # V_min, cap, no progress: FIRE's own verdict stands
                return first
            polish(self, ftol, log, verbose=verbose, newton=newton)
            return finish(self, settings, first.iterations, first.seconds)
        done, seconds = 0, 0.0
        while True:
            chunk = replace(settings, max_iterations=min(after, settings.max_iterations - done))
            result = plain(self, chunk)
            done, seconds = done + result.iterations, seconds + result.seconds
            if result.reason != "iteration-cap" or done >= settings.max_iterations:
                return replace(result, iterations=done, seconds=seconds)
            if result.max_force < CREEP_FORCE:
                polish(self, ftol, log, verbose=verbose, newton=newton)
                return finish(self, settings, done, seconds)

    CompiledEngine.minimize = minimize


# --- closed cases -----------------------------------------------------------------------------------
def _engine_at(positions, diameters, length):
    from jamflow.model.box import Box
    from jamflow.model.packing import Packing
    from jamflow.model.potentials import Spring

    box = Box.cube(float(length), 2)
    return CompiledEngine(Packing(np.asarray(positions, float), np.asarray(diameters, float), box, Spring()))


def check() -> None:
    """Closed cases and a displaced jammed packing; raises AssertionError on failure."""
    # two disks of diameter 1 at distance 0.9 in a large box: the minimum is r = 1 (V = 0); GN is
    # exact for one pair: delta + J dx = 0 in one step (the model is the exact linearisation)
    eng = _engine_at([[5.0, 5.0], [5.9, 5.0]], [1.0, 1.0], 10.0)
    log = PolishLog()
    polish(eng, 1e-14, log)
    r = np.linalg.norm(eng.positions()[1] - eng.positions()[0])
    print(f"two disks: {len(log.steps)} steps, r = {r:.15f}, V = {eng.evaluate().energy:.3e}")
    assert abs(r - 1.0) < 1e-12 and len(log.steps) <= 6
    # three disks on a line, outer ones pushed in: the minimum is all gaps open (V = 0)
    eng = _engine_at([[4.2, 5.0], [5.0, 5.0], [5.7, 5.0]], [1.0, 1.0, 1.0], 10.0)
    log = PolishLog()
    polish(eng, 1e-14, log)
    x = eng.positions()
    print(f"three disks: {len(log.steps)} steps, gaps {np.diff(x[:, 0]) - 1}, V = {eng.evaluate().energy:.3e}")
    assert eng.evaluate().max_force < 1e-14 and np.all(np.diff(x[:, 0]) >= 1 - 1e-12)
    # a jammed packing 1e-3 above onset, minimised by FIRE, displaced randomly by 1e-6
    from jamflow.protocols.compression import jam

    res = jam(n=256, seed=2, engine="numba")  # seed 1 unjams (V -> 7e-31) when compressed by 1e-3
    p = res.packing
    eng = CompiledEngine(p)
    from jamflow.model.box import Box

    eng.set_box(Box(p.box.h * (res.phi_j / (res.phi_j + 1e-3)) ** 0.5))
    first = minimize(eng, MinimizerSettings(v_min=1e-30))
    assert first.reason == "force" and first.energy_per_particle > 1e-9, first
    x0 = eng.positions()
    e0 = eng.evaluate().energy
    rng = np.random.default_rng(0)
    eng.set_positions(x0 + 1e-6 * rng.standard_normal(x0.shape))
    ftol = tolerance(eng, MinimizerSettings())
    log = PolishLog()
    ok = polish(eng, ftol, log, verbose=True)
    from jamflow.mechanics.contacts import Contacts

    kept = Contacts().compute(eng.packing()).kept  # rattlers keep their displacement (no force on them)
    dx = eng.box.minimum_image(eng.positions() - x0)[kept]
    dx -= dx.mean(axis=0)
    print(f"jammed N = 256, phi_J + 1e-3 (V/N = {first.energy_per_particle:.2e}): GN {len(log.steps)} steps, "
          f"converged {ok}, |x - x_min|_max = {np.abs(dx).max():.2e} ({len(kept)} non-rattlers), V/V_min - 1 = {eng.evaluate().energy / e0 - 1:.2e}")
    assert ok and len(log.steps) <= 15 and np.abs(dx).max() < 1e-8


def run(args) -> None:
    from jamflow.mechanics.checks import check_packing
    from jamflow.protocols.settings import fast_protocol
    from jamflow.protocols.compression import jam

    jam(n=16, seed=0, engine="numba")
    out = Path(args.out) if args.out else None
    for seed in args.seeds:
        for trigger in args.trigger:
            log = PolishLog()
            install(trigger, args.after, log, verbose=args.steps, newton=args.newton)
            c0 = time.process_time()
            creep = {"soft": "soft-modes", "hook": "auto"}.get(trigger, "off")  # jamflow's own creep method: hook only
            settings = fast_protocol(minimizer=MinimizerSettings(creep=creep))
            res = jam(n=args.n, dim=args.dim, seed=seed, engine="numba", settings=settings)
            cpu = time.process_time() - c0
            CompiledEngine.minimize = PLAIN_MINIMIZE
            checks = check_packing(res.packing, res.energy_per_particle, None, res.settings.v_tol)
            steps = log.steps
            row = {"n": args.n, **({"dim": args.dim} if args.dim != 2 else {}), "seed": seed, "trigger": trigger, "after": args.after if trigger == "chunk" else "",
                   "newton": args.newton if trigger not in ("none", "soft", "hook") else "",
                   "phi_j": f"{res.phi_j:.10f}", "iterations": res.iterations,
                   "final_iterations": int(res.history["iterations"][-1]), "minimizations": res.minimizations,
                   "polishes": log.polishes, "polish_converged": log.converged, "gn_steps": len(steps),
                   "gn_refused": sum(s.alpha == 0 for s in steps), "polish_cpu_s": round(log.seconds, 3),
                   "cpu_s": round(cpu, 3), "max_force": f"{res.max_force:.2e}", "checks": checks.passed}
            print(" ".join(f"{k}={v}" for k, v in row.items()), flush=True)
            if out:
                append_row(out, list(row), row)


def variant(row: dict) -> str:
    if row["trigger"] in ("none", "soft", "hook"):
        return {"none": "FIRE only", "soft": "soft modes on", "hook": "polish in minimize (default)"}[row["trigger"]]
    name = f"chunk {int(row['after']) // 1000}k" if row["trigger"] == "chunk" else "reach 1e-9"
    return name + (" + Newton" if row.get("newton") == "True" else "")


def plot(path: Path, png: Path) -> None:
    """CPU seconds per seed and variant, one panel per N (the CSV of ``run``)."""
    import csv

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = list(csv.DictReader(path.open()))
    sizes = sorted({int(r["n"]) for r in rows}, reverse=True)
    names = list(dict.fromkeys(variant(r) for r in rows))
    fig, axes = plt.subplots(1, len(sizes), figsize=(5.5 * len(sizes), 4), squeeze=False)
    for ax, n in zip(axes[0], sizes):
        seeds = sorted({int(r["seed"]) for r in rows if int(r["n"]) == n})
        width = 0.8 / len(names)
        for k, name in enumerate(names):
            cpu = {int(r["seed"]): float(r["cpu_s"]) for r in rows if int(r["n"]) == n and variant(r) == name}
            xs = [s + (k - (len(names) - 1) / 2) * width for s in seeds if s in cpu]
            ax.bar(xs, [cpu[s] for s in seeds if s in cpu], width, label=name)
        ax.set_xticks(seeds)
        ax.set_xlabel("seed")
        ax.set_ylabel("CPU seconds of jam() (one core)")
        ax.set_title(f"N = {n}, 2D bidisperse, default protocol")
    axes[0][0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png, dpi=110)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--check", action="store_true", help="closed cases and a displaced jammed packing")
    ap.add_argument("--n", type=int, default=1024)
    ap.add_argument("--dim", type=int, default=2, choices=(2, 3), help="3: spheres, default (bidisperse) sizes; adds a dim column")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1])
    ap.add_argument("--trigger", nargs="+", choices=("none", "chunk", "reach", "soft", "hook"), default=["none", "chunk"])
    ap.add_argument("--after", type=int, default=20000, help="chunk length of the chunk trigger")
    ap.add_argument("--steps", action="store_true", help="print every polish step")
    ap.add_argument("--newton", action="store_true", help="try a full Newton step first where the Hessian is positive definite")
    ap.add_argument("--out", default=None)
    ap.add_argument("--plot", default=None, help="draw CPU seconds per seed from this CSV into --out (png)")
    args = ap.parse_args()
    if args.plot:
        plot(Path(args.plot), Path(args.out))
    elif args.check:
        check()
    else:
        run(args)


if __name__ == "__main__":
    main()
