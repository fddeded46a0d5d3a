"""FIRE 2.0 over translations and rotations, written once for every particle shape.

This is LAMMPS's ``min_style fire`` (FIRE 2.0, Guenole et al., Comput. Mater. Sci. 175,
109584 (2020); LAMMPS src/min_fire.cpp) with its defaults -- semi-implicit Euler, half step
back, delaystep 20, dtgrow 1.1, dtshrink 0.5, alpha0 0.25, alphashrink 0.99, tmax 10, tmin
0.02, dmax 0.1, unit masses, ``min_modify norm max`` -- extended to rotational coordinates the
way the chapter's dynamical matrix counts them (section 3): particle i's rotation about body
axis a is the coordinate d_k theta (a length), its generalized force the body-frame torque
tau_a / d_k, its velocity w = d_k omega. FIRE sees one flat vector of coordinates; a step
moves centres by dt v and turns each particle by the body-frame rotation dt w / d_k
(``rotation.rotate``). For disks and spheres there are no rotational coordinates and the
floating-point operations are those of the translational FIRE. Units: eps, diameter, unit
mass (rotational inertia m d_k^2); time in units of sqrt(m l^2 / eps) (``time_unit``).

The time step: the stiffest contact of a unit-mass particle has the curvature k / l^2, l the
smallest contact distance, so the largest stable step scales with l. The defaults (dt0 0.05, tmax
10: up to 0.5) were measured on disks and spheres (l = 1); an oblate spheroid of aspect ratio 0.6
touches face to face at l = 0.6, its stiffest modes (2.5x those of the prolate 1.5, measured)
made FIRE run at the edge of stability at dt = 0.5, reset on P < 0 every ~4 steps, and creep
(measured in docs/notes/ellipses.md, "FIRE's time unit and the oblate creep"): so the step is taken in units of l.

The force/torque kernel comes from the pair list's type (``kernels.evaluate``); beside it
FIRE calls the external field (``field.external``: walls, gravity, fixed particles). At
constant stress the box coordinates q (``field``: strain amplitudes times L, generalized
forces -dH/dq) join the flat vector the same way as the rotations: one more block in the
dot products and the velocity update, and a step that deforms the box (``field.deform``).
Without walls, gravity, fixed particles or box coordinates the floating-point operations
are those of the plain FIRE above.
"""

from __future__ import annotations

import math

import numpy as np

from jamflow.engines.compiled import jit
from jamflow.engines.compiled.field import box_forces, deform, external
from jamflow.engines.compiled.kernels import evaluate
from jamflow.engines.compiled.rotation import generalized_torques, rotate

DELAYSTEP, DTGROW, DTSHRINK, ALPHA0, ALPHASHRINK, TMAX, TMIN, DMAX = 20, 1.1, 0.5, 0.25, 0.99, 10.0, 0.02, 0.1

# FIRE state carried between calls (a neighbour-list rebuild interrupts a window):
DT, ALPHA, LAST_NEGATIVE, STEP, FLAG_V0, DT0 = range(6)
# why ``fire`` returned
CAP, FORCE, ENERGY_BELOW, REBUILD = 0, 1, 2, 3


def time_unit(shape) -> float:
    """sqrt(m l^2 / eps) in units of sqrt(m diameter^2 / eps): l, the smallest contact distance of
    two unit-scale particles of ``shape`` (1 for disks, spheres, ellipses, prolate spheroids and
    bodies of unit sites; ALPHA for oblate spheroids, S for dimer:ALPHA:S)."""
    return float(shape.smallest_contact(1.0))


def fire_state(dt0: float) -> np.ndarray:
    """A fresh FIRE state, as LAMMPS's ``minimize`` starts: v = 0, dt = timestep."""
    return np.array([dt0, ALPHA0, 0.0, 0.0, 1.0, dt0])


@jit
def forces(model, fld, x, f, o, tau, g, dk, mask, virial, gb):
    """Evaluate the kernel and the external field, turn torques into generalized forces g and
    the virial into box forces gb; return the energy."""
    energy = evaluate(model, x, o, f, tau, virial)
    energy += external(fld, x, f, virial)
    if g.shape[1] > 0:
        generalized_torques(o, tau, dk, mask, g)
    if gb.shape[0] > 0:
        box_forces(fld, virial, gb)
    return energy


@jit
def _turn(o, w, dk, factor, turned):
    """Rotate every particle by the body-frame vector factor * w_i / dk_i."""
    n, r = w.shape
    phi = np.zeros(max(r, 1))
    for i in range(n):
        for a in range(r):
            phi[a] = factor * w[i, a] / dk[i, a]
        turned[i] += rotate(o, i, phi)


@jit
def fire(model, fld, x, v, f, o, w, tau, g, dk, mask, virial, ub, gb, state, x_built, turned, reach, half_skin_sq,
         max_steps, ftol, energy_halt):
    """Run up to ``max_steps`` FIRE 2.0 iterations in place; return (iterations, reason, energy).

    x, v, f: (N, d) positions, velocities, forces; o: orientations (N, 0 | 1 | 4); w, g: (N, r)
    rotational velocities and generalized torques, tau (N, r) world torques, dk (N, r) rotational
    lengths, mask (r,) 1 for the body axes that are degrees of freedom; fld the external field
    (``field.Field``), ub, gb (k,) box-coordinate velocities and forces (k = 0: fixed box).
    Stops on: every particle's |f_i| and |g_i| and every |gb_k| below ftol (FORCE), energy <
    energy_halt (ENERGY_BELOW, like LAMMPS ``fix halt``), a particle moved more than half the
    skin since the pair list was built (REBUILD; rotations count as reach x angle turned; box
    steps move particles affinely, which this counts too), or max_steps (CAP).
    """
    n, d = x.shape
    r = w.shape[1]
    m, mr, mb = n * d, n * r, gb.shape[0]
    xs, vs, fs, x0 = x.reshape(m), v.reshape(m), f.reshape(m), x_built.reshape(m)  # flat views
    ws, gs = w.reshape(mr), g.reshape(mr)
    dt, fire_alpha = state[DT], state[ALPHA]
    dtmax, dtmin = TMAX * state[DT0], TMIN * state[DT0]
    energy = forces(model, fld, x, f, o, tau, g, dk, mask, virial, gb)
    for it in range(1, max_steps + 1):
        state[STEP] += 1.0
        step = state[STEP]
        vdotf, vdotv, fdotf, vmax = 0.0, 0.0, 0.0, 0.0  # one fused pass
        for k in range(m):
            vdotf += vs[k] * fs[k]
            vdotv += vs[k] * vs[k]
            fdotf += fs[k] * fs[k]
            vmax = max(vmax, abs(vs[k]))
        for k in range(mr):
            vdotf += ws[k] * gs[k]
            vdotv += ws[k] * ws[k]
            fdotf += gs[k] * gs[k]
            vmax = max(vmax, abs(ws[k]))
        for k in range(mb):
            vdotf += ub[k] * gb[k]
            vdotv += ub[k] * ub[k]
            fdotf += gb[k] * gb[k]
            vmax = max(vmax, abs(ub[k]))
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
            if mr > 0:
                _turn(o, w, dk, -0.5 * dt, turned)
                ws[:] = 0.0
            if mb > 0:
                deform(fld, model, x, ub, -0.5 * dt)
                ub[:] = 0.0
            state[FLAG_V0] = 1.0
        restart = state[FLAG_V0] > 0.0
        if restart:  # v = 0: the step limit uses the velocity one step of dt would give
            energy = forces(model, fld, x, f, o, tau, g, dk, mask, virial, gb)
            vmax = 0.0
            for k in range(m):
                vmax = max(vmax, abs(dt * fs[k]))
            for k in range(mr):
                vmax = max(vmax, abs(dt * gs[k]))
            for k in range(mb):
                vmax = max(vmax, abs(dt * gb[k]))
        dtv = dt if dt * vmax <= DMAX else DMAX / vmax
        keep = 0.0 if restart else 1.0
        if vdotf > 0.0:
            for k in range(m):
                vk = scale1 * (dtv * fs[k] + keep * vs[k]) + scale2 * fs[k]
                vs[k] = vk
                xs[k] += dtv * vk
            for k in range(mr):
                ws[k] = scale1 * (dtv * gs[k] + keep * ws[k]) + scale2 * gs[k]
            for k in range(mb):
                ub[k] = scale1 * (dtv * gb[k] + keep * ub[k]) + scale2 * gb[k]
        else:
            for k in range(m):
                vk = dtv * fs[k] + keep * vs[k]
                vs[k] = vk
                xs[k] += dtv * vk
            for k in range(mr):
                ws[k] = dtv * gs[k] + keep * ws[k]
            for k in range(mb):
                ub[k] = dtv * gb[k] + keep * ub[k]
        if mr > 0:
            _turn(o, w, dk, dtv, turned)
        if mb > 0:
            deform(fld, model, x, ub, dtv)
        energy = forces(model, fld, x, f, o, tau, g, dk, mask, virial, gb)
        state[FLAG_V0] = 0.0
        state[DT], state[ALPHA] = dt, fire_alpha
        fmax_sq, moved_sq = 0.0, 0.0  # one fused pass
        for i in range(n):
            fi, mi = 0.0, 0.0
            for k in range(i * d, i * d + d):
                fi += fs[k] * fs[k]
                mi += (xs[k] - x0[k]) ** 2
            if mr > 0:
                gi = 0.0
                for k in range(i * r, i * r + r):
                    gi += gs[k] * gs[k]
                fi = max(fi, gi)
                if turned[i] > 0.0:
                    mi = (math.sqrt(mi) + reach[i] * turned[i]) ** 2
            fmax_sq = max(fmax_sq, fi)
            moved_sq = max(moved_sq, mi)
        for k in range(mb):
            fmax_sq = max(fmax_sq, gb[k] * gb[k])
        if moved_sq > half_skin_sq:  # a pair may have come into reach unseen: rebuild first
            return it, REBUILD, energy
        if energy < energy_halt:
            return it, ENERGY_BELOW, energy
        if fmax_sq < ftol * ftol:
            return it, FORCE, energy
    return max_steps, CAP, energy
