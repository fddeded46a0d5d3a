"""The Newton-Krylov minimiser (``jamflow.minimize.newton``) against FIRE, measured two ways.

``single``: one minimisation of an onset packing compressed affinely by dphi, by the compiled FIRE
alone (``creep="off"``) and by ``newton.relax`` alone (no FIRE), the same start and force tolerance:
iterations or Newton steps, CG iterations, factorisations, the energy reached, CPU seconds.
``jam``: whole default jams (the fast protocol) with each creep method, the same seeds: phi_J,
minimisations, FIRE iterations, CPU seconds, the packing checks.
``watch``: minimisation STEP of a default jam run again by FIRE alone, window by window (energy,
max force, pressure, contacts and how many changed): what a creeping minimisation is doing.
``replay``: minimisations STEPS of a default jam run again from their recorded starts and settings
with each creep method (``auto`` is what the jam ran; ``off`` is FIRE alone; ``newton:2000`` sets
``creep_after``): which minimiser a costly near-onset minimisation needs.

    python benchmarks/newton_minimizer.py single --n 1024 4096 --seeds 1 --dphi 1e-7 1e-6 1e-5 1e-4 --out docs/notes/newton-single.csv
    python benchmarks/newton_minimizer.py jam --n 1024 --seeds 1 2 3 --creep auto newton --out docs/notes/newton-jam.csv
    python benchmarks/newton_minimizer.py jam --n 4096 --seeds 1 2 --creep auto newton --out docs/notes/newton-jam.csv
    timeout 3000 python benchmarks/newton_minimizer.py jam --n 16384 --seeds 1 --creep newton --out /tmp/newton-jam.csv \
        --trace docs/notes/newton-trace-n16384.csv
    python benchmarks/newton_minimizer.py watch --n 4096 --seeds 2 --step 45 --windows 30 --out docs/notes/newton-watch.csv
    timeout 6000 python benchmarks/newton_minimizer.py replay --n 16384 --seeds 1 --steps 51 52 \
        --creep auto off newton:2000 --out /tmp/newton-replay.csv

Rows are appended (CPU seconds of this process: ``time.process_time``).
"""

from __future__ import annotations

import argparse
import logging
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

import jamflow
from jamflow.engines.compiled.engine import CompiledEngine
from jamflow.mechanics.checks import check_packing
from jamflow.minimize import newton
from jamflow.minimize.rules import minimize
from jamflow.minimize.settings import CREEP_METHODS, MinimizerSettings
from jamflow.protocols.settings import fast_protocol

from common import append_row, check_outputs  # (benchmarks/ is the script's directory)

SINGLE = ["n", "dim", "seed", "dphi", "method", "converged", "iterations", "cg_iterations", "factorisations",
          "energy_per_particle", "max_force", "cpu_s"]
WATCH = ["n", "dim", "seed", "step", "phi", "iterations", "energy_per_particle", "max_force", "pressure", "contacts",
         "contacts_changed"]
REPLAY = ["n", "dim", "seed", "step", "creep", "iterations", "reason", "energy_per_particle", "max_force",
          "creep_steps", "cpu_s"]
JAM = ["n", "dim", "seed", "creep", "phi_j", "minimisations", "iterations", "energy_per_particle", "checks", "cpu_s"]


def sizes_of(dim: int) -> str:
    return "bi:1.4:0.5" if dim == 2 else "mono"


def compressed(packing, dphi: float):
    """The packing compressed affinely to phi + dphi (particles follow the box)."""
    box = packing.box.scaled((packing.phi / (packing.phi + dphi)) ** (1 / packing.dim))
    return packing.with_positions(box.to_cartesian(packing.box.to_fractional(packing.positions)), box=box)


def single_rows(n: int, dim: int, seed: int, dphis):
    onset = jamflow.jam(n=n, dim=dim, sizes=sizes_of(dim), seed=seed).packing
    settings = MinimizerSettings(creep="off")
    for dphi in dphis:
        start = compressed(onset, dphi)
        base = dict(n=n, dim=dim, seed=seed, dphi=dphi)
        with CompiledEngine(start) as eng:
            c0 = time.process_time()
            res = minimize(eng, settings)
            yield {**base, "method": "fire", "converged": res.converged, "iterations": res.iterations,
                   "cg_iterations": 0, "factorisations": 0, "energy_per_particle": f"{res.energy_per_particle:.12e}",
                   "max_force": f"{res.max_force:.3e}", "cpu_s": f"{time.process_time() - c0:.3f}"}
        with CompiledEngine(start) as eng:
            ftol = settings.force_tol_for(eng.template, box=eng.box)
            c0 = time.process_time()
            res = newton.relax(eng, ftol)
            cpu = time.process_time() - c0
            yield {**base, "method": "newton", "converged": res.converged, "iterations": res.steps + res.rejected,
                   "cg_iterations": res.cg_iterations, "factorisations": res.factorisations,
                   "energy_per_particle": f"{eng.state().energy / n:.12e}", "max_force": f"{res.max_force:.3e}",
                   "cpu_s": f"{cpu:.3f}"}


TRACE = ["step", "phi", "dphi", "V", "reason", "iterations", "max_force", "creep_steps", "cpu_s"]


def tracer(path: Path | None, c0: float):
    """Observers of a jam that append a row per minimisation to ``path`` as it ends (none if None)."""
    if path is None:
        return ()

    def observe(step):
        r = step["result"]
        append_row(path, TRACE, dict(step=step["step"], phi=f"{step['phi']:.12f}", dphi=f"{step['dphi']:.3e}",
                                     V=f"{r.energy_per_particle:.4e}", reason=r.reason, iterations=r.iterations,
                                     max_force=f"{r.max_force:.3e}", creep_steps=r.creep_steps,
                                     cpu_s=f"{time.process_time() - c0:.1f}"))

    return (observe,)


def jam_row(n: int, dim: int, seed: int, creep: str, trace: Path | None = None) -> dict:
    c0 = time.process_time()
    res = jamflow.jam(n=n, dim=dim, sizes=sizes_of(dim), seed=seed, observers=tracer(trace, c0),
                      settings=fast_protocol(minimizer=MinimizerSettings(creep=creep)))
    cpu = time.process_time() - c0
    checks = check_packing(res.packing, res.energy_per_particle, None, res.settings.v_tol)
    return dict(n=n, dim=dim, seed=seed, creep=creep, phi_j=f"{res.phi_j:.12f}", minimisations=len(res.history["phi"]),
                iterations=int(res.history["iterations"].sum()), energy_per_particle=f"{res.energy_per_particle:.4e}",
                checks=checks.passed, cpu_s=f"{cpu:.2f}")


def start_of_step(n: int, dim: int, seed: int, step: int):
    """The configuration (at its box) that minimisation ``step`` of the default jam starts from, and
    that minimisation's settings (the protocol's ``minimize`` wrapped for the one run)."""
    starts = starts_of_jam(n, dim, seed)
    if not 0 <= step < len(starts):
        raise SystemExit(f"error: --step {step}: the jam ran {len(starts)} minimisations (0 .. {len(starts) - 1})")
    return starts[step]


def starts_of_jam(n: int, dim: int, seed: int) -> list:
    """(packing, settings) of every minimisation of the default jam, as each started."""
    import jamflow.protocols.compression as compression

    starts = []
    plain = compression.minimize

    def recording(sim, settings):
        starts.append((sim.packing(), settings))
        return plain(sim, settings)

    compression.minimize = recording
    try:
        jamflow.jam(n=n, dim=dim, sizes=sizes_of(dim), seed=seed)
    finally:
        compression.minimize = plain
    return starts


def replay_rows(n: int, dim: int, seed: int, steps, creeps):
    """Minimisations ``steps`` of the default jam again, from their starts, with each creep method
    ("METHOD" or "METHOD:AFTER", AFTER the FIRE iterations before its first attempt)."""
    starts = starts_of_jam(n, dim, seed)
    for step in steps:
        if not 0 <= step < len(starts):
            raise SystemExit(f"error: --steps {step}: the jam ran {len(starts)} minimisations")
        packing, settings = starts[step]
        for creep in creeps:
            method, _, after = creep.partition(":")
            run = replace(settings, creep=method, creep_after=int(after) if after else settings.creep_after)
            with CompiledEngine(packing) as eng:
                c0 = time.process_time()
                res = minimize(eng, run)
                cpu = time.process_time() - c0
            yield dict(n=n, dim=dim, seed=seed, step=step, creep=creep, iterations=res.iterations, reason=res.reason,
                       energy_per_particle=f"{res.energy_per_particle:.12e}", max_force=f"{res.max_force:.3e}",
                       creep_steps=res.creep_steps, cpu_s=f"{cpu:.2f}")


def contacts_of(packing) -> set:
    """The pairs (i, j, image offset) in contact (delta > 0)."""
    model = newton.Model.at(packing, packing.positions)
    rows, cols = model.jac.nonzero()
    on = model.delta > 0
    ij = {}
    for r, c in zip(rows, cols):
        ij.setdefault(r, set()).add(c // packing.dim)
    return {tuple(sorted(ij[r])) for r in np.flatnonzero(on)}


def watch_rows(n: int, dim: int, seed: int, step: int, windows: int):
    packing, settings = start_of_step(n, dim, seed, step)
    settings = replace(settings, creep="off")
    with CompiledEngine(packing) as eng:
        ftol = settings.force_tol_for(eng.template, box=eng.box)
        before = contacts_of(eng.packing())
        with eng.minimizer_session(settings, ftol) as window:
            done = 0
            for _ in range(windows):
                w = window(settings.window)
                done += w.iterations
                now = contacts_of(eng.packing())
                yield dict(n=n, dim=dim, seed=seed, step=step, phi=f"{packing.phi:.10f}", iterations=done,
                           energy_per_particle=f"{w.objective / n:.6e}", max_force=f"{w.max_force:.3e}",
                           pressure=f"{eng.state().pressure:.5e}", contacts=len(now), contacts_changed=len(now ^ before))
                before = now
                if w.max_force < ftol:
                    break


def creep_choice(text: str) -> str:
    """A creep method, or METHOD:AFTER (replay)."""
    method, _, after = text.partition(":")
    if method not in CREEP_METHODS or (after and not after.isdigit()):
        raise argparse.ArgumentTypeError(f"{text!r}: use one of {', '.join(CREEP_METHODS)}, optionally :ITERATIONS")
    return text


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("mode", choices=("single", "jam", "watch", "replay"))
    ap.add_argument("--dim", type=int, default=2)
    ap.add_argument("--n", type=int, nargs="+", default=[1024])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1])
    ap.add_argument("--dphi", type=float, nargs="+", default=[1e-7, 1e-6, 1e-5, 1e-4], help="single: compressions")
    ap.add_argument("--creep", nargs="+", default=["auto", "newton"], type=creep_choice,
                    help="jam, replay: creep methods (replay also METHOD:AFTER)")
    ap.add_argument("--steps", type=int, nargs="+", default=[0], help="replay: which minimisations of the default jam")
    ap.add_argument("--step", type=int, default=0, help="watch: which minimisation of the default jam")
    ap.add_argument("--windows", type=int, default=30, help="watch: FIRE windows to run at most")
    ap.add_argument("--trace", type=Path, default=None, metavar="CSV",
                    help="jam: also append a row per minimisation as it ends (a long run stopped from outside leaves its path)")
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args(argv)
    check_outputs(args.out, args.trace)
    if args.trace is not None:  # each Newton attempt's steps, CG iterations, factorisations and CPU s on stderr
        logging.basicConfig(format="%(asctime)s %(message)s")
        logging.getLogger("jamflow.minimize.newton").setLevel(logging.INFO)
    for n in args.n:
        for seed in args.seeds:
            if args.mode == "watch":
                for row in watch_rows(n, args.dim, seed, args.step, args.windows):
                    append_row(args.out, WATCH, row)
                    print(row, flush=True)
                continue
            if args.mode == "replay":
                for row in replay_rows(n, args.dim, seed, args.steps, args.creep):
                    append_row(args.out, REPLAY, row)
                    print(row, flush=True)
                continue
            if args.mode == "single":
                for row in single_rows(n, args.dim, seed, args.dphi):
                    append_row(args.out, SINGLE, row)
                    print(row, flush=True)
                continue
            for creep in args.creep:  # alternating, the same seed: side by side in one run
                row = jam_row(n, args.dim, seed, creep, args.trace)
                append_row(args.out, JAM, row)
                print(row, flush=True)


if __name__ == "__main__":
    main()
