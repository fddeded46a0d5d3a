"""Energy minimisation in LAMMPS with the seed's stopping rules (chapter section 2.1, step 3).

Methods:
- ``fire``: LAMMPS ``min_style fire`` (FIRE 2.0), ``min_modify norm max``.
- ``cg``: Polak-Ribiere conjugate gradient, ``min_modify line forcezero`` (the default
  backtracking line search stalls at forces ~1e-10, see docs/failure-modes.md).
- ``md``: damped molecular dynamics, ``fix nve`` + ``fix viscous b`` (drag -b v on every
  particle). This is *not* the pairwise damping of seed eq. 2.3: it also damps rattlers
  and is not Galilean invariant; both dissipate to the same local minima for large b,
  and the net momentum of a periodic packing is zero, so the minima found are comparable.

Stopping rules, checked after every ``window`` iterations (LAMMPS runs the window):
1. ``force``: max force component below ``force_tol`` (default scales with the box side and
   the contact stiffness, since round-off in positions of a box of side L limits forces to
   ~L * 1e-16 * d2V/dr2; repulsive LJ is 72x stiffer at contact than the linear spring),
   and, for particles that turn, every generalized torque component tau_a / d_k below it too
   (torque balance; d_k the rotational length of ``jamflow.shapes``).
2. ``energy-below-vmin``: energy per particle below ``v_min`` (seed rule b, V_min = 1e-16),
   also caught inside a window by ``fix halt``.
3. ``no-progress``: over a whole window the relative energy decrease was below ``delta``
   (seed rule a, delta = 1e-16) and the max force did not halve: the round-off floor.
   Reported as not converged by force; the protocol records it.
4. ``linesearch``: CG's line search could not move (LAMMPS stopped early).
5. ``iteration-cap``: ``max_iterations`` reached (not converged).
6. ``blown-up``: non-finite energy or force, or V < V_min with a force no state at V < V_min
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
from dataclasses import asdict, dataclass

import numpy as np

METHODS = ("fire", "cg", "md")
STRESS_MODES = ("iso", "aniso", "tri")  # box relaxation at a target pressure


@dataclass(frozen=True)
class MinimizerSettings:
    """Parameters of one minimisation. Energies per particle in eps; forces in eps/diameter."""

    method: str = "fire"
    force_tol: float | None = None  # None: 1e-14 * max(1, L / 20) * k, L the longest box side, k the contact stiffness
    delta: float = 1e-16  # seed's relative energy change threshold
    v_min: float = 1e-16  # seed's V_min (per particle)
    max_iterations: int = 500_000
    window: int = 10000  # iterations per LAMMPS call between rule checks
    timestep: float = 0.05  # FIRE initial step (0.1 diverges: docs/failure-modes.md), in sqrt(m diameter^2 / eps)
    md_timestep: float = 0.1  # damped-MD step
    damping: float = 0.3  # md only: drag coefficient b, in sqrt(m eps) / diameter
    pressure: float | None = None  # target pressure (eps / diameter^d): the box relaxes to it; None: fixed box
    stress: str = "iso"  # with pressure: iso | aniso (each P_aa) | tri (also the shear stresses -> 0)

    def __post_init__(self):
        if self.method not in METHODS:
            raise ValueError(f"unknown minimizer {self.method!r}; use one of {', '.join(METHODS)}")
        for name in ("delta", "v_min", "timestep", "md_timestep", "damping"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"minimizer {name} must be a finite positive number, got {value}")
        if self.force_tol is not None and not (math.isfinite(self.force_tol) and self.force_tol > 0):
            raise ValueError(f"force_tol must be a finite positive number, got {self.force_tol}")
        if self.method == "md" and self.damping * self.md_timestep >= 2.0:
            raise ValueError(f"damping x md_timestep = {self.damping * self.md_timestep:g} >= 2: the explicit drag "
                             "-b v overshoots and diverges (the blown-up state even reports V = 0); use "
                             "damping < 2 / md_timestep, e.g. 0.3 with md_timestep 0.1")
        if self.max_iterations < 1 or self.window < 1:
            raise ValueError("max_iterations and window must be positive integers")
        if self.pressure is not None and not (isinstance(self.pressure, (int, float)) and math.isfinite(self.pressure)
                                              and self.pressure > 0):
            raise ValueError(f"target pressure must be a finite positive number (eps/diameter^d), got {self.pressure!r}")
        if self.stress not in STRESS_MODES:
            raise ValueError(f"unknown stress mode {self.stress!r}; use one of {', '.join(STRESS_MODES)}")

    def resolved_force_tol(self, box, stiffness: float = 1.0) -> float:
        """The force tolerance; by default above the round-off floor ~ L * 1e-16 * stiffness."""
        if self.force_tol is not None:
            return self.force_tol
        return 1e-14 * max(1.0, float(box.lengths.max()) / 20.0) * max(1.0, stiffness)

    def as_dict(self) -> dict:
        return {f"minimizer_{k}": v for k, v in asdict(self).items()}


@dataclass(frozen=True)
class MinimizeResult:
    """Outcome of one minimisation; ``converged`` is False for no-progress, linesearch
    and iteration-cap stops."""

    converged: bool
    reason: str
    iterations: int
    energy_per_particle: float
    max_force: float
    seconds: float
    max_torque: float = 0.0  # largest generalized torque component tau_a / d_k (eps/diameter)


CONVERGED_REASONS = ("force", "energy-below-vmin")


def minimize(engine, settings: MinimizerSettings) -> MinimizeResult:
    """Minimise the engine's configuration at fixed box; the engine holds the result.

    The engine runs windows of iterations (``engine.minimizer_session``: LAMMPS or the
    compiled FIRE), each returning (iterations, total energy, max force component, max
    generalized torque component); the stopping rules are applied here, the same for every
    engine."""
    start = time.perf_counter()
    n = engine.template.n_mobile
    stiffness = engine.template.potential.contact_stiffness
    ftol = settings.resolved_force_tol(engine.box, stiffness)
    fmax_at_vmin = _force_bound(engine.template, n * settings.v_min)
    done, energy_prev, fmax_prev = 0, math.inf, math.inf
    with engine.minimizer_session(settings, ftol) as run_window:
        while True:
            steps = min(settings.window, settings.max_iterations - done)
            ran, energy_total, fmax, gmax = run_window(steps)
            done += ran
            energy = energy_total / n
            worst = max(fmax, gmax)  # forces and generalized torques share the units and the tolerance
            reason = _stop_reason(settings, ftol, energy, worst, energy_prev, fmax_prev, ran, steps, done,
                                  fmax_at_vmin)
            if reason:
                if settings.pressure is not None:  # report the potential energy, not the enthalpy
                    energy = engine.state().energy / n
                return MinimizeResult(reason in CONVERGED_REASONS, reason, done, energy, fmax,
                                      time.perf_counter() - start, gmax)
            energy_prev, fmax_prev = energy, worst


def _force_bound(packing, energy: float) -> float:
    """10x the largest force a particle can feel when the total energy is below ``energy``:
    the force of one contact of the smallest pair holding all of it, times sqrt(12) contacts
    (Cauchy-Schwarz) and a margin. A larger force at V < V_min means the state blew up."""
    from scipy.optimize import brentq

    pot, sigma = packing.potential, float(packing.shape.smallest_contact(packing.diameters))
    if pot.energy(np.array([0.5 * sigma]), sigma)[0] <= energy:
        return math.inf
    r = brentq(lambda x: pot.energy(np.array([x]), sigma)[0] - energy, 0.5 * sigma, sigma, xtol=1e-15 * sigma)
    return 10.0 * abs(pot.dv_dr(np.array([r]), sigma)[0])


def _stop_reason(s, ftol, energy, fmax, energy_prev, fmax_prev, ran, steps, done, fmax_at_vmin):
    fixed_box = s.pressure is None
    if not (math.isfinite(energy) and math.isfinite(fmax)) or (fixed_box and energy < s.v_min and fmax > fmax_at_vmin):
        return "blown-up"
    if fmax < ftol:
        return "force"
    if fixed_box and energy < s.v_min:
        return "energy-below-vmin"
    if math.isfinite(energy_prev) and (energy_prev - energy) < s.delta * energy and fmax > 0.5 * fmax_prev:
        return "no-progress"
    if s.method == "cg" and ran < steps:
        return "linesearch"
    if done >= s.max_iterations:
        return "iteration-cap"
    return None
