"""Ahead-of-time compiled kernels against numba's start-up floor (issue 17, item 1; docs/speed-2.md
section 10).

Builds, with ``numba.pycc.CC``, an extension module exporting the compiled engine's disk/sphere
FIRE (``jamflow.engine.compiled.fire.fire`` over the ``spheres`` kernel and the spring law: the
same njit functions, behind a wrapper of plain arrays with an explicit signature) into a
temporary directory, then times whole processes, alternating run by run so that all see the
same load:

- ``numpy``, ``numpy+scipy.spatial``, ``numpy+h5py``: ``python -c "import numpy[, ...]"``;
- ``aot``: a process that imports the AOT module and runs one N = 64 minimisation with it;
- ``numba``: the same minimisation with the numba-cached ``fire`` (cache warmed first);
- ``jam``: ``jamflow jam --n 64 --seed S --quiet``;
- ``jam-aot``: the same command with the compiled engine's two kernel calls swapped for the AOT
  module's and numba replaced by a stand-in that compiles nothing (``AOT_SWAP``,
  ``NUMBA_STAND_IN``): what a jam costs when it neither imports nor starts numba;
- ``jam-aot+numba``: the swap alone (numba imported, never called);
- ``jam-aot-no-spatial``: ``jam-aot`` with scipy.spatial replaced by the AOT module's cell list
  (``SPATIAL_STAND_IN``, ``benchmarks/cell_list.py``).

Both minimisations start from one saved state (``jamflow.jam(n=64, seed=1)``'s packing compressed
affinely by dphi = 0.01, skin 1 so that no pair-list rebuild is needed) and must end bit-identical
(iterations, energy and positions), and the four jams must give the same phi_J (to the bit),
iterations and minimisations; the AOT process also reports whether numba was imported.
``--speed N ...`` times both kernels per FIRE iteration in one process (the N-particle seed 1
packing compressed by 0.01) and checks they end bit-identical.

    python benchmarks/aot_startup.py --repeats 7 --target-cpu host --out docs/aot-startup.csv
    python benchmarks/aot_startup.py --speed-only --speed 256 1024 --target-cpu host   # and --target-cpu ''

Times are ``/usr/bin/time`` (wall, user + sys) of each process; rows go to the CSV with the
load average. Set ``OPENBLAS_NUM_THREADS=1`` to keep numpy's threads off the second core.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from cell_list import cell_pairs  # (benchmarks/ is the script's directory)
from speed_accuracy import append_row

MODULE = "jamflow_aot_bench"
N, DPHI, SEED, SKIN, STEPS, FTOL = 64, 0.01, 1, 1.0, 100_000, 1e-13
A1, A2, A3, I1 = "float64[::1]", "float64[:, ::1]", "float64[:, :, ::1]", "int64[::1]"
# fire_spheres_spring(i, j, shift, sigma, alpha, epsilon, <Field>, <fire's arrays>, scalars)
FIRE_SIGNATURE = ("Tuple((int64, int64, float64))("
                  f"{I1}, {I1}, {A2}, {A1}, float64, float64, "
                  f"{A2}, {A1}, {A1}, {A1}, boolean, float64, {A3}, float64, float64, "
                  f"{A2}, {A2}, {A2}, {A2}, {A2}, {A2}, {A2}, {A2}, {A1}, {A2}, {A1}, {A1}, {A1}, {A2}, {A1}, {A1}, "
                  "float64, int64, float64, float64)")
FORCES_SIGNATURE = ("float64("
                    f"{I1}, {I1}, {A2}, {A1}, float64, float64, "
                    f"{A2}, {A1}, {A1}, {A1}, boolean, float64, {A3}, float64, float64, "
                    f"{A2}, {A2}, {A2}, {A2}, {A2}, {A2}, {A1}, {A2}, {A1})")
CELL_PAIRS_SIGNATURE = "Tuple((int64[::1], int64[::1]))(float64[:, ::1], float64[::1], int64[::1], float64)"
PAIRS = ("i", "j", "shift", "sigma")
FIELD = ("h", "walled", "half", "mobile", "any_fixed", "gravity", "basis", "pressure", "length")
ARRAYS = ("x", "v", "f", "o", "w", "tau", "g", "dk", "mask", "virial", "ub", "gb", "state", "x_built", "turned",
          "reach")
SCALARS = ("half_skin_sq", "max_steps", "ftol", "energy_halt")

# the child processes: load the state, minimise once, print what the minimum is (bits)
LOAD = """import sys, hashlib, time
import numpy as np
d = dict(np.load(sys.argv[1]))
arrays = [d[k] for k in {arrays}]
field = [bool(d[k]) if k == "any_fixed" else (float(d[k]) if d[k].ndim == 0 else d[k]) for k in {field}]
scalars = [float(d["half_skin_sq"]), int(d["max_steps"]), float(d["ftol"]), float(d["energy_halt"])]
"""
REPORT = """seconds = time.process_time() - t0
print(int(it), int(reason), float(energy).hex(), hashlib.sha256(arrays[0].tobytes()).hexdigest()[:16],
      int("numba" in sys.modules), "%.4f" % seconds)
"""
AOT_RUN = LOAD + """import {module}
t0 = time.process_time()
it, reason, energy = {module}.fire_spheres_spring(d["i"], d["j"], d["shift"], d["sigma"], float(d["alpha"]),
                                                   float(d["epsilon"]), *field, *arrays, *scalars)
""" + REPORT
# a jamflow process whose compiled engine calls the AOT kernels: the engine's two kernel calls
# (``fire.fire``, ``fire.forces``) go to the AOT module; with NUMBA_STAND_IN first, numba itself is
# replaced by a stand-in that compiles nothing (jamflow's kernel modules import it to decorate), so
# that anything else reaching a kernel would run as plain Python (slow, not wrong: it would show in
# the time); without it numba is imported but never called (no target-context set-up)
AOT_SWAP = """import sys
import {module} as aot
from jamflow.engine.compiled import fire as kernels
from jamflow.potentials import SpringParams

def _flat(model, fld):
    assert type(model.law) is SpringParams, "the AOT module holds the spring only"
    return (model.i, model.j, model.shift, model.sigma, model.law.alpha, model.law.epsilon, fld.h, fld.walled,
            fld.half, fld.mobile, fld.any_fixed, fld.gravity, fld.basis, fld.pressure, fld.length)

kernels.fire = lambda model, fld, *rest: aot.fire_spheres_spring(*_flat(model, fld), *rest)
kernels.forces = lambda model, fld, *rest: aot.forces_spheres_spring(*_flat(model, fld), *rest)
"""
NUMBA_STAND_IN = """import sys, types
numba = types.ModuleType("numba")
numba.__version__ = "stand-in"
numba.njit = lambda *a, **k: (lambda fn: fn)
numba.config = types.SimpleNamespace(CACHE_DIR="")
numba.extending = types.ModuleType("numba.extending")
numba.extending.overload = numba.extending.register_jitable = lambda *a, **k: (lambda fn: fn)
sys.modules["numba"], sys.modules["numba.extending"] = numba, numba.extending
"""
# between NUMBA_STAND_IN and AOT_SWAP: scipy.spatial replaced by a cKDTree of the AOT cell list
# (``benchmarks/cell_list.py``, the same pair set: docs/speed-2.md 7.1), so that the jam process
# imports neither numba nor scipy.spatial (the orthogonal boxes of ``pairs.neighbor_pairs`` only)
SPATIAL_STAND_IN = """import numpy as np
spatial = types.ModuleType("scipy.spatial")

class _CellTree:
    def __init__(self, data, boxsize=None):
        self.x = np.ascontiguousarray(data, dtype=float)
        box = np.zeros(self.x.shape[1]) if boxsize is None else np.asarray(boxsize, float)
        self.periodic = (box > 0).astype(np.int64)
        self.lengths = np.where(box > 0, box, np.maximum(self.x.max(axis=0), 1e-300))

    def query_pairs(self, r, output_type="ndarray"):
        i, j = aot.cell_pairs(self.x, self.lengths, self.periodic, float(r))
        return np.stack([i, j], axis=1)

spatial.cKDTree = _CellTree
sys.modules["scipy.spatial"] = spatial
"""
JAM_RESULT = """import sys
from jamflow.protocols.compression import jam
res = jam(n=64, seed=int(sys.argv[1]))
print(res.phi_j.hex(), res.iterations, res.minimizations, res.engine, getattr(sys.modules["numba"], "__version__"),
      "scipy.spatial:" + ("scipy" if hasattr(sys.modules["scipy.spatial"], "__file__") else "stand-in"))
"""
JAM_CLI = """from jamflow.cli import main
sys.exit(main(sys.argv[1:]))
"""
NUMBA_RUN = LOAD + """from jamflow.engine.compiled.fire import fire
from jamflow.engine.compiled.field import Field
from jamflow.engine.compiled.spheres import Pairs
from jamflow.potentials import SpringParams
law = SpringParams(float(d["alpha"]), float(d["epsilon"]))
model = Pairs(d["i"], d["j"], d["shift"], d["sigma"], law)
fld = Field(field[0], field[1], law, *field[2:])
t0 = time.process_time()  # the first call: numba's set-up and cache load included
it, reason, energy = fire(model, fld, *arrays, *scalars)
""" + REPORT


def build(out_dir: Path, target_cpu: str = "") -> float:
    """Compile the AOT module into ``out_dir``; return the build's CPU seconds (this process)."""
    import warnings

    t0 = _cpu()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        from numba.pycc import CC
    for w in caught:
        print(f"pycc: {w.category.__name__}: {str(w.message).splitlines()[0]}")
    cc = CC(MODULE)
    cc.output_dir = str(out_dir)
    cc.target_cpu = target_cpu
    fire_body, forces_body = _compiled_bodies()
    cc.export("fire_spheres_spring", FIRE_SIGNATURE)(fire_body)
    cc.export("forces_spheres_spring", FORCES_SIGNATURE)(forces_body)
    cc.export("cell_pairs", CELL_PAIRS_SIGNATURE)(cell_pairs)
    cc.compile()
    return _cpu() - t0


def _cpu() -> float:
    """User + sys seconds of this process and its finished children (pycc runs gcc)."""
    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def _compiled_bodies():
    """The exported wrappers; pycc compiles their bodies, so the imports are their globals."""
    from jamflow.engine.compiled.field import Field
    from jamflow.engine.compiled.fire import fire, forces
    from jamflow.engine.compiled.spheres import Pairs
    from jamflow.potentials import SpringParams

    def fire_body(pi, pj, shift, sigma, alpha, epsilon, h, walled, half, mobile, any_fixed, gravity, basis, pressure,
                  length, x, v, f, o, w, tau, g, dk, mask, virial, ub, gb, state, x_built, turned, reach, half_skin_sq,
                  max_steps, ftol, energy_halt):
        law = SpringParams(alpha, epsilon)
        return fire(Pairs(pi, pj, shift, sigma, law), Field(h, walled, law, half, mobile, any_fixed, gravity, basis,
                                                             pressure, length),
                    x, v, f, o, w, tau, g, dk, mask, virial, ub, gb, state, x_built, turned, reach, half_skin_sq,
                    max_steps, ftol, energy_halt)

    def forces_body(pi, pj, shift, sigma, alpha, epsilon, h, walled, half, mobile, any_fixed, gravity, basis, pressure,
                    length, x, f, o, tau, g, dk, mask, virial, gb):
        law = SpringParams(alpha, epsilon)
        return forces(Pairs(pi, pj, shift, sigma, law), Field(h, walled, law, half, mobile, any_fixed, gravity, basis,
                                                               pressure, length),
                      x, f, o, tau, g, dk, mask, virial, gb)

    return fire_body, forces_body


def prepare(path: Path, n: int = N) -> None:
    """Save the arguments of one FIRE call: jamflow's N-particle seed 1 packing compressed by DPHI."""
    from jamflow.engine.compiled import fire
    from jamflow.engine.compiled.engine import CompiledEngine
    from jamflow.protocols.compression import jam

    jammed = jam(n=n, seed=SEED).packing
    packing = jammed.scaled_to_phi(jammed.phi + DPHI)
    engine = CompiledEngine(packing, skin=SKIN)
    pairs, fld = engine._model(), engine._field
    x = engine._x
    arrays = dict(x=x, v=np.zeros_like(x), f=engine._f, o=engine._o, w=np.zeros_like(engine._g), tau=engine._tau,
                  g=engine._g, dk=engine._dk, mask=engine._mask, virial=engine._virial, ub=np.zeros(0), gb=engine._gb,
                  state=fire.fire_state(0.1), x_built=engine._built_at, turned=engine._turned, reach=engine._reach)
    np.savez(path, **{k: getattr(pairs, k) for k in PAIRS}, alpha=pairs.law.alpha, epsilon=pairs.law.epsilon,
             **{k: getattr(fld, k) for k in FIELD}, **arrays, half_skin_sq=(SKIN / 2) ** 2, max_steps=STEPS,
             ftol=FTOL, energy_halt=-np.inf)


def kernel_speed(state: Path, module_dir: Path, repeats: int) -> dict:
    """In this process: CPU microseconds per FIRE iteration of the AOT and the numba kernel on
    ``state`` (each call on fresh copies, after a warm-up call; alternating; medians)."""
    import importlib

    from jamflow.engine.compiled.field import Field
    from jamflow.engine.compiled.fire import fire
    from jamflow.engine.compiled.spheres import Pairs
    from jamflow.potentials import SpringParams

    sys.path.insert(0, str(module_dir))
    aot = importlib.import_module(MODULE)
    d = dict(np.load(state))
    law = SpringParams(float(d["alpha"]), float(d["epsilon"]))
    fld_args = [bool(d[k]) if k == "any_fixed" else (float(d[k]) if d[k].ndim == 0 else d[k]) for k in FIELD]
    scalars = [float(d["half_skin_sq"]), int(d["max_steps"]), float(d["ftol"]), float(d["energy_halt"])]

    def run(kind):
        arrays = [d[k].copy() for k in ARRAYS]
        shift = d["shift"].copy()
        t0 = time.process_time()
        if kind == "aot":
            it, *_ = aot.fire_spheres_spring(d["i"], d["j"], shift, d["sigma"], law.alpha, law.epsilon, *fld_args,
                                             *arrays, *scalars)
        else:
            it, *_ = fire(Pairs(d["i"], d["j"], shift, d["sigma"], law), Field(*fld_args[:2], law, *fld_args[2:]),
                          *arrays, *scalars)
        return 1e6 * (time.process_time() - t0) / it, (it, arrays[0].tobytes())

    same = run("aot")[1] == run("numba")[1]  # warm-up, and the same iterations and positions (bits)
    per = {"aot": [], "numba": []}
    for _ in range(repeats):
        for kind in per:
            us, (iterations, _) = run(kind)
            per[kind].append(us)
    return {k: statistics.median(v) for k, v in per.items()} | {"iterations": iterations, "same": same}


def timed(argv, env) -> tuple[float, float, str]:
    """(wall s, user + sys s, stdout) of one process, from ``/usr/bin/time``."""
    with tempfile.NamedTemporaryFile("r", suffix=".time") as fh:
        out = subprocess.run(["/usr/bin/time", "-o", fh.name, "-f", "%e %U %S", *argv], env=env, check=True,
                             capture_output=True, text=True).stdout
        wall, user, sys_ = map(float, fh.read().split()[-3:])
    return wall, user + sys_, out.strip()


def processes(tmp: Path, seed: int) -> dict:
    """name -> argv of the whole processes timed (module docstring)."""
    fmt = dict(arrays=repr(ARRAYS), field=repr(FIELD), module=MODULE)
    swap, state = AOT_SWAP.format(**fmt), str(tmp / "state.npz")
    jam_args = ["jam", "--n", "64", "--seed", str(seed), "--quiet", "--out", str(tmp / "p.h5"), "--force"]
    return {"numpy": ["-c", "import numpy"], "numpy+scipy.spatial": ["-c", "import numpy, scipy.spatial"],
            "numpy+h5py": ["-c", "import numpy, h5py"],
            "aot": ["-c", AOT_RUN.format(**fmt), state], "numba": ["-c", NUMBA_RUN.format(**fmt), state],
            "jam": ["-m", "jamflow.cli", *jam_args],
            "jam-aot": ["-c", NUMBA_STAND_IN + swap + JAM_CLI, *jam_args],
            "jam-aot+numba": ["-c", swap + JAM_CLI, *jam_args],
            "jam-aot-no-spatial": ["-c", NUMBA_STAND_IN + SPATIAL_STAND_IN + swap + JAM_CLI, *jam_args]}


def same_results(procs: dict, env: dict, seed: int) -> bool:
    """Run each process once (the warm-up); print and compare the minimisations' and the jams' results."""
    outputs = {k: timed(argv, env)[2] for k, argv in procs.items()}
    print("aot   ", outputs["aot"], "(iterations, reason, energy, sha of x, numba imported, CPU s of the call)")
    print("numba ", outputs["numba"])
    same = outputs["aot"].split()[:4] == outputs["numba"].split()[:4]
    preludes = {"numba": "", "aot": procs["jam-aot"][2], "aot+numba": procs["jam-aot+numba"][2],
                "no-spatial": procs["jam-aot-no-spatial"][2]}
    lines = {}
    for k, prelude in preludes.items():
        code = prelude.replace(JAM_CLI, "") + JAM_RESULT
        lines[k] = subprocess.run([sys.executable, "-c", code, str(seed)], env=env, check=True, capture_output=True,
                                  text=True).stdout.strip()
        print(f"jam(n=64, seed={seed}) {k:10s}: {lines[k]} (phi_J, iterations, minimisations, engine, numba, spatial)")
    same = same and all(line.split()[:3] == lines["numba"].split()[:3] for line in lines.values())
    print("bit-identical:", same)
    return same


def alternate(procs: dict, env: dict, repeats: int) -> tuple[dict, list]:
    """(name -> [(wall, cpu)], loads): every process once per round, ``repeats`` rounds."""
    runs, loads = {k: [] for k in procs}, []
    for _ in range(repeats):
        for k, argv in procs.items():
            runs[k].append(timed(argv, env)[:2])
        loads.append(os.getloadavg()[0])
    return runs, loads


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--seed", type=int, default=1, help="seed of the jamflow jam --n 64 process")
    ap.add_argument("--out", default=None, help="CSV to append the rows to")
    ap.add_argument("--speed", type=int, nargs="*", default=[], help="also time the kernels per iteration at these N")
    ap.add_argument("--speed-only", action="store_true", help="only the per-iteration timing (--speed)")
    ap.add_argument("--speed-repeats", type=int, default=3)
    ap.add_argument("--target-cpu", default="", help="pycc's target CPU ('' = generic, pycc's default; 'host')")
    args = ap.parse_args()
    target = args.target_cpu or "generic"
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        build_cpu = build(tmp, args.target_cpu)
        print(f"AOT module built in {build_cpu:.1f} CPU s (target {target}): {[p.name for p in tmp.glob(MODULE + '*')]}")
        for n in args.speed:
            prepare(tmp / f"state-{n}.npz", n)
            speed = kernel_speed(tmp / f"state-{n}.npz", tmp, args.speed_repeats)
            print(f"N = {n}: {speed['iterations']} iterations, bit-identical {speed['same']}; CPU us per iteration: "
                  f"AOT {speed['aot']:.2f}, numba {speed['numba']:.2f} (medians of {args.speed_repeats}, alternating; "
                  f"target {target}, load {os.getloadavg()[0]:.2f})")
        if args.speed_only:
            return
        prepare(tmp / "state.npz")
        env = {**os.environ, "PYTHONPATH": str(tmp), "OPENBLAS_NUM_THREADS": "1"}
        procs = {k: [sys.executable, *argv] for k, argv in processes(tmp, args.seed).items()}
        same = same_results(procs, env, args.seed)
        runs, loads = alternate(procs, env, args.repeats)
    for k, r in runs.items():
        walls, cpus = [w for w, _ in r], [c for _, c in r]
        row = {"what": k, "seed": args.seed, "target_cpu": target,
               "wall_median_s": round(statistics.median(walls), 3), "wall_min_s": round(min(walls), 3),
               "cpu_median_s": round(statistics.median(cpus), 3), "cpu_min_s": round(min(cpus), 3), "repeats": len(r),
               "load_median": round(statistics.median(loads), 2), "bit_identical": same,
               "build_cpu_s": round(build_cpu, 2)}
        print(f"{k:19s} wall {row['wall_median_s']:.3f} s (min {row['wall_min_s']:.3f})  cpu {row['cpu_median_s']:.3f} s "
              f"(min {row['cpu_min_s']:.3f})  load {row['load_median']:.2f}")
        if args.out:
            append_row(Path(args.out), list(row), row)


if __name__ == "__main__":
    main()
