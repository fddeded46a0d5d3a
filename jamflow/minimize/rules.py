"""Energy minimisation in LAMMPS with the chapter's stopping rules (chapter section 2.1, step 3).

Methods:
- ``fire``: LAMMPS ``min_style fire`` (FIRE 2.0), ``min_modify norm max``.
- ``cg``: Polak-Ribiere conjugate gradient, ``min_modify line forcezero`` (the default
  backtracking line search stalls at forces ~1e-10, see docs/notes/failure-modes.md).
- ``md``: damped molecular dynamics (velocity Verlet, ``fix nve``) with one of two dampings:
  ``md_damping="viscous"`` (default), ``fix viscous b``: a drag -b v on every particle. It
  also damps rattlers and is not Galilean invariant.
  ``md_damping="pairwise"``, ``fix jamflow/damping b`` (jamflow's plugin): chapter eq. 2.3
  exactly, -b (v_ij . rhat_ij) rhat_ij on every pair in contact; conserves momentum and
  leaves free (rattler) and tangential motion undamped. docs/notes/damped-md.md compares them.
  For ellipsoids ``fix nve/asphere`` + ``fix langevin`` at T = 0 with ``angmom`` (drag
  ``rotating_damping`` on translations and rotations, the only LAMMPS route that turns them).

Stopping rules, checked after every ``window`` iterations (LAMMPS runs the window):
1. ``force``: max force component below ``force_tol`` (default scales with the box side and
   the contact stiffness, since round-off in positions of a box of side L limits forces to
   ~L * 1e-16 * d2V/dr2; repulsive LJ is 72x stiffer at contact than the linear spring;
   ellipses/spheroids start from 5e-13 instead of 1e-14: near onset their quartic modes make
   every minimiser creep, docs/notes/ellipses.md),
   and, for particles that turn, every generalized torque component tau_a / d_k below it too
   (torque balance; d_k the rotational length of ``jamflow.model.shapes``).
2. ``energy-below-vmin``: energy per particle below ``v_min`` (the chapter's rule b, V_min = 1e-16),
   also caught inside a window by ``fix halt``.
3. ``energy-steady`` (md only): the chapter's MD rule, <(V - <V>)^2>^(1/2) / <V> < ``delta``
   over the energies sampled every ``md_sample_every`` steps inside the window (needs 2
   samples). Checked before ``no-progress``; reported as not converged by force, like it.
4. ``no-progress``: over a whole window the relative energy decrease was below ``delta``
   (the chapter's rule a, delta = 1e-16) and the max force did not halve: the round-off floor.
   Reported as not converged by force; the protocol records it. For md the energy compared
   is the mechanical energy V + K at the window ends, which damping can only lower: V alone
   rises and falls as the dynamics trades it for kinetic energy (pairwise damping rings).
5. ``linesearch``: CG's line search could not move (LAMMPS stopped early).
6. ``iteration-cap``: ``max_iterations`` reached (not converged).
7. ``blown-up``: non-finite energy or force, or V < V_min with a force no state at V < V_min
   can have (``_force_bound``): the integration diverged (not converged).

At a target ``pressure`` (constant stress, the box as a degree of freedom: compiled FIRE's box
coordinates, LAMMPS ``fix box/relax`` with CG) the objective is the enthalpy U + P V: rule 1
also requires every box force component below the force tolerance (so |P - P_target| <
force_tol / (d L^(d-1)) isotropically), rule 3 watches the enthalpy, and rule 2 is off (a
packing at P > 0 has U > 0 however small). Energies per particle count mobile particles only.
"""

from __future__ import annotations

import math
import time
from functools import lru_cache

import numpy as np

from jamflow.minimize.creep import Creep
from jamflow.minimize.settings import CONVERGED_REASONS, MinimizeResult, MinimizerSettings


def minimize(engine, settings: MinimizerSettings | None = None) -> MinimizeResult:
    """Minimise the engine's configuration at fixed box; the engine holds the result.

    The engine runs windows of iterations (``engine.minimizer_session``: LAMMPS or the
    compiled FIRE), each returning (iterations, total energy, max force component, max
    generalized torque component); the stopping rules are applied here, the same for every
    engine. ``settings`` None: ``MinimizerSettings()``."""
    settings = settings or MinimizerSettings()
    start = time.perf_counter()
    n = engine.template.n_mobile
    stiffness = engine.template.potential.contact_stiffness
    ftol = settings.force_tol_for(engine.template, box=engine.box)
    fmax_at_vmin = _force_bound(engine.template, n * settings.v_min)
    done, energy_prev, fmax_prev = 0, math.inf, math.inf
    creep = _creep_method(engine, settings, stiffness, ftol)
    with engine.minimizer_session(settings, ftol) as run_window:
        while True:
            steps = min(settings.window, settings.max_iterations - done)
            due_in = creep.trigger.until_due(done) if creep is not None else None
            if due_in is not None:
                steps = min(steps, due_in)
            w = run_window(steps)
            done += w.iterations
            energy = w.objective / n
            mechanical = energy + w.kinetic / n  # V + K per particle: what damping can only lower
            worst = max(w.max_force, w.max_torque)  # forces and generalized torques share the units and the tolerance
            reason = _stop_reason(settings, ftol, energy, worst, energy_prev, fmax_prev, w.iterations, steps, done,
                                  fmax_at_vmin, w.fluctuation, mechanical)
            if reason:
                if settings.pressure is not None:  # report the potential energy, not the enthalpy
                    energy = engine.state().energy / n
                return MinimizeResult(converged=reason in CONVERGED_REASONS, reason=reason, iterations=done,
                                      energy_per_particle=energy, max_force=w.max_force,
                                      seconds=time.perf_counter() - start, max_torque=w.max_torque,
                                      creep_steps=creep.accepted if creep else 0)
            energy_prev, fmax_prev = mechanical, worst
            if creep is not None and creep.due(done, worst) and creep.step(engine, done):
                energy_prev, fmax_prev = math.inf, math.inf  # a new state: the next window must not read "no-progress"


def _creep_method(engine, settings: MinimizerSettings, stiffness: float, ftol: float) -> Creep | None:
    """The creep method of this minimisation (``MinimizerSettings.creep``; ``minimize.creep``), or None."""
    template = engine.template
    method = settings.creep
    if settings.pressure is not None or template.box.walls or template.gravity or template.fixed is not None:
        if method in ("auto", "off"):
            return None
        raise ValueError(f"creep method {method!r} runs at a fixed periodic box without walls, gravity or fixed "
                         "particles; use the creep method auto or off here")
    if method == "auto":
        method = _auto_creep(engine, settings)
    if method == "soft-modes":
        from jamflow.minimize.soft_modes import SoftModeSteps, trigger  # scipy.sparse.linalg: loaded only where it runs

        return Creep(trigger(template, settings.creep_after), SoftModeSteps(max(1.0, stiffness)))
    if method == "newton":
        from jamflow.minimize.newton import AFTER, NewtonSteps, newton_reason, newton_trigger

        reason = newton_reason(template)
        if reason:
            raise ValueError(f"creep method 'newton': {reason}; use the creep method auto (what was measured to pay "
                             "for this scene) or off")
        return Creep(newton_trigger(settings.creep_after or AFTER), NewtonSteps(ftol))
    if method == "polish":
        from jamflow.minimize.polish import AFTER, PolishSteps, polish_reason, polish_trigger

        reason = polish_reason(template)
        if reason and settings.creep == "auto":  # e.g. the Hertz law: FIRE alone, as measured
            return None
        if reason:
            raise ValueError(f"creep method 'polish': {reason}; use the creep method soft-modes or off")
        return Creep(polish_trigger(template, settings.creep_after or AFTER), PolishSteps(ftol))
    return None


def _auto_creep(engine, settings: MinimizerSettings) -> str:
    """What ``creep="auto"`` runs: what was measured to pay, in the compiled engine only (a LAMMPS
    run must stay equal to its deck)."""
    from jamflow.minimize.polish import polish_reason

    template = engine.template
    if settings.method != "fire" or getattr(engine, "name", "") != "numba":
        return "off"
    if template.shape.made_of_sites and not polish_reason(template):
        return "polish"
    if template.shape.oriented:
        return "soft-modes"
    return "polish" if template.dim == 2 else "off"


def _force_bound(packing, energy: float) -> float:
    """10x the largest force a particle can feel when the total energy is below ``energy``:
    the force of one contact of the smallest pair holding all of it, times sqrt(12) contacts
    (Cauchy-Schwarz) and a margin. A larger force at V < V_min means the state blew up."""
    return _contact_force_bound(packing.potential, float(packing.shape.smallest_contact(packing.diameters)),
                                float(energy))


@lru_cache(maxsize=64)
def _contact_force_bound(pot, sigma: float, energy: float) -> float:
    """``_force_bound`` for one law and contact distance, cached: a protocol asks it once per
    minimisation with the same arguments (the root search cost 2 ms a call, 0.1 s per N = 64
    jam). The root of V(r) = energy on [sigma/2, sigma] by bisection (V falls with r): scipy's
    brentq cost a 0.1 s scipy.optimize import that a jam needs nowhere else."""
    lo, hi = 0.5 * sigma, sigma
    if pot.energy(np.array([lo]), sigma)[0] <= energy:
        return math.inf
    while hi - lo > 1e-15 * sigma:
        mid = 0.5 * (lo + hi)
        if mid in (lo, hi):  # float64 resolution
            break
        lo, hi = (mid, hi) if pot.energy(np.array([mid]), sigma)[0] > energy else (lo, mid)
    r = 0.5 * (lo + hi)
    return 10.0 * abs(pot.dv_dr(np.array([r]), sigma)[0])


def _stop_reason(s, ftol, energy, fmax, energy_prev, fmax_prev, ran, steps, done, fmax_at_vmin, fluctuation=None,
                 mechanical=None):
    """The stop reason or None. ``energy_prev`` is the previous window's ``mechanical`` energy
    (V + K per particle; V for the minimisers, where K = 0), which no-progress compares."""
    mechanical = energy if mechanical is None else mechanical
    fixed_box = s.pressure is None
    if not (math.isfinite(energy) and math.isfinite(fmax)) or (fixed_box and energy < s.v_min and fmax > fmax_at_vmin):
        return "blown-up"
    if fmax < ftol:
        return "force"
    if fixed_box and energy < s.v_min:
        return "energy-below-vmin"
    if fluctuation is not None and fluctuation < s.delta:
        return "energy-steady"
    if math.isfinite(energy_prev) and (energy_prev - mechanical) < s.delta * mechanical and fmax > 0.5 * fmax_prev:
        return "no-progress"
    if s.method == "cg" and ran < steps:
        return "linesearch"
    if done >= s.max_iterations:
        return "iteration-cap"
    return None
