"""ABC-FIRE against jamflow's FIRE 2.0 (issue 27 item 3): iterations on the same seeds.

ABC-FIRE (Echeverri Restrepo and Andric, Comput. Mater. Sci. 218, 111978 (2023); ASE's
``optimize/fire2.py`` with ``use_abc``) divides FIRE's mixed velocity by 1 - (1 - alpha)^(n + 1), n
the steps since the last P < 0, and caps each velocity component at dmax / dt. The compiled FIRE
carries it as a flag in its state (``fire.fire_state(dt0, abc=True)``); this script switches it on
for the whole process by wrapping ``fire_state`` (the engine looks it up at each window).

Two measurements, FIRE 2.0 and ABC-FIRE alternately: whole ``jamflow.jam`` runs (defaults, 2D 50:50
bidisperse), and single minimisations from the same states (each seed's onset compressed by dphi,
``minimize(CompiledEngine(state))`` with default settings).

    python benchmarks/abc_fire.py --n 64 256 1024 --seeds 1 2 3 --states 256 1024 --out docs/notes/abc-fire.csv
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import jamflow
from jamflow.engines.compiled import fire
from jamflow.engines.compiled.engine import CompiledEngine
from jamflow.minimize.rules import minimize
from jamflow.minimize.settings import MinimizerSettings

from benchmarks.common import write_rows

FIRE_STATE = fire.fire_state
DPHI = (1e-2, 1e-4, 1e-6)


def use_abc(on: bool) -> None:
    fire.fire_state = lambda dt0, abc=on: FIRE_STATE(dt0, abc)


def whole_jams(n: int, seeds) -> list[dict]:
    rows = []
    for seed in seeds:
        for abc in (False, True):
            use_abc(abc)
            t = time.process_time()
            res = jamflow.jam(n=n, seed=seed)
            rows.append(dict(kind="jam", n=n, seed=seed, dphi="", method="abc-fire" if abc else "fire2",
                             iterations=res.iterations, phi_j=f"{res.phi_j:.12f}", reason="",
                             cpu_s=round(time.process_time() - t, 2)))
            print(rows[-1], flush=True)
    return rows


def minimisations(n: int, seeds) -> list[dict]:
    rows = []
    for seed in seeds:
        use_abc(False)
        onset = jamflow.jam(n=n, seed=seed).packing
        for dphi in DPHI:
            start = onset.scaled_to_phi(onset.phi + dphi)
            for abc in (False, True):
                use_abc(abc)
                t = time.process_time()
                res = minimize(CompiledEngine(start), MinimizerSettings())
                rows.append(dict(kind="minimisation", n=n, seed=seed, dphi=dphi, method="abc-fire" if abc else "fire2",
                                 iterations=res.iterations, phi_j="", reason=res.reason,
                                 cpu_s=round(time.process_time() - t, 2)))
                print(rows[-1], flush=True)
    return rows


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[64, 256])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--states", type=int, nargs="*", default=[256], help="N of the single-minimisation study")
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    rows = []
    for n in args.n:
        rows += whole_jams(n, args.seeds)
    for n in args.states:
        rows += minimisations(n, args.seeds)
    use_abc(False)
    if args.out:
        write_rows(Path(args.out), rows, list(rows[0]))


if __name__ == "__main__":
    main()
