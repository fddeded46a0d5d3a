"""Compiled kernels (numba) for the spring potential and FIRE 2.0, used by ``NumbaEngine``.

``spring_forces`` evaluates V = eps/alpha (1 - r/sigma)^alpha (seed eq. 2.1) over a pair
list with minimum images in an orthogonal periodic box. ``fire`` is LAMMPS's ``min_style
fire`` (FIRE 2.0, Guenole et al., Comput. Mater. Sci. 175, 109584 (2020); LAMMPS
src/min_fire.cpp) with its defaults: semi-implicit Euler, half step back, delaystep 20,
dtgrow 1.1, dtshrink 0.5, alpha0 0.25, alphashrink 0.99, tmax 10, tmin 0.02, dmax 0.1, unit
masses, and ``min_modify norm max`` (stop when every per-particle force magnitude is
below ftol). Units: eps, diameter, unit mass.
"""

from __future__ import annotations

import math

import numba
import numpy as np

DELAYSTEP, DTGROW, DTSHRINK, ALPHA0, ALPHASHRINK, TMAX, TMIN, DMAX = 20, 1.1, 0.5, 0.25, 0.99, 10.0, 0.02, 0.1

# FIRE state carried between calls (a neighbour-list rebuild interrupts a window):
DT, ALPHA, LAST_NEGATIVE, STEP, FLAG_V0, DT0 = range(6)
# why ``fire`` returned
CAP, FORCE, ENERGY_BELOW, REBUILD = 0, 1, 2, 3


def fire_state(dt0: float) -> np.ndarray:
    """A fresh FIRE state, as LAMMPS's ``minimize`` starts: v = 0, dt = timestep."""
    return np.array([dt0, ALPHA0, 0.0, 0.0, 1.0, dt0])


@numba.njit(cache=True, fastmath=False)
def spring_forces(x, shift, pi, pj, sigma, alpha, eps, f):
    """Fill f (N, d) with the forces; return the total energy. ``shift`` (P, d) is each
    pair's periodic image offset, fixed when the pair list is built (positions are not
    rewrapped between builds). Pairs beyond contact add nothing."""
    n, d = x.shape
    f[:] = 0.0
    energy = 0.0
    for k in range(pi.shape[0]):
        i, j, s = pi[k], pj[k], sigma[k]
        dr0 = x[i, 0] - x[j, 0] + shift[k, 0]
        dr1 = x[i, 1] - x[j, 1] + shift[k, 1]
        dr2 = x[i, 2] - x[j, 2] + shift[k, 2] if d == 3 else 0.0
        r2 = dr0 * dr0 + dr1 * dr1 + dr2 * dr2
        if r2 >= s * s:
            continue
        r = math.sqrt(r2)
        overlap = 1.0 - r / s
        if alpha == 2.0:
            energy += 0.5 * eps * overlap * overlap
            fr = eps * overlap / (s * r)  # -dV/dr / r
        else:
            energy += eps / alpha * overlap**alpha
            fr = eps * overlap ** (alpha - 1.0) / (s * r)
        f[i, 0] += fr * dr0
        f[j, 0] -= fr * dr0
        f[i, 1] += fr * dr1
        f[j, 1] -= fr * dr1
        if d == 3:
            f[i, 2] += fr * dr2
            f[j, 2] -= fr * dr2
    return energy


@numba.njit(cache=True, fastmath=False)
def fire(x, v, f, state, shift, pi, pj, sigma, alpha, eps, x_built, half_skin_sq, max_steps, ftol, energy_halt):
    """Run up to ``max_steps`` FIRE 2.0 iterations in place; return (iterations, reason, energy).

    Stops on: every |f_i| < ftol (FORCE), energy < energy_halt (ENERGY_BELOW, like LAMMPS
    ``fix halt``), a particle moved more than half the skin since the pair list was built
    (REBUILD: rebuild and call again with the same state), or max_steps (CAP).
    """
    n, d = x.shape
    m = n * d
    xs, vs, fs, x0 = x.reshape(m), v.reshape(m), f.reshape(m), x_built.reshape(m)  # flat views
    dt, fire_alpha = state[DT], state[ALPHA]
    dtmax, dtmin = TMAX * state[DT0], TMIN * state[DT0]
    energy = spring_forces(x, shift, pi, pj, sigma, alpha, eps, f)
    for it in range(1, max_steps + 1):
        state[STEP] += 1.0
        step = state[STEP]
        vdotf, vdotv, fdotf, vmax = 0.0, 0.0, 0.0, 0.0  # one fused pass
        for k in range(m):
            vdotf += vs[k] * fs[k]
            vdotv += vs[k] * vs[k]
            fdotf += fs[k] * fs[k]
            vmax = max(vmax, abs(vs[k]))
        scale1, scale2 = 1.0, 0.0
        if vdotf > 0.0:
            scale1 = 1.0 - fire_alpha
            scale2 = 0.0 if fdotf <= 1e-20 else fire_alpha * math.sqrt(vdotv / fdotf)
            if step - state[LAST_NEGATIVE] > DELAYSTEP:
                dt = min(dt * DTGROW, dtmax)
                fire_alpha *= ALPHASHRINK
        else:
            state[LAST_NEGATIVE] = step
            if step >= DELAYSTEP:  # LAMMPS: no reset during the first delaystep steps
                fire_alpha = ALPHA0
                if dt * DTSHRINK >= dtmin:
                    dt *= DTSHRINK
            for k in range(m):
                xs[k] -= 0.5 * dt * vs[k]
                vs[k] = 0.0
            state[FLAG_V0] = 1.0
        restart = state[FLAG_V0] > 0.0
        if restart:  # v = 0: the step limit uses the velocity one step of dt would give
            energy = spring_forces(x, shift, pi, pj, sigma, alpha, eps, f)
            vmax = 0.0
            for k in range(m):
                vmax = max(vmax, abs(dt * fs[k]))
        dtv = dt if dt * vmax <= DMAX else DMAX / vmax
        keep = 0.0 if restart else 1.0
        if vdotf > 0.0:
            for k in range(m):
                vk = scale1 * (dtv * fs[k] + keep * vs[k]) + scale2 * fs[k]
                vs[k] = vk
                xs[k] += dtv * vk
        else:
            for k in range(m):
                vk = dtv * fs[k] + keep * vs[k]
                vs[k] = vk
                xs[k] += dtv * vk
        energy = spring_forces(x, shift, pi, pj, sigma, alpha, eps, f)
        state[FLAG_V0] = 0.0
        state[DT], state[ALPHA] = dt, fire_alpha
        fmax_sq, moved_sq = 0.0, 0.0  # one fused pass
        for i in range(n):
            fi, mi = 0.0, 0.0
            for k in range(i * d, i * d + d):
                fi += fs[k] * fs[k]
                mi += (xs[k] - x0[k]) ** 2
            fmax_sq = max(fmax_sq, fi)
            moved_sq = max(moved_sq, mi)
        if moved_sq > half_skin_sq:  # a pair may have come into reach unseen: rebuild first
            return it, REBUILD, energy
        if energy < energy_halt:
            return it, ENERGY_BELOW, energy
        if fmax_sq < ftol * ftol:
            return it, FORCE, energy
    return max_steps, CAP, energy
