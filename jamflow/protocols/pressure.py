"""Jamming at constant pressure: the box as a degree of freedom (chapter section 2.3, "constant
stress [35]"; the enthalpy-minimising definition of jamming, e.g. Dagois-Bohy et al., PRL 109,
095703 (2012), which also relaxes the shear stress).

From a start (a random one at phi0, or a given packing), minimise the enthalpy H = U + P V
at each pressure of a decreasing sequence, each from the previous minimum: the compiled
FIRE with box coordinates (``jamflow.engines.compiled.field``) or LAMMPS ``fix box/relax``
with CG (``etol 0``). ``stress``: ``iso`` (the box keeps its shape), ``aniso`` (each P_aa =
P), ``tri`` (also every shear stress relaxed to 0: the box tilts). Near jamming
phi - phi_J ~ P^(1/(alpha-1)) (alpha the potential's onset exponent: P ~ dV/dphi), so
phi_J is extrapolated from the two lowest pressures (``extrapolate_phi_j``); the phi at the
lowest pressure is reported beside it. With one pressure (a target at or above the start
pressure 1e-4) no extrapolation is possible: phi_J is NaN and reported as "n/a", never the phi
at that pressure.

The lowest target float64 resolves (``pressure_floor``): a contact force ~ P a^(d-1) must
stay ``FLOOR_MARGIN`` = 1000 times above the force round-off floor, i.e. the minimiser's
force tolerance (base max(1, L/20) k, base the shape's: 1e-14 for disks, 5e-13 for ellipses;
``MinimizerSettings.force_tol_for``); below it
force balance is no longer resolved against the contact forces. For 2D bidisperse disks
(mean diameter 1.2) that is P = 8.3e-12 up to L = 20 (N ~ 300), 1.6e-11 at N = 1024 and
3.2e-11 at N = 4096: it grows with L.

The highest target (``pressure_ceiling``): the box cannot shrink below twice the largest contact
distance (``model.packing.fits_cell``: a unique minimum image), and the pressure the particles carry
in that densest box, relaxed there by FIRE, bounds what a periodic box of them reaches: 0.74 for
2D bidisperse disks at N = 16, 12 at N = 64, 200 at N = 256 (linear spring; about 0.14 phi^2 in 2D
and 0.19 phi^2 in 3D, phi that box's packing fraction). Targets above it are refused before any
work; it is measured only for targets above ``CEILING_SCREEN`` phi^2 eps / diameter^d.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, field, replace

import numpy as np

from jamflow.engines.choose import open_engine
from jamflow.minimize.rules import minimize
from jamflow.protocols.outcome import JammingFailed, engine_label
from jamflow.minimize.settings import MinimizerSettings
from jamflow.model.box import STRESS_MODES
from jamflow.model.packing import Packing, densest_phi
from jamflow.protocols.compression import RLJ_MIN_START_RATIO, deepest_overlap, remove_overlaps
from jamflow.support import hooks
from jamflow.support.reprs import changed_fields_repr
from jamflow.support.settings_errors import SettingError

FLOOR_MARGIN = 1000.0
CEILING_SCREEN = 1e-3  # targets below this x phi^2 (densest box) are not probed: far below the measured 0.14 phi^2
CEILING_GAP = 1e-3  # the probe's box is this much (relative) wider than the densest one
CEILING_FORCE_TOL = 1e-8  # eps / diameter: the probe's forces are ~0.1-10, its pressure needs no better
DEFAULT_START_PRESSURE = 1e-4  # from a random start; starting higher raises phi_J (docs/notes/walls-gravity-pressure.md)
PRESSURE_COLUMNS = ("target_pressure", "phi", "pressure", "shear_stress", "energy_per_particle", "iterations",
                    "max_force", "max_box_force", "converged")  # max_box_force: largest box (or torque) force component


def pressure_sequence(target: float, start: float = DEFAULT_START_PRESSURE) -> tuple[float, ...]:
    """Decades from ``start`` down to ``target`` (inclusive); just ``target`` if it is above ``start``."""
    _check_pressure(target)
    seq = []
    p = start
    while p > target * (1 + 1e-9):
        seq.append(p)
        p /= 10.0
    return tuple(seq) + (float(target),)


def _check_pressure(p) -> None:
    if not (isinstance(p, (int, float, np.floating)) and math.isfinite(p) and p > 0):
        raise SettingError("pressure", f"must be a finite positive number (eps/diameter^d), got {p!r}")


@dataclass(frozen=True)
class PressureSettings:
    """A decreasing sequence of target pressures (eps / diameter^d) and how the box relaxes."""

    pressures: tuple = (1e-4, 1e-5, 1e-6)  #: target pressures, eps / diameter^d, decreasing (each minimum starts the next)
    stress: str = "iso"  #: how the box relaxes: "iso" (one scale), "aniso" (each length), "tri" (lengths and tilts)
    minimizer: MinimizerSettings = field(default_factory=MinimizerSettings)  #: the minimiser at each target

    __repr__ = changed_fields_repr  # only the fields that differ from their defaults

    def __post_init__(self):
        pressures = tuple(float(p) for p in self.pressures) if np.ndim(self.pressures) else (float(self.pressures),)
        if not pressures:
            raise ValueError("give at least one target pressure")
        for p in pressures:
            _check_pressure(p)
        if any(b >= a for a, b in zip(pressures, pressures[1:])):
            raise ValueError(f"target pressures must decrease (each minimum starts the next), got {pressures}")
        if self.stress not in STRESS_MODES:
            raise ValueError(f"unknown stress mode {self.stress!r}; use one of {', '.join(STRESS_MODES)}")
        object.__setattr__(self, "pressures", pressures)

    def as_dict(self) -> dict:
        """The settings as flat attributes of a packing file's protocol group."""
        return {"pressures": ",".join(repr(p) for p in self.pressures), "stress": self.stress,
                **self.minimizer.as_dict()}


def pressure_floor(packing: Packing, minimizer: MinimizerSettings) -> float:
    """Lowest target pressure float64 resolves for this packing (module docstring)."""
    ftol = minimizer.force_tol_for(packing)
    a = float(np.mean(packing.diameters))
    return FLOOR_MARGIN * ftol / a ** (packing.dim - 1)


def pressure_ceiling(packing: Packing) -> tuple[float, float]:
    """(P, phi): the pressure (eps / diameter^d) of ``packing`` compressed affinely to just above its
    densest box (``densest_phi``, ``CEILING_GAP``) and relaxed there by FIRE at that box, and that
    box's packing fraction. The pressure grows as the box shrinks, so no periodic box of these
    particles carries much more."""
    phi = densest_phi(packing) / (1.0 + CEILING_GAP) ** packing.dim
    dense = packing.scaled_to_phi(phi)
    with open_engine(dense, "fire") as sim:
        minimize(sim, MinimizerSettings(v_min=1e-300, force_tol=CEILING_FORCE_TOL))  # balance, no V_min stop
        return sim.state().pressure, phi


def check_pressure_ceiling(packing: Packing, target: float, option: str = "--pressure",
                           what: str | None = None) -> None:
    """Refuse, before any work, a target pressure above ``pressure_ceiling`` (measured only for
    targets above ``CEILING_SCREEN`` phi^2 eps / diameter^d, phi the densest box's; not for a
    potential that diverges at contact, repulsive LJ, whose random start FIRE cannot relax in that
    box); ``option`` chose the target, ``what`` names it in the message (default: the option and the
    target)."""
    if packing.potential.soft_start:
        return
    phi = densest_phi(packing)
    unit = packing.potential.epsilon / float(np.mean(packing.diameters)) ** packing.dim
    if target < CEILING_SCREEN * phi**2 * unit:
        return
    ceiling, phi = pressure_ceiling(packing)
    if target >= ceiling:
        raise ValueError(f"{what or option} {target:g} is above what {packing.n} {packing.shape.name(packing.dim)} "
                         f"particles carry in a periodic box: about {ceiling:.3g} at phi = {phi:.3g}, where the box "
                         "side is twice the largest contact distance (no smaller box has a unique minimum image); "
                         f"use a smaller {option}, or more particles")


def check_pressure_start(packing: Packing, settings: PressureSettings) -> None:
    """Refuse what the constant-pressure protocol cannot run, before any work."""
    if packing.box.walls or packing.gravity > 0 or packing.fixed is not None:
        raise ValueError("constant pressure relaxes a periodic box: it runs without walls, gravity or fixed particles")
    floor = pressure_floor(packing, settings.minimizer)
    ftol = settings.minimizer.force_tol_for(packing)
    if min(settings.pressures) < floor:
        raise ValueError(f"target pressure {min(settings.pressures):g} is below what float64 resolves at N = "
                         f"{packing.n} (box side {packing.box.lengths.max():.3g}): contact forces ~ P a^(d-1) must "
                         f"stay {FLOOR_MARGIN:g}x above the force round-off floor {ftol:.1e}, so P >= {floor:.1e}; "
                         "choose a larger target pressure, or --precision double-double (jamflow refine) to go below")
    check_pressure_ceiling(packing, max(settings.pressures))


def extrapolate_phi_j(pressures, phis, onset_exponent: float) -> float:
    """phi_J from phi = phi_J + c P^beta, beta = 1 / (alpha - 1), through the two lowest pressures;
    NaN with fewer than two (one point fixes no extrapolation)."""
    order = np.argsort(pressures)
    if len(order) < 2:
        return math.nan
    (p1, f1), (p2, f2) = [(pressures[k], phis[k]) for k in order[:2]]
    beta = 1.0 / (onset_exponent - 1.0)
    x1, x2 = p1**beta, p2**beta
    return float((f1 * x2 - f2 * x1) / (x2 - x1))


@dataclass(frozen=True)
class PressureResult:
    """The packing at the lowest pressure and one history row per target pressure."""

    packing: Packing  #: the packing at the lowest target pressure
    pressure_tensor: np.ndarray  #: (d, d) at the last pressure, eps / diameter^d
    history: dict  #: PRESSURE_COLUMNS (+ reason) -> array, one entry per target pressure
    settings: PressureSettings  #: the targets and the minimiser
    seconds: float  #: wall time of the run
    engine: str  #: "numba" or "lammps"
    lammps_version: int  #: the installed LAMMPS version as an integer date (e.g. 20250722), whichever engine ran
    kernels: str = ""  #: the engine's ``kernels`` (summary line only)

    def __repr__(self) -> str:
        """One line: N, dim, shape, phi and pressure at the last target, targets, engine."""
        p = self.packing
        return (f"PressureResult(N={p.n}, dim={p.dim}, shape={p.shape.spec(p.dim)!r}, phi={self.phi:.10f}, "
                f"P={self.pressure:.3e}, targets={len(self.settings.pressures)}, stress={self.settings.stress!r}, "
                f"engine={self.engine!r})")

    def save(self, path, checks=None, force: bool = False):
        """Write this result as ``jamflow jam --pressure P --out`` does (``jamflow.save_result``:
        checked first when ``checks`` is None; a result that fails its checks is not written)."""
        return hooks.call("save_result", self, path, checks, force=force)

    @property
    def phi(self) -> float:
        """Packing fraction at the lowest target pressure."""
        return float(self.history["phi"][-1])

    @property
    def phi_j(self) -> float:
        """phi_J extrapolated to P -> 0 from the two lowest pressures; NaN with one pressure."""
        return extrapolate_phi_j(self.history["target_pressure"], self.history["phi"],
                                 self.packing.potential.onset_exponent)

    @property
    def pressure(self) -> float:
        """P = trace / d of the pressure tensor at the last target, eps / diameter^d."""
        return float(np.trace(self.pressure_tensor) / self.packing.dim)

    @property
    def energy_per_particle(self) -> float:
        """V at the last target, eps."""
        return float(self.history["energy_per_particle"][-1])

    @property
    def max_force(self) -> float:
        """Largest force component at the last target, eps / diameter."""
        return float(self.history["max_force"][-1])

    @property
    def iterations(self) -> int:
        """Minimiser iterations over all targets."""
        return int(np.sum(self.history["iterations"]))

    def summary(self) -> str:
        """The line ``jamflow jam --pressure`` prints: target and reached P, phi, phi_J(P -> 0), shear stress, max|F|."""
        target = self.history["target_pressure"][-1]
        shear = shear_stress(self.pressure_tensor)
        return (f"P_target = {target:.3e}  P = {self.pressure:.6e} (rel. {self.pressure / target - 1:+.1e})  "
                f"phi = {self.phi:.10f}  {phi_j_text(self.phi_j)}  shear stress {shear:.1e}  "
                f"max|F| = {self.max_force:.1e}  {len(self.history['phi'])} pressures, {self.iterations} iterations "
                f"({engine_label(self.engine, self.kernels)}), {self.seconds:.2f} s")


def phi_j_text(phi_j: float) -> str:
    """phi_J(P->0) as the summary prints it: "n/a" when one pressure gives no extrapolation."""
    if math.isfinite(phi_j):
        return f"phi_J(P->0) = {phi_j:.10f}"
    return (f"phi_J(P->0) n/a: one pressure (a target below {DEFAULT_START_PRESSURE:g} runs a sequence of decades "
            "that extrapolates)")


def shear_stress(tensor: np.ndarray) -> float:
    """Largest |P_ab|, a != b (the residual shear stress; Sigma = -P_xy in 2D, chapter eq. 2.34)."""
    t = np.asarray(tensor)
    off = t - np.diag(np.diag(t))
    return float(np.abs(off).max())


def jam_at_pressure(start: Packing, settings: PressureSettings | None = None, *, observers=(), engine: str = "auto",
                    engine_options=None) -> PressureResult:
    """Minimise the enthalpy at each target pressure in turn, from ``start``."""
    from jamflow.engines.lammps.library import lammps_version

    settings = settings or PressureSettings()
    check_pressure_start(start, settings)
    t0 = time.perf_counter()
    if start.potential.soft_start and deepest_overlap(start) < RLJ_MIN_START_RATIO:
        # repulsive LJ diverges at contact: from deep overlaps (a random start always) the forces
        # blew the box up to an infinite size ("array is too big"); relax with the spring first, as jam() does
        start = remove_overlaps(start, settings.minimizer, engine)
    rows = {c: [] for c in PRESSURE_COLUMNS}
    reasons = []
    method = settings.minimizer.method
    with open_engine(start, method, engine, pressure=True, **(engine_options or {})) as sim:
        for step, target in enumerate(settings.pressures):
            minimizer = replace(settings.minimizer, pressure=target, stress=settings.stress)
            result = minimize(sim, minimizer)
            state = sim.state()
            packing = sim.packing()
            values = (target, packing.phi, state.pressure, shear_stress(state.pressure_tensor),
                      result.energy_per_particle, result.iterations, result.max_force, result.max_torque,
                      result.converged)
            for column, value in zip(PRESSURE_COLUMNS, values):
                rows[column].append(value)
            reasons.append(result.reason)
            for observe in observers:
                observe({"step": step, "phi": packing.phi, "dphi": 0.0, "result": result})
            if result.reason == "blown-up":
                other = ("the LAMMPS engine's CG box relaxation (--engine lammps --minimizer cg), or "
                         if sim.name != "lammps" else "")
                raise JammingFailed(f"the minimisation at P = {target:g} diverged (the box coordinates ran away "
                                    f"within a window of FIRE steps): use {other}a lower target pressure, or a "
                                    "smaller FIRE timestep (MinimizerSettings.timestep)")
            if not result.converged:
                warnings.warn(f"the minimisation at P = {target:g} stopped by '{result.reason}' (max force "
                              f"{result.max_force:.2e}, box force {result.max_torque:.2e})", stacklevel=2)
        name, kernels = sim.name, sim.kernels
    history = {k: np.array(v) for k, v in rows.items()}
    history["reason"] = np.array(reasons).astype("S")
    return PressureResult(packing, state.pressure_tensor, history, settings, time.perf_counter() - t0, name,
                          lammps_version(), kernels)

