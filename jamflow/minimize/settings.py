"""Settings and outcome of one minimisation: the minimiser, its tolerances and the creep method."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from jamflow.mechanics.force_floor import FORCE_TOL_BASE, force_floor
from jamflow.model.box import STRESS_MODES
from jamflow.support.reprs import changed_fields_repr
from jamflow.support.settings_errors import SettingError

METHODS = ("fire", "cg", "md")


MD_DAMPINGS = ("viscous", "pairwise")


CREEP_METHODS = ("auto", "newton", "soft-modes", "polish", "off")
CREEP_FORCE = 1e-9  # max force (eps/diameter) below which a minimisation that has not converged creeps


@dataclass(frozen=True)
class MinimizerSettings:
    """Parameters of one minimisation. Energies per particle in eps; forces in eps/diameter."""

    method: str = "fire"  #: ``fire``, ``cg`` or ``md``
    #: largest force component at convergence, eps / diameter; None: the force floor base x max(1, L / 20) x k,
    #: L the longest box side, k the contact stiffness, base the shape's ``force_tol_base`` (1e-14; 5e-13 for
    #: ellipses and spheroids)
    force_tol: float | None = None
    delta: float = 1e-16  #: the chapter's relative energy change threshold (V_t+1 - V_t) / V_t
    v_min: float = 1e-16  #: the chapter's V_min: below it (energy per particle, eps) the state counts as unjammed
    max_iterations: int = 500_000  #: most iterations of one minimisation
    window: int = 10000  #: iterations per LAMMPS call between checks of the stopping rules
    # FIRE initial step (0.1 diverges: docs/notes/failure-modes.md), in sqrt(m diameter^2 / eps); the compiled
    # FIRE takes it in units of sqrt(m l^2 / eps), l the shape's smallest unit-scale contact distance
    # (``engines.compiled.fire.time_unit``: 1 but for oblate spheroids and dimers of unequal sites)
    timestep: float = 0.05  #: FIRE's initial step, sqrt(m diameter^2 / eps)
    md_timestep: float = 0.1  #: step of damped MD, sqrt(m diameter^2 / eps)
    damping: float = 0.3  #: ``md`` only: damping coefficient b, sqrt(m eps) / diameter
    md_damping: str = "viscous"  #: ``md`` only: ``viscous`` (-b v on every particle) or ``pairwise`` (chapter eq. 2.3)
    md_sample_every: int = 10  #: ``md`` only: steps between the energy samples of the energy-steady rule
    pressure: float | None = None  #: target pressure (eps / diameter^d): the box relaxes to it; None: fixed box
    stress: str = "iso"  #: with ``pressure``: ``iso``, ``aniso`` (each P_aa) or ``tri`` (also the shear stresses to 0)
    # md of particles that turn (LAMMPS ellipsoids: fix langevin at T = 0, drag rate b / m on translations
    # and rotations). Near onset 0.01 reached the force tolerance where 0.3 was 500x off after 3e5 steps
    # (docs/notes/ellipses.md)
    rotating_damping: float = 0.01  #: ``md`` of particles that turn: drag rate b / m on translations and rotations
    # what a creeping minimisation (not converged, max force below 1e-9; 1e-6 for the polish of rigid bodies)
    # does between FIRE windows at a fixed box:
    # "soft-modes": Newton steps along its softest modes (``jamflow.minimize.soft_modes``), "polish": Gauss-Newton
    # active-set steps (``jamflow.minimize.polish``; disks/spheres and rigid bodies, linear spring), "newton":
    # Newton-Krylov steps on the exact Hessian with a kept Cholesky factor (``jamflow.minimize.newton``; disks and
    # spheres, linear spring; docs/notes/newton-krylov.md), "off"; "auto" =
    # what was measured to pay: the polish for rigid bodies (repeated every creep_after iterations) and for
    # 2D disks (once) with the linear spring, soft modes for the other shapes that turn (ellipses, spheroids,
    # rigid bodies with other laws) (docs/notes/nmers.md, docs/notes/soft-modes.md, docs/notes/speed-2.md section 8), nothing
    # otherwise
    #: between FIRE windows of a creeping minimisation: ``auto``, ``soft-modes``, ``polish``, ``newton`` or ``off``
    creep: str = "auto"
    creep_after: int | None = None  #: iterations before the first creep attempt; None: the method's measured value

    __repr__ = changed_fields_repr  # only the fields that differ from their defaults

    def __post_init__(self):
        if self.method not in METHODS:
            raise ValueError(f"unknown minimizer {self.method!r}; use one of {', '.join(METHODS)}")
        for name in ("delta", "v_min", "timestep", "md_timestep", "damping", "rotating_damping"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise SettingError(name, f"must be a finite positive number, got {value} (minimizer)")
        if self.force_tol is not None and not (math.isfinite(self.force_tol) and self.force_tol > 0):
            raise SettingError("force_tol", f"must be a finite positive number, got {self.force_tol}")
        if self.creep not in CREEP_METHODS:
            raise ValueError(f"unknown creep method {self.creep!r}; use one of {', '.join(CREEP_METHODS)}")
        if self.creep_after is not None and self.creep_after < 1:
            raise ValueError(f"creep_after must be a positive number of iterations, got {self.creep_after}")
        if self.md_damping not in MD_DAMPINGS:
            raise ValueError(f"unknown md_damping {self.md_damping!r}; use one of {', '.join(MD_DAMPINGS)}")
        if self.max_iterations < 1 or self.window < 1 or self.md_sample_every < 1:
            raise ValueError("max_iterations, window and md_sample_every must be positive integers")
        if self.pressure is not None and not (isinstance(self.pressure, (int, float)) and math.isfinite(self.pressure)
                                              and self.pressure > 0):
            raise ValueError(f"target pressure must be a finite positive number (eps/diameter^d), got {self.pressure!r}")
        if self.stress not in STRESS_MODES:
            raise ValueError(f"unknown stress mode {self.stress!r}; use one of {', '.join(STRESS_MODES)}")
        if self.method == "md":
            self._check_md()

    def _check_md(self) -> None:
        """The explicit damping must not overshoot (docs/notes/damped-md.md derives both limits)."""
        bdt = self.damping * self.md_timestep
        if self.rotating_damping * self.md_timestep >= 2.0:
            raise ValueError(f"rotating_damping x md_timestep = {self.rotating_damping * self.md_timestep:g} >= 2: "
                             "the explicit drag of fix langevin overshoots and diverges; use rotating_damping < "
                             "2 / md_timestep, e.g. 0.01 with md_timestep 0.1")
        if self.md_damping == "viscous" and bdt >= 2.0:
            raise ValueError(f"damping x md_timestep = {bdt:g} >= 2: the explicit drag "
                             "-b v overshoots and diverges (the blown-up state even reports V = 0); use "
                             "damping < 2 / md_timestep, e.g. 0.3 with md_timestep 0.1")
        if self.md_damping == "pairwise" and bdt >= PAIRWISE_BDT_LIMIT:
            raise ValueError(f"damping x md_timestep = {bdt:g} >= {PAIRWISE_BDT_LIMIT:.4g} with pairwise damping: "
                             f"a contact network's relative velocities are damped at up to b (z_i + z_j) / m "
                             f"(z_i + z_j <= {2 * KISSING_NUMBER_3D} for equal spheres), and the explicit step "
                             "diverges beyond rate x dt = 2; use damping x md_timestep < "
                             f"{PAIRWISE_BDT_LIMIT:.4g}, e.g. 0.3 with md_timestep 0.1")
        if self.window < 2 * self.md_sample_every:
            raise ValueError(f"window = {self.window} < 2 x md_sample_every = {2 * self.md_sample_every}: the "
                             "energy-steady rule needs at least 2 energy samples per window")

    def resolved_force_tol(self, box, stiffness: float = 1.0, base: float = FORCE_TOL_BASE) -> float:
        """The force tolerance: ``force_tol``, or by default the force floor (``mechanics.force_floor``)."""
        if self.force_tol is not None:
            return self.force_tol
        return force_floor(box, stiffness, base)

    def force_tol_for(self, packing, box=None) -> float:
        """``resolved_force_tol`` of ``packing``: its box (or ``box``, e.g. an engine's current
        one), its potential's contact stiffness and its shape's ``force_tol_base``."""
        return self.resolved_force_tol(packing.box if box is None else box, packing.potential.contact_stiffness,
                                       packing.shape.force_tol_base)

    def as_dict(self) -> dict:
        """The settings as plain values (JSON-serialisable)."""
        return {f"minimizer_{k}": v for k, v in asdict(self).items()}


@dataclass(frozen=True)
class MinimizeResult:
    """Outcome of one minimisation; ``converged`` is False for no-progress, linesearch
    and iteration-cap stops."""

    converged: bool  #: stopped by "force" or "energy-below-vmin" (``CONVERGED_REASONS``)
    reason: str  #: the stop: force, energy-below-vmin, energy-steady, no-progress, linesearch, iteration-cap, blown-up
    iterations: int  #: minimiser iterations
    energy_per_particle: float  #: V at the stop, eps
    max_force: float  #: largest force component at the stop, eps / diameter
    seconds: float  #: wall time
    max_torque: float = 0.0  #: largest generalized torque component tau_a / d_k (eps/diameter)
    creep_steps: int = 0  #: steps of the creep method kept (``MinimizerSettings.creep``)


CONVERGED_REASONS = ("force", "energy-below-vmin")


KISSING_NUMBER_3D = 12


# pairwise damping: v <- (1 - dt D/m) v with D = b sum_contacts (e_i - e_j)(e_i - e_j)^T (x) n n^T,
# lambda_max(D) <= b max_contacts (z_i + z_j) (Gershgorin) <= 2 x 12 b: stable for b dt < 2 / 24
PAIRWISE_BDT_LIMIT = 2.0 / (2 * KISSING_NUMBER_3D)
