"""FIRE and the disk/sphere forces on several threads: the compiled engine's option ``threads``.

The same FIRE 2.0 as ``fire.fire`` (same constants, same steps, same stops) for disks and spheres
with a spring law (linear, Hertz, ``spring:ALPHA``) in a periodic box (orthogonal or tilted), without
walls, fixed particles, gravity or box coordinates; ``CompiledEngine`` runs its serial kernels
for every other scene (``uncovered`` says why, and the engine warns once).

Results do not depend on the number of threads: the work is cut into ``CHUNKS`` fixed ranges of
the particles (0..N-1 in equal index ranges), never by the thread count; no two ranges write one
place, and the ranges' partial sums are added in range order.

- Pair loop (``pair_forces``): range c runs the pairs whose i lies in it (the pair list is sorted
  by i) as the serial kernel does: the force on i summed in registers from f[i], the force on j
  subtracted from f[j] when j lies in the range too. The force on a j in another range goes into
  its own row of a j-side buffer, at a slot that groups the rows by j in increasing k
  (``incidence``: a counting sort made once per pair list); energy and virial are the range's
  partial sums. Random starts of 8192 particles and more are numbered along the Morton curve
  (``jamflow.model.ordering``), so most pairs stay within a range.
- Gather (``gather``): f[p] minus the rows of its slots (pairs from other ranges), read in order;
  in the same pass, per range, v.f, v.v, f.f and max |v| (FIRE's next step), the largest |f_p|
  and the largest move since the pair list was built (its stops).
- FIRE's vector steps (the half step back, the velocity and position update) run over the same
  ranges. Three parallel loops per iteration, each ended by numba's barrier.

Against the serial kernels only the order of the sums differs (energy, virial, the force on a
particle, the dot products): the results differ in round-off, and a minimisation can follow
another path to an equivalent minimum (tests/test_threads.py).

numba compiles these with ``parallel=True`` (``jit_parallel``), which numba.pycc cannot do ahead of
time: the first use in a new cache compiles them (announced). Per-iteration speed against the
serial kernels: docs/notes/threads.md (benchmarks/threads.py).
"""

from __future__ import annotations

import math
import os

import numpy as np

from jamflow.engines.base import scene_boundaries
from jamflow.engines.compiled import announce_compile, jit, jit_parallel, when_numba_starts
from jamflow.engines.compiled.fire import (
    ALPHA,
    ALPHA0,
    ALPHASHRINK,
    CAP,
    DELAYSTEP,
    DMAX,
    DT,
    DT0,
    DTGROW,
    DTSHRINK,
    ENERGY_BELOW,
    FLAG_V0,
    FORCE,
    LAST_NEGATIVE,
    REBUILD,
    STEP,
    TMAX,
    TMIN,
)
from jamflow.engines.compiled.laws import energy_force
from jamflow.model.potentials import SpringParams

CHUNKS = 16  # fixed index ranges of the particles (never the thread count)
COMPILE_SECONDS = 15  # cold compile of these kernels (announced)
# per-chunk partial sums of the force gather: v.f, v.v, f.f, max |v|, max |f_i|^2, max |x_i - x_built_i|^2
VF, VV, FF, VMAX, FMAX2, MOVED2 = range(6)
prange = range  # numba.prange once numba starts (the kernels are compiled after that)


def _use_prange():
    import numba

    global prange
    prange = numba.prange


when_numba_starts(_use_prange)


def check_threads(threads) -> int:
    """``threads`` as an int >= 1; ValueError (what to give instead) otherwise."""
    if isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1:
        raise ValueError(f"threads must be an integer >= 1 (1: the serial kernels, the default; 2 or more: FIRE and "
                         f"the forces on that many threads, disks/spheres), got {threads!r}")
    return int(threads)


def uncovered(packing, pressure: bool = False) -> str | None:
    """What in this scene the threaded kernels do not run (the engine then runs its serial ones), or None."""
    if not packing.shape.round:
        return f"{packing.shape.name(packing.dim)} particles"
    needs = scene_boundaries(packing)
    if needs:
        return " and ".join(sorted(needs))
    if type(packing.potential.params) is not SpringParams:
        return f"the potential {packing.potential.spec}"
    if pressure:
        return "a target pressure (box coordinates)"
    return None


@jit
def incidence(pi, pj, n):
    """(istart, jstart, slot) of a pair list sorted by i: the pairs with i_k = p are k in
    istart[p]:istart[p + 1]. A pair whose j lies outside the range (``CHUNKS``) of its i has a slot
    slot[k] >= 0 in the j-side rows, grouped by j in increasing k: those of particle p are
    jstart[p]:jstart[p + 1] (a counting sort); a pair within one range has slot -1. Raises
    ValueError if the pairs are not sorted by i (the engine's lists are)."""
    count = pi.shape[0]
    istart, jstart = np.zeros(n + 1, np.int64), np.zeros(n + 1, np.int64)
    slot = np.full(count, -1, np.int64)
    c = 0
    for k in range(count):
        if k > 0 and pi[k] < pi[k - 1]:
            raise ValueError("the pair list is not sorted by i")
        istart[pi[k] + 1] += 1
        while pi[k] >= n * (c + 1) // CHUNKS:
            c += 1
        if pj[k] < n * c // CHUNKS or pj[k] >= n * (c + 1) // CHUNKS:
            jstart[pj[k] + 1] += 1
            slot[k] = 0  # across ranges: numbered below
    for p in range(n):
        istart[p + 1] += istart[p]
        jstart[p + 1] += jstart[p]
    following = jstart[:-1].copy()
    for k in range(count):
        if slot[k] >= 0:
            slot[k] = following[pj[k]]
            following[pj[k]] += 1
    return istart, jstart, slot


@jit
def _pair_chunk(istart, pj, slot, shift, sigma, law, x, f, fj, partial, c):
    """Range c of the particles, as the serial kernel over the pairs whose i lies in it: the force on
    i summed in registers from f[i], the force on j subtracted from f[j] when j lies in the range too,
    else stored in j's slot of fj (0 outside contact); the range's energy and virial (row-major
    d x d) into partial[c]."""
    n, d = x.shape
    lo, hi = n * c // CHUNKS, n * (c + 1) // CHUNKS
    for p in range(lo, hi):
        for a in range(d):
            f[p, a] = 0.0
    energy = 0.0
    w00 = w01 = w10 = w11 = w02 = w12 = w20 = w21 = w22 = 0.0
    for i in range(lo, hi):
        fi0, fi1 = f[i, 0], f[i, 1]
        fi2 = f[i, 2] if d == 3 else 0.0
        xi0, xi1 = x[i, 0], x[i, 1]
        xi2 = x[i, 2] if d == 3 else 0.0
        for k in range(istart[i], istart[i + 1]):
            j, s, q = pj[k], sigma[k], slot[k]
            dr0 = xi0 - x[j, 0] + shift[k, 0]
            dr1 = xi1 - x[j, 1] + shift[k, 1]
            dr2 = xi2 - x[j, 2] + shift[k, 2] if d == 3 else 0.0
            r2 = dr0 * dr0 + dr1 * dr1 + dr2 * dr2
            if r2 >= s * s:
                if q >= 0:
                    fj[q, 0] = 0.0
                    fj[q, 1] = 0.0
                    if d == 3:
                        fj[q, 2] = 0.0
                continue
            r = math.sqrt(r2)
            v, dv = energy_force(law, r / s)
            energy += v
            fr = -dv / (s * r)
            fi0 += fr * dr0
            fi1 += fr * dr1
            if d == 3:
                fi2 += fr * dr2
            if q >= 0:
                fj[q, 0] = fr * dr0
                fj[q, 1] = fr * dr1
                if d == 3:
                    fj[q, 2] = fr * dr2
            else:
                f[j, 0] -= fr * dr0
                f[j, 1] -= fr * dr1
                if d == 3:
                    f[j, 2] -= fr * dr2
            w00 += fr * dr0 * dr0
            w01 += fr * dr0 * dr1
            w10 += fr * dr1 * dr0
            w11 += fr * dr1 * dr1
            if d == 3:
                w02 += fr * dr0 * dr2
                w12 += fr * dr1 * dr2
                w20 += fr * dr2 * dr0
                w21 += fr * dr2 * dr1
                w22 += fr * dr2 * dr2
        f[i, 0] = fi0
        f[i, 1] = fi1
        if d == 3:
            f[i, 2] = fi2
    partial[c, 0] = energy
    if d == 2:
        partial[c, 1], partial[c, 2], partial[c, 3], partial[c, 4] = w00, w01, w10, w11
    else:
        partial[c, 1], partial[c, 2], partial[c, 3] = w00, w01, w02
        partial[c, 4], partial[c, 5], partial[c, 6] = w10, w11, w12
        partial[c, 7], partial[c, 8], partial[c, 9] = w20, w21, w22


@jit_parallel
def pair_forces(istart, pj, slot, shift, sigma, alpha, epsilon, x, f, fj, partial):
    """Every chunk of particles (``_pair_chunk``) with the law ``SpringParams(alpha, epsilon)``
    (only arrays and numbers cross into numba's threaded loop)."""
    for c in prange(CHUNKS):
        _pair_chunk(istart, pj, slot, shift, sigma, SpringParams(alpha, epsilon), x, f, fj, partial, c)


@jit_parallel
def gather(jstart, fj, f, x, v, x_built, sums):
    """f_p -= the j-side forces of its slots (in increasing pair order); per chunk of particles into
    sums (CHUNKS, 6): v.f, v.v, f.f, max |v_k|, max |f_p|^2 and max |x_p - x_built_p|^2."""
    n, d = f.shape
    for c in prange(CHUNKS):
        vf = vv = ff = vmax = fmax2 = moved2 = 0.0
        for p in range(n * c // CHUNKS, n * (c + 1) // CHUNKS):
            f0, f1 = f[p, 0], f[p, 1]
            f2 = f[p, 2] if d == 3 else 0.0
            for q in range(jstart[p], jstart[p + 1]):
                f0 -= fj[q, 0]
                f1 -= fj[q, 1]
                if d == 3:
                    f2 -= fj[q, 2]
            f[p, 0] = f0
            f[p, 1] = f1
            if d == 3:
                f[p, 2] = f2
            fi, mi = 0.0, 0.0
            for a in range(d):
                fa, va = f[p, a], v[p, a]
                vf += va * fa
                vv += va * va
                ff += fa * fa
                vmax = max(vmax, abs(va))
                fi += fa * fa
                mi += (x[p, a] - x_built[p, a]) ** 2
            fmax2 = max(fmax2, fi)
            moved2 = max(moved2, mi)
        sums[c, VF], sums[c, VV], sums[c, FF], sums[c, VMAX] = vf, vv, ff, vmax
        sums[c, FMAX2], sums[c, MOVED2] = fmax2, moved2


@jit
def forces(m, inc, x, f, v, x_built, virial, fj, partial, sums):
    """Fill f (N, d) and the virial (d, d), and sums (``gather``); return the energy. The partial
    sums of the chunks are added in chunk order."""
    d = x.shape[1]
    istart, jstart, slot = inc
    pair_forces(istart, m.j, slot, m.shift, m.sigma, m.law.alpha, m.law.epsilon, x, f, fj, partial)
    gather(jstart, fj, f, x, v, x_built, sums)
    energy = 0.0
    for c in range(CHUNKS):
        energy += partial[c, 0]
    for a in range(d):
        for b in range(d):
            w = 0.0
            for c in range(CHUNKS):
                w += partial[c, 1 + a * d + b]
            virial[a, b] = w
    return energy


@jit_parallel
def _restart(x, v, dt):
    """FIRE's half step back on P <= 0: x -= dt / 2 v, v = 0."""
    n = x.shape[0]
    d = x.shape[1]
    for c in prange(CHUNKS):
        for p in range(n * c // CHUNKS, n * (c + 1) // CHUNKS):
            for a in range(d):
                x[p, a] -= 0.5 * dt * v[p, a]
                v[p, a] = 0.0


@jit_parallel
def _largest_step(f, dt, out):
    """max |dt f_k| per chunk of particles into out (CHUNKS,)."""
    n, d = f.shape
    for c in prange(CHUNKS):
        vmax = 0.0
        for p in range(n * c // CHUNKS, n * (c + 1) // CHUNKS):
            for a in range(d):
                vmax = max(vmax, abs(dt * f[p, a]))
        out[c] = vmax


@jit_parallel
def _move(x, v, f, scale1, scale2, dtv, keep, mixing):
    """FIRE's velocity and position step: v = scale1 (dtv f + keep v) + scale2 f with mixing (P > 0),
    else v = dtv f + keep v; x += dtv v."""
    n, d = x.shape
    for c in prange(CHUNKS):
        for p in range(n * c // CHUNKS, n * (c + 1) // CHUNKS):
            for a in range(d):
                if mixing:
                    vk = scale1 * (dtv * f[p, a] + keep * v[p, a]) + scale2 * f[p, a]
                else:
                    vk = dtv * f[p, a] + keep * v[p, a]
                v[p, a] = vk
                x[p, a] += dtv * vk


@jit
def fire(m, inc, x, v, f, virial, state, x_built, half_skin_sq, max_steps, ftol, energy_halt):
    """``fire.fire`` for disks and spheres without rotations, field or box coordinates, on threads:
    up to ``max_steps`` FIRE 2.0 iterations in place; return (iterations, reason, energy)."""
    n, d = x.shape
    fj = np.empty((inc[1][n], d))  # the pairs across ranges
    partial = np.empty((CHUNKS, 1 + d * d))
    sums = np.empty((CHUNKS, 6))
    largest = np.empty(CHUNKS)
    dt, fire_alpha = state[DT], state[ALPHA]
    dtmax, dtmin = TMAX * state[DT0], TMIN * state[DT0]
    energy = forces(m, inc, x, f, v, x_built, virial, fj, partial, sums)
    for it in range(1, max_steps + 1):
        state[STEP] += 1.0
        step = state[STEP]
        vdotf, vdotv, fdotf, vmax = 0.0, 0.0, 0.0, 0.0  # of the last gather: the current v and f
        for c in range(CHUNKS):
            vdotf += sums[c, VF]
            vdotv += sums[c, VV]
            fdotf += sums[c, FF]
            vmax = max(vmax, sums[c, VMAX])
        scale1, scale2 = 1.0, 0.0
        if vdotf > 0.0:
            scale1 = 1.0 - fire_alpha
            scale2 = 0.0 if fdotf <= 1e-20 else fire_alpha * math.sqrt(vdotv / fdotf)
            if step - state[LAST_NEGATIVE] > DELAYSTEP:
                dt = min(dt * DTGROW, dtmax)
                fire_alpha *= ALPHASHRINK
        else:
            state[LAST_NEGATIVE] = step
            if step >= DELAYSTEP:
                fire_alpha = ALPHA0
                if dt * DTSHRINK >= dtmin:
                    dt *= DTSHRINK
            _restart(x, v, dt)
            state[FLAG_V0] = 1.0
        restart = state[FLAG_V0] > 0.0
        if restart:
            energy = forces(m, inc, x, f, v, x_built, virial, fj, partial, sums)
            _largest_step(f, dt, largest)
            vmax = 0.0
            for c in range(CHUNKS):
                vmax = max(vmax, largest[c])
        dtv = dt if dt * vmax <= DMAX else DMAX / vmax
        keep = 0.0 if restart else 1.0
        _move(x, v, f, scale1, scale2, dtv, keep, vdotf > 0.0)
        energy = forces(m, inc, x, f, v, x_built, virial, fj, partial, sums)
        state[FLAG_V0] = 0.0
        state[DT], state[ALPHA] = dt, fire_alpha
        fmax_sq, moved_sq = 0.0, 0.0
        for c in range(CHUNKS):
            fmax_sq = max(fmax_sq, sums[c, FMAX2])
            moved_sq = max(moved_sq, sums[c, MOVED2])
        if moved_sq > half_skin_sq:
            return it, REBUILD, energy
        if energy < energy_halt:
            return it, ENERGY_BELOW, energy
        if fmax_sq < ftol * ftol:
            return it, FORCE, energy
    return max_steps, CAP, energy


def passive_waits() -> None:
    """OMP_WAIT_POLICY=PASSIVE unless OMP_WAIT_POLICY or GOMP_SPINCOUNT is set, before numba's OpenMP
    thread pool starts (libgomp reads it once, at load; later it changes nothing). A thread that
    reaches a barrier first then sleeps instead of spinning (GNU OpenMP's default: up to ~300 000
    spins). On cores shared with other jobs a spinning thread takes the time slice the other one
    needs: 2D N = 16384 ran 5-7x slower than serial per iteration with spinning and 1.3x slower with
    passive waits, at a load of 4-6 on 2 cores (docs/notes/threads.md)."""
    if "OMP_WAIT_POLICY" not in os.environ and "GOMP_SPINCOUNT" not in os.environ:
        os.environ["OMP_WAIT_POLICY"] = "PASSIVE"


class ThreadedKernels:
    """``fire.fire`` and ``fire.forces`` (the engine's arguments) on ``threads`` numba threads, for the
    scenes ``uncovered`` passes; the pair list's ``incidence`` is made when a new list arrives."""

    def __init__(self, threads: int, what: str):
        self.threads = threads
        self.what = what  # the compile notice's name, e.g. "threaded disk"
        passive_waits()
        import numba

        self.available = numba.get_num_threads()  # numba's limit as the engine opens (it also caps each run)
        self._model = None
        self._inc = None

    def _incidence(self, model, n):
        if model is not self._model:
            announce_compile(self.what, COMPILE_SECONDS, incidence, (model.i, model.j, n))  # the first kernel run
            self._inc = incidence(model.i, model.j, n)
            self._model = model
        return self._inc

    def _run(self, kernel, args):
        import numba

        announce_compile(self.what, COMPILE_SECONDS, kernel, args)
        before = numba.get_num_threads()  # numba's limit (NUMBA_NUM_THREADS, numba.set_num_threads) caps threads
        numba.set_num_threads(min(self.threads, before))
        try:
            return kernel(*args)
        finally:
            numba.set_num_threads(before)

    def fire(self, model, fld, x, v, f, o, w, tau, g, dk, mask, virial, ub, gb, state, x_built, turned, reach,
             half_skin_sq, max_steps, ftol, energy_halt):
        inc = self._incidence(model, x.shape[0])
        return self._run(fire, (model, inc, x, v, f, virial, state, x_built, half_skin_sq, max_steps, ftol,
                                energy_halt))

    def forces(self, model, fld, x, f, o, tau, g, dk, mask, virial, gb):
        inc = self._incidence(model, x.shape[0])
        n, d = x.shape
        fj, partial, sums = np.empty((inc[1][n], d)), np.empty((CHUNKS, 1 + d * d)), np.empty((CHUNKS, 6))
        return self._run(forces, (model, inc, x, f, np.zeros((n, d)), x, virial, fj, partial, sums))
