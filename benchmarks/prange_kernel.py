"""The second core for one large packing (issue 17, item 6): the disk/sphere force kernel and a
whole FIRE iteration with numba ``prange``, against the serial engine, measured.

    python benchmarks/prange_kernel.py --sizes 1024 4096 16384 --dim3 4096 --states DIR --prepare
    flock /tmp/jamflow-bench.lock python benchmarks/prange_kernel.py --sizes 1024 4096 16384 \
        --dim3 4096 --repeats 12 --states DIR --out docs/prange-kernel.csv
    python benchmarks/prange_kernel.py --summary docs/prange-kernel.csv   # the speed-ups
    flock /tmp/jamflow-bench.lock python benchmarks/prange_kernel.py --startup 5   # fresh processes

Kernels (each gives the forces, energy and virial of ``compiled.spheres.forces`` to round-off,
checked; same arguments ``(model, x, o, f, tau, virial)``, so the engine's FIRE can run any of
them): ``serial``, the engine's kernel over the half pair list (i < j, sorted by i); ``csr``, a
per-particle loop over the full (both directions) neighbour list in CSR form, each particle
summing its own force (every pair evaluated twice), conflict-free under ``prange``; compiled
with and without ``parallel=True`` (``csr_1core``: the doubled work on one core, no threads);
``chunks``, the half list cut into CHUNKS equal runs of pairs, each evaluated by the engine's own
kernel into its own force buffer (``prange`` over the runs), the buffers summed at the end.
The spring law is the potentials' own (``laws.energy_force``), as in the engine.

FIRE: the engine's ``fire.fire`` compiled again from its own code with ``evaluate`` bound to
one of these kernels (``fire_with``), run from a relaxed state for a fixed number of iterations
on a fixed pair list (no rebuilds; the state moves far less than the skin, reported);
``passes``: FIRE's passes over the coordinates alone, serial and ``prange``; ``ceiling``: a
compute-bound ``prange`` loop, what the second core can give at all.

Times: CPU (process time: every thread) and WALL microseconds per force evaluation, FIRE
iteration or passes call, with 1 and 2 threads (``numba.set_num_threads``), minimum over
``--repeats`` round-robin rounds (``round_robin``). The run starts when the 1-minute load
average is <= ``--max-load``; each round starts when the other processes use <= ``--max-others``
cores (an idle 2 s sample), and the cores they used before and during the rounds are recorded.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
import types
from pathlib import Path
from typing import NamedTuple

import math

from kernel import near_jamming_state  # (benchmarks/ is the script's directory)
from speed_accuracy import append_row

import numba
import numpy as np
from numba import prange

from jamflow.engines.compiled import fire, spheres, start_numba
from jamflow.engines.compiled.engine import CompiledEngine
from jamflow.engines.compiled.field import deform
from jamflow.engines.compiled.laws import energy_force
from jamflow.minimize.settings import MinimizerSettings

start_numba()  # jamflow's kernels as numba dispatchers (and its overloads registered) before they are recompiled here

CHUNKS = 2  # runs of the half list in ``chunks``: one per core of this machine


class Neighbours(NamedTuple):
    """The full neighbour list in CSR form: particle i's neighbours are j[start[i]:start[i + 1]],
    with image offsets shift (x_i - x_j + shift is the pair vector) and sigma_ij."""

    start: np.ndarray
    j: np.ndarray
    shift: np.ndarray
    sigma: np.ndarray
    law: tuple


class Chunked(NamedTuple):
    """The half list ``pairs`` cut at ``cuts`` (CHUNKS + 1 pair indices), with a force and a
    virial buffer per run. ``shift`` is the half list's (FIRE's box steps deform it)."""

    pairs: spheres.Pairs
    cuts: np.ndarray
    fbuf: np.ndarray  # (CHUNKS, N, d)
    wbuf: np.ndarray  # (CHUNKS, d, d)
    shift: np.ndarray


def neighbours(pairs: spheres.Pairs, n: int) -> Neighbours:
    """Both directions of every pair of the half list, grouped by the first particle."""
    i = np.concatenate([pairs.i, pairs.j])
    order = np.argsort(i, kind="stable")
    j = np.concatenate([pairs.j, pairs.i])[order]
    shift = np.concatenate([pairs.shift, -pairs.shift])[order]
    sigma = np.concatenate([pairs.sigma, pairs.sigma])[order]
    start = np.zeros(n + 1, np.int64)
    np.cumsum(np.bincount(i, minlength=n), out=start[1:])
    return Neighbours(start, j.astype(np.int64), np.ascontiguousarray(shift), sigma, pairs.law)


def chunked(pairs: spheres.Pairs, n: int) -> Chunked:
    d = pairs.shift.shape[1]
    cuts = np.linspace(0, len(pairs.i), CHUNKS + 1).round().astype(np.int64)
    return Chunked(pairs, cuts, np.zeros((CHUNKS, n, d)), np.zeros((CHUNKS, d, d)), pairs.shift)


def _csr_loop(start, nbr, shift, sigma, law, x, f, virial):
    """Each particle sums its own force over its neighbours; energy and virial are half the sums
    over both directions (the upper triangle of the virial, mirrored: central forces)."""
    n, d = x.shape
    energy = 0.0
    w00 = w01 = w11 = w02 = w12 = w22 = 0.0
    for i in prange(n):
        fi0 = fi1 = fi2 = 0.0
        for k in range(start[i], start[i + 1]):
            j, s = nbr[k], sigma[k]
            dr0 = x[i, 0] - x[j, 0] + shift[k, 0]
            dr1 = x[i, 1] - x[j, 1] + shift[k, 1]
            dr2 = x[i, 2] - x[j, 2] + shift[k, 2] if d == 3 else 0.0
            r2 = dr0 * dr0 + dr1 * dr1 + dr2 * dr2
            if r2 >= s * s:
                continue
            r = math.sqrt(r2)
            v, dv = energy_force(law, r / s)
            fr = -dv / (s * r)
            energy += v
            fi0 += fr * dr0
            fi1 += fr * dr1
            fi2 += fr * dr2
            w00 += fr * dr0 * dr0
            w01 += fr * dr0 * dr1
            w11 += fr * dr1 * dr1
            w02 += fr * dr0 * dr2
            w12 += fr * dr1 * dr2
            w22 += fr * dr2 * dr2
        f[i, 0], f[i, 1] = fi0, fi1
        if d == 3:
            f[i, 2] = fi2
    virial[0, 0], virial[1, 1] = 0.5 * w00, 0.5 * w11
    virial[0, 1] = virial[1, 0] = 0.5 * w01
    if d == 3:
        virial[2, 2] = 0.5 * w22
        virial[0, 2] = virial[2, 0] = 0.5 * w02
        virial[1, 2] = virial[2, 1] = 0.5 * w12
    return 0.5 * energy


_run = numba.njit(spheres.forces.py_func)  # the engine's kernel, uncached: chunks make new types


def _chunk_loop(pi, pj, ps, pg, law, cuts, fbuf, wbuf, x, o, f, tau, virial):
    """The engine's kernel on each run of the half list into its own buffer, then the sums."""
    n, d = x.shape
    energy = 0.0
    for c in prange(CHUNKS):
        a, b = cuts[c], cuts[c + 1]
        energy += _run(spheres.Pairs(pi[a:b], pj[a:b], ps[a:b], pg[a:b], law), x, o, fbuf[c], tau, wbuf[c])
    fs, fb = f.reshape(n * d), fbuf.reshape(CHUNKS, n * d)
    for k in prange(n * d):
        acc = 0.0
        for c in range(CHUNKS):
            acc += fb[c, k]
        fs[k] = acc
    virial[:, :] = wbuf.sum(axis=0)
    return energy


# A parfor cannot take a tuple holding a tuple (the law) as an argument: the loops take the fields.
_csr_par = numba.njit(parallel=True, cache=True)(_csr_loop)
_csr_1core = numba.njit(_csr_loop)
_chunk_par = numba.njit(parallel=True, cache=True)(_chunk_loop)


@numba.njit(cache=True)
def csr(m, x, o, f, tau, virial):
    return _csr_par(m.start, m.j, m.shift, m.sigma, m.law, x, f, virial)


@numba.njit
def csr_1core(m, x, o, f, tau, virial):
    return _csr_1core(m.start, m.j, m.shift, m.sigma, m.law, x, f, virial)


@numba.njit(cache=True)
def chunks(m, x, o, f, tau, virial):
    p = m.pairs
    return _chunk_par(p.i, p.j, p.shift, p.sigma, p.law, m.cuts, m.fbuf, m.wbuf, x, o, f, tau, virial)


def _passes(xs, vs, fs, x0, d, dtv, alpha):
    """FIRE's passes over the coordinates in one iteration, as ``fire.fire`` runs them when
    P = F.v > 0 (no rotations, fixed box): the fused dot products and max |v|, the velocity and
    position update, the max |f_i|^2 and displacement; returns what FIRE decides from."""
    m = xs.shape[0]
    vdotf = vdotv = fdotf = vmax = 0.0
    for k in prange(m):
        vdotf += vs[k] * fs[k]
        vdotv += vs[k] * vs[k]
        fdotf += fs[k] * fs[k]
        vmax = max(vmax, abs(vs[k]))
    scale1, scale2 = 1.0 - alpha, alpha * math.sqrt(vdotv / fdotf)
    for k in prange(m):
        vk = scale1 * (dtv * fs[k] + vs[k]) + scale2 * fs[k]
        vs[k] = vk
        xs[k] += dtv * vk
    fmax_sq = moved_sq = 0.0
    for i in prange(m // d):
        fi = mi = 0.0
        for k in range(i * d, i * d + d):
            fi += fs[k] * fs[k]
            mi += (xs[k] - x0[k]) ** 2
        fmax_sq = max(fmax_sq, fi)
        moved_sq = max(moved_sq, mi)
    return vdotf, vdotv, fdotf, vmax, fmax_sq, moved_sq


_passes_par = numba.njit(parallel=True)(_passes)
_passes_1core = numba.njit(_passes)


CEILING_WORK = 2_000_000  # square roots per ``_ceiling`` call (~1 ms)


@numba.njit(parallel=True)
def _ceiling(m):
    """Compute-bound work with no memory traffic: what a second thread can give on this machine."""
    acc = 0.0
    for k in prange(m):
        acc += math.sqrt(k + 0.5)
    return acc


@numba.njit
def _repeat_passes(passes, xs, vs, fs, x0, d, reps):
    acc = 0.0
    for _ in range(reps):
        acc += passes(xs, vs, fs, x0, d, 1e-12, 0.1)[0]
    return acc


class Counted(NamedTuple):
    """The half list and a counter of force evaluations (``counted``)."""

    pairs: spheres.Pairs
    calls: np.ndarray  # (1,) int64
    shift: np.ndarray


@numba.njit
def counted(m, x, o, f, tau, virial):
    """The engine's kernel, counting its calls: FIRE evaluates twice on a restart (P <= 0)."""
    m.calls[0] += 1
    return spheres.forces(m.pairs, x, o, f, tau, virial)


KERNELS = {  # name -> (compiled kernel, model from (half pairs, n)); parallel ones are cached
    "serial": (spheres.forces, lambda pairs, n: pairs),
    "csr_1core": (csr_1core, neighbours),
    "csr": (csr, neighbours),
    "chunks": (chunks, chunked),
    "counted": (counted, lambda pairs, n: Counted(pairs, np.zeros(1, np.int64), pairs.shift)),
}
PARALLEL = ("csr", "chunks")
TIMED = ("serial", "csr_1core", "csr", "chunks")


@numba.njit
def _repeat(kernel, model, x, o, f, tau, virial, reps):
    e = 0.0
    for _ in range(reps):
        e += kernel(model, x, o, f, tau, virial)
    return e


def _rebound(fn, **names):
    """``fn``'s own code compiled again (numba, no cache) with some of its globals rebound."""
    py = fn.py_func
    return numba.njit(types.FunctionType(py.__code__, {**py.__globals__, **names}, py.__name__, py.__defaults__))


def fire_with(kernel):
    """The engine's FIRE (``fire.fire``) calling ``kernel`` where it evaluates the pair forces."""
    evaluate = numba.njit(lambda model, x, o, f, tau, virial: kernel(model, x, o, f, tau, virial))
    forces = _rebound(fire.forces, evaluate=evaluate)
    return _rebound(fire.fire, forces=forces, deform=numba.njit(deform.py_func))


FIRES = {name: (fire.fire if name == "serial" else fire_with(kernel)) for name, (kernel, _) in KERNELS.items()}


# measurement --------------------------------------------------------------------------------------
def _busy_seconds() -> float:
    """CPU seconds every process of the machine has used (from /proc/stat)."""
    with open("/proc/stat") as fh:
        v = [int(t) for t in fh.readline().split()[1:]]
    return (sum(v) - v[3] - v[4]) / os.sysconf("SC_CLK_TCK")


class Probe(NamedTuple):
    """One timed thing: ``call()`` runs ``count`` units (force evaluations, FIRE iterations,
    passes calls) on ``threads`` threads."""

    key: tuple  # (row name, threads)
    column: str  # "call" or "fire"
    threads: int
    call: object
    count: int


def round_robin(probes: list[Probe], rounds: int, max_others: float, wait: float) -> tuple[dict, dict]:
    """Every probe once per round, ``rounds`` rounds, starting at the next probe each round
    (drift in the machine's speed hits every probe alike); the minimum CPU and wall microseconds per unit of each, and per round the
    cores the other processes used (idle sample before it, and during it)."""
    best = {}
    others = {"before": [], "during": []}
    for r in range(rounds):
        others["before"].append(wait_for_core(max_others, wait))
        b0, c0, t0 = _busy_seconds(), time.process_time(), time.perf_counter()
        probes[0].call()  # warm-up after the idle sample: the first probe paid for it (run 2)
        for p in probes[r % len(probes):] + probes[:r % len(probes)]:  # each probe first in turn
            numba.set_num_threads(p.threads)
            c, t = time.process_time(), time.perf_counter()
            p.call()
            cpu, wall = (time.process_time() - c) / p.count * 1e6, (time.perf_counter() - t) / p.count * 1e6
            old = best.get((p.key, p.column), (np.inf, np.inf))
            best[(p.key, p.column)] = (min(old[0], cpu), min(old[1], wall))
        others["during"].append((_busy_seconds() - b0 - (time.process_time() - c0)) / (time.perf_counter() - t0))
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    return best, others


def wait_for_load(max_load: float, wait: float) -> float:
    """Sleep until the 1-minute load average is <= max_load (at most ``wait`` seconds); return it."""
    end = time.time() + wait
    while os.getloadavg()[0] > max_load and time.time() < end:
        time.sleep(10)
    return round(os.getloadavg()[0], 2)


def wait_for_core(max_others: float, wait: float) -> float:
    """Sample, idle, the cores the other processes use (2 s windows) until it is <= max_others
    (at most ``wait`` seconds); return the last sample. The load average cannot tell: it counts
    this process's own last block."""
    end = time.time() + wait
    while True:
        b0, c0, t0 = _busy_seconds(), time.process_time(), time.perf_counter()
        time.sleep(2.0)
        others = (_busy_seconds() - b0 - (time.process_time() - c0)) / (time.perf_counter() - t0)
        if others <= max_others or time.time() > end:
            return round(max(others, 0.0), 2)


def _largest_pair_force(pairs, x) -> float:
    """max over contacts of |dV/dr| (numpy, the potential's own law)."""
    dr = x[pairs.i] - x[pairs.j] + pairs.shift
    s = np.sqrt(np.einsum("ij,ij->i", dr, dr)) / pairs.sigma
    inside = s < 1.0
    _, dv = energy_force(pairs.law, s[inside])
    return float(np.abs(dv / pairs.sigma[inside]).max())


class Case:
    """One relaxed state with its half pair list and the arrays the kernels and FIRE need."""

    def __init__(self, packing, skin: float = 0.3):
        self.packing = packing
        self.eng = CompiledEngine(packing, skin=skin)
        self.pairs = self.eng._model()
        n, d = packing.n, packing.dim
        self.models = {name: make(self.pairs, n) for name, (_, make) in KERNELS.items()}
        self.x = np.ascontiguousarray(self.eng._x)
        self.f, self.virial = np.zeros((n, d)), np.zeros((d, d))
        self.pair_force = _largest_pair_force(self.pairs, self.x)

    def evaluate(self, name: str):
        """(forces, energy, virial) of kernel ``name`` at the relaxed state."""
        e = KERNELS[name][0](self.models[name], self.x, self.eng._o, self.f, self.eng._tau, self.virial)
        return self.f.copy(), e, self.virial.copy()

    def kernel_call(self, name: str, reps: int):
        kernel, model = KERNELS[name][0], self.models[name]
        return lambda: _repeat(kernel, model, self.x, self.eng._o, self.f, self.eng._tau, self.virial, reps)

    def fire_run(self, name: str, iterations: int):
        """Run ``iterations`` FIRE iterations of variant ``name`` from the relaxed state; return
        (positions, energy, iterations run)."""
        e = self.eng
        x, v, w, u = self.x.copy(), np.zeros_like(self.x), np.zeros_like(e._g), np.zeros_like(e._gb)
        ran, _, energy = FIRES[name](self.models[name], e._field, x, v, np.zeros_like(x), e._o, w, e._tau, e._g, e._dk,
                                     e._mask, np.zeros_like(self.virial), u, e._gb, fire.fire_state(MinimizerSettings().timestep), x.copy(),
                                     np.zeros(len(x)), e._reach, np.inf, iterations, 1e-300, -np.inf)
        return x, energy, ran


ROUND_OFF = 1e-12  # the largest relative difference that ``agreement`` accepts as round-off


def agreement(case: Case, name: str) -> dict:
    """How far kernel ``name`` is from the engine's: max |df| over max |f| (``df``; at a relaxed
    state |f| is the residual, ~1e-9, of pair forces ~1e-2 that cancel) and over the largest pair
    force (``df_pair``: round-off of the summands), relative energy and virial (max component)
    differences, and whether the forces are bit-identical."""
    f0, e0, w0 = case.evaluate("serial")
    f1, e1, w1 = case.evaluate(name)
    df = float(np.abs(f1 - f0).max())
    out = {"df": df / np.abs(f0).max(), "df_pair": df / case.pair_force, "de": abs(e1 - e0) / abs(e0),
           "dw": float(np.abs(w1 - w0).max() / np.abs(w0).max()), "same_bits": bool(np.array_equal(f0, f1))}
    if max(out["df_pair"], out["de"], out["dw"]) > ROUND_OFF:
        raise AssertionError(f"kernel {name} does not give the engine's forces: {out}")
    return out


def _report(row: dict) -> dict:
    print(" ".join(f"{k}={v:.3g}" if isinstance(v, float) else f"{k}={v}" for k, v in row.items()), flush=True)
    return row


def measure(case: Case, label: str, args) -> list[dict]:
    """Rows for every kernel and its FIRE (``call_*`` per force evaluation, ``fire_*`` per
    iteration), FIRE's passes alone and the ceiling (per call), at 1 (and, parallel, 2) threads."""
    n, d = case.packing.n, case.packing.dim
    reps, iterations = max(100, 2_000_000 // n), max(500, 2_000_000 // n)
    x_ref, e_ref, _ = case.fire_run("serial", iterations)
    case.models["counted"].calls[0] = 0
    case.fire_run("counted", iterations)
    head = {"case": label, "n": n, "pairs": len(case.pairs.i),
            "evals_per_iteration": round(case.models["counted"].calls[0] / iterations, 4)}
    checks, probes = {}, []
    for name in TIMED:
        case.kernel_call(name, 5)()  # compile
        x_fire, e_fire, ran = case.fire_run(name, iterations)
        checks[name] = {**agreement(case, name), "fire_dx": float(np.abs(x_fire - x_ref).max()),
                        "fire_de": abs(e_fire - e_ref) / abs(e_ref),
                        "fire_moved": float(np.abs(x_ref - case.x).max()), "fire_iterations": ran}
        for threads in ((1, 2) if name in PARALLEL else (1,)):
            probes.append(Probe((name, threads), "call", threads, case.kernel_call(name, reps), reps))
            probes.append(Probe((name, threads), "fire", threads,
                                lambda name=name: case.fire_run(name, iterations), iterations))
    f = case.evaluate("serial")[0].reshape(-1)
    xs, vs, x0 = case.x.reshape(-1).copy(), 0.05 * f, case.x.reshape(-1).copy()
    for name, passes, threads in (("passes_1core", _passes_1core, 1), ("passes", _passes_par, 1),
                                  ("passes", _passes_par, 2)):
        _repeat_passes(passes, xs, vs, f, x0, d, 5)
        probes.append(Probe((name, threads), "call", threads,
                            lambda passes=passes: _repeat_passes(passes, xs, vs, f, x0, d, reps), reps))
    _ceiling(1000)
    for threads in (1, 2):
        probes.append(Probe(("ceiling", threads), "call", threads, lambda: _ceiling(CEILING_WORK), 1))
    best, others = round_robin(probes, args.repeats, args.max_others, args.wait)
    rows = []
    for key in dict.fromkeys(p.key for p in probes):
        name, threads = key
        row = {**head, "kernel": name, "threads": threads}
        for column in ("call", "fire"):
            cpu, wall = best.get((key, column), (np.nan, np.nan))
            row[f"{column}_cpu_us"], row[f"{column}_wall_us"] = round(cpu, 3), round(wall, 3)
        row.update({"load": round(os.getloadavg()[0], 2), "others_before": round(max(others["before"]), 2),
                    "others": round(max(others["during"]), 2), **checks.get(name, {})})
        rows.append(_report(row))
    return rows


# start-up ------------------------------------------------------------------------------------------
def first_call(name: str) -> None:
    """In this (fresh) process: wall seconds of the first and second call of kernel ``name``:
    the engine's cached ``spheres.forces``, or the cached parallel loop itself (``_csr_par``,
    ``_chunk_par``; the NamedTuple wrappers ``csr`` and ``chunks`` were compiled again in every
    process in this benchmark, seen with NUMBA_DEBUG_CACHE=1, not diagnosed)."""
    from jamflow.protocols.compression import initial_packing

    case = Case(initial_packing(1024, 2, "bi:1.4:0.5", "spring", 0, 0.85))
    x, f, w, o, tau = case.x, case.f, case.virial, case.eng._o, case.eng._tau
    m = case.models[name]
    call = {"serial": lambda: spheres.forces(m, x, o, f, tau, w),
            "csr": lambda: _csr_par(m.start, m.j, m.shift, m.sigma, m.law, x, f, w),
            "chunks": lambda: _chunk_par(*m.pairs, m.cuts, m.fbuf, m.wbuf, x, o, f, tau, w)}[name]
    t0 = time.perf_counter()
    call()
    t1 = time.perf_counter()
    call()
    t2 = time.perf_counter()
    layer = numba.threading_layer() if name in PARALLEL else "-"
    print(f"{name} first_s={t1 - t0:.4f} second_s={t2 - t1:.6f} layer={layer}", flush=True)


def compile_seconds() -> None:
    """Wall seconds to compile (no cache) the CSR loop without and with ``parallel=True``, and
    the chunked loop, on the types of a 2D spring state."""
    from jamflow.protocols.compression import initial_packing

    case = Case(initial_packing(256, 2, "bi:1.4:0.5", "spring", 0, 0.85))
    x, f, w, o, tau = case.x, case.f, case.virial, case.eng._o, case.eng._tau
    m, c = case.models["csr"], case.models["chunks"]
    for label, fn, args in (("csr_1core", numba.njit(_csr_loop), (*m, x, f, w)),
                            ("csr", numba.njit(parallel=True)(_csr_loop), (*m, x, f, w)),
                            ("chunks", numba.njit(parallel=True)(_chunk_loop),
                             (*c.pairs, c.cuts, c.fbuf, c.wbuf, x, o, f, tau, w))):
        t0 = time.perf_counter()
        fn(*args)
        print(f"compile {label}: {time.perf_counter() - t0:.2f} s", flush=True)


def startup(times: int) -> None:
    """``times`` fresh processes per kernel, alternating, after one warm-up each (cache warm);
    ``process_s``: the whole process's wall seconds (the same work but for the kernel)."""
    cmd = [sys.executable, __file__, "--first-call"]
    for name in ("serial", *PARALLEL):
        subprocess.run([*cmd, name], check=True, capture_output=True)
    for _ in range(times):
        for name in ("serial", *PARALLEL):
            t0 = time.perf_counter()
            out = subprocess.run([*cmd, name], check=True, capture_output=True, text=True).stdout
            print(out.strip(), f"process_s={time.perf_counter() - t0:.3f} load={os.getloadavg()[0]:.2f}", flush=True)
    compile_seconds()


def state(n: int, dim: int, phi: float, directory: str | None):
    """``kernel.near_jamming_state``, kept in ``directory`` (HDF5) when given."""
    from jamflow.io.packing_file import load_packing, save_packing

    path = Path(directory, f"state-{dim}d-{n}-{phi}.h5") if directory else None
    if path is not None and path.exists():
        return load_packing(path)
    packing = near_jamming_state(n, dim=dim, phi=phi)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        save_packing(path, packing)
    return packing


def summary(path: str) -> None:
    """Per case, from a CSV of ``measure`` rows: the wall-time speed-ups at 2 threads of the
    force loop and of a FIRE iteration over the serial engine, the serial integration share
    (a FIRE iteration minus its force evaluations) and what a FIRE iteration would take with the
    measured 2-thread loop and a perfect one (Amdahl: the integration stays serial)."""
    import csv

    rows = list(csv.DictReader(open(path)))
    for case in dict.fromkeys((r["case"], r["n"]) for r in rows):
        at = {(r["kernel"], r["threads"]): r for r in rows if (r["case"], r["n"]) == case}
        s = at[("serial", "1")]
        call, fire_us, evals = float(s["call_wall_us"]), float(s["fire_wall_us"]), float(s["evals_per_iteration"])
        share = 1.0 - evals * call / fire_us
        print(f"{case[0]} N={case[1]}: serial force {call:.1f} us, FIRE {fire_us:.1f} us/iteration, "
              f"integration share {share:.2f}; FIRE with a perfect 2-thread force loop at most "
              f"{fire_us / (fire_us - evals * call / 2):.2f}x")
        for name in PARALLEL:
            p = at[(name, "2")]
            par = float(p["call_wall_us"])
            predicted = fire_us / (fire_us - evals * (call - par))
            print(f"  {name}: force loop {call / par:.2f}x, FIRE measured {fire_us / float(p['fire_wall_us']):.2f}x, "
                  f"predicted {predicted:.2f}x")
        one, two = float(at[("passes_1core", "1")]["call_wall_us"]), float(at[("passes", "2")]["call_wall_us"])
        ceiling = float(at[("ceiling", "1")]["call_wall_us"]) / float(at[("ceiling", "2")]["call_wall_us"])
        print(f"  FIRE's passes alone: {one:.1f} us serial, {two:.1f} us on 2 threads ({one / two:.2f}x); "
              f"compute-bound ceiling {ceiling:.2f}x")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="*", default=[1024, 4096, 16384])
    ap.add_argument("--dim3", type=int, nargs="*", default=[], help="3D sizes (phi = 0.70)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--max-load", type=float, default=1.2)
    ap.add_argument("--max-others", type=float, default=0.2, help="cores others may use before a block")
    ap.add_argument("--wait", type=float, default=600.0)
    ap.add_argument("--states", default=None, help="directory keeping the relaxed states (HDF5)")
    ap.add_argument("--prepare", action="store_true", help="only build (and keep) the states")
    ap.add_argument("--out", default=None)
    ap.add_argument("--startup", type=int, default=0, help="time the first call in this many fresh processes")
    ap.add_argument("--summary", default=None, help="print the speed-ups from a CSV this script wrote")
    ap.add_argument("--first-call", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.summary:
        return summary(args.summary)
    if args.first_call:
        return first_call(args.first_call)
    if args.startup:
        return startup(args.startup)
    print(f"numba {numba.__version__}, {numba.config.NUMBA_NUM_THREADS} threads", flush=True)
    specs = [("2d phi 0.85", n, 2, 0.85) for n in args.sizes] + [("3d phi 0.70", n, 3, 0.70) for n in args.dim3]
    cases = [(label, Case(state(n, dim, phi, args.states))) for label, n, dim, phi in specs]
    if args.prepare:
        return
    print(f"load {wait_for_load(args.max_load, args.wait)} at the start of the timed runs", flush=True)
    for label, case in cases:
        rows = measure(case, label, args)
        if args.out:
            for row in rows:
                append_row(Path(args.out), list(rows[0]), row)  # rows[0]: a kernel row, every column
    print("threading layer:", numba.threading_layer(), flush=True)


if __name__ == "__main__":
    main()
