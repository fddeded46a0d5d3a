"""Isotropic compression to jamming onset (seed chapter section 2.1, steps 1-4).

Start from random positions at phi0; after each minimisation compress by dphi if
V < V_tol, decompress if V > 2 V_tol, halve dphi whenever the state crosses from one
side to the other, and stop when V_tol < V < 2 V_tol (V is the energy per particle).
Box changes are affine (LAMMPS ``change_box ... remap``); the box is always set from
the original one so phi carries no accumulated round-off.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from ..engine.lammps import LammpsEngine
from ..minimize import MinimizerSettings, MinimizeResult
from ..packing import DENSEST_PHI, Packing, random_packing
from ..potentials import Potential, RepulsiveLJ, Spring, parse_potential
from ..sizes import parse_sizes

DEFAULT_PHI0 = {2: 0.80, 3: 0.55}
HISTORY_COLUMNS = ("phi", "energy_per_particle", "pressure", "dphi", "iterations", "max_force", "converged")


@dataclass(frozen=True)
class CompressionSettings:
    """Parameters of the compression protocol (dimensionless packing fractions;
    energies per particle in eps)."""

    phi0: float | None = None  # None: DEFAULT_PHI0[dim], well below phi_J
    dphi0: float = 1e-4
    v_tol: float = 1e-16
    max_steps: int = 100_000
    minimizer: MinimizerSettings = field(default_factory=MinimizerSettings)

    def __post_init__(self):
        for name in ("phi0", "dphi0", "v_tol"):
            value = getattr(self, name)
            if name == "phi0" and value is None:
                continue
            if not (isinstance(value, (int, float)) and math.isfinite(value)):
                raise ValueError(f"{name} must be a finite number, got {value!r}")
        if self.phi0 is not None and not 0.0 < self.phi0 < 1.0:
            raise ValueError(f"phi0 must lie in (0, 1), got {self.phi0}")
        if not 0.0 < self.dphi0 < 0.1:
            raise ValueError(f"dphi0 must lie in (0, 0.1), got {self.dphi0}; the seed uses 1e-4")
        if not self.v_tol > 0:
            raise ValueError(f"vtol must be positive, got {self.v_tol}; the seed uses 1e-16")
        if self.max_steps < 1:
            raise ValueError("max_steps must be a positive integer")

    def start_phi(self, dim: int) -> float:
        return DEFAULT_PHI0.get(dim, math.nan) if self.phi0 is None else self.phi0

    def as_dict(self) -> dict:
        out = {k: v for k, v in asdict(self).items() if k != "minimizer"}
        return {**out, **self.minimizer.as_dict()}


@dataclass(frozen=True)
class JamResult:
    """A packing at jamming onset and how it was found."""

    packing: Packing
    phi_j: float
    energy_per_particle: float
    pressure_tensor: np.ndarray
    max_force: float
    history: dict  # column name -> np.ndarray, one entry per minimisation
    settings: CompressionSettings
    seconds: float
    lammps_version: int

    @property
    def pressure(self) -> float:
        return float(np.trace(self.pressure_tensor) / self.packing.dim)

    @property
    def minimizations(self) -> int:
        return len(self.history["phi"])

    @property
    def iterations(self) -> int:
        return int(np.sum(self.history["iterations"]))

    def summary(self) -> str:
        return (f"phi_J = {self.phi_j:.10f}  V = {self.energy_per_particle:.3e}  "
                f"P = {self.pressure:.3e}  max|F| = {self.max_force:.1e}  "
                f"{self.minimizations} minimisations, {self.iterations} iterations, {self.seconds:.2f} s")


class JammingFailed(RuntimeError):
    """The protocol could not reach the energy window; the message says why and what to do."""


def jam(n: int = 256, dim: int = 2, sizes: str = "bi:1.4:0.5", potential: str | Potential = "spring",
        seed: int = 0, settings: CompressionSettings | None = None, *, start: Packing | None = None,
        observers=(), engine_options: dict | None = None) -> JamResult:
    """Jam N particles by isotropic compression; ``start`` overrides the random start.

    ``observers`` are callables ``f(step: dict)`` called after every minimisation
    (progress bars, writers).
    """
    settings = settings or CompressionSettings()
    if start is None:
        start = initial_packing(n, dim, sizes, potential, seed, settings.start_phi(dim))
        if isinstance(start.potential, RepulsiveLJ):
            start = remove_overlaps(start, settings.minimizer)
    return compress(start, settings, observers=observers, engine_options=engine_options)


def initial_packing(n, dim, sizes, potential, seed, phi0) -> Packing:
    """Validated random start (seed step 1); errors before any LAMMPS work."""
    if not isinstance(n, (int, np.integer)) or n < 2:
        raise ValueError(f"n must be an integer >= 2, got {n!r}")
    if dim not in (2, 3):
        raise ValueError(f"dim must be 2 or 3, got {dim!r}")
    if not 0.0 < phi0 < DENSEST_PHI[dim]:
        raise ValueError(f"phi0 = {phi0} must lie in (0, {DENSEST_PHI[dim]:.4f}), below the densest "
                         f"packing of equal {'disks' if dim == 2 else 'spheres'}")
    if not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    pot = parse_potential(potential) if isinstance(potential, str) else potential
    size_spec = parse_sizes(sizes) if isinstance(sizes, str) else sizes
    try:
        return random_packing(int(n), dim, size_spec, phi0, int(seed), pot)
    except ValueError as err:
        raise ValueError(f"{err} (n = {n} is too small for these sizes)") from None


def remove_overlaps(packing: Packing, minimizer: MinimizerSettings) -> Packing:
    """Relax a random start with the linear spring until V < V_min, so that a potential
    that diverges at r -> 0 (repulsive LJ) starts without significant overlaps (seed step 1;
    from a raw random start RLJ forces reach ~1e13 and LAMMPS loses atoms)."""
    with LammpsEngine(replace(packing, potential=Spring())) as engine:
        result = engine.minimize(minimizer)
        relaxed = engine.packing()
    if result.energy_per_particle >= minimizer.v_min:
        raise JammingFailed(f"the random start at phi0 = {packing.phi:.4f} does not relax to zero overlap "
                            f"(V = {result.energy_per_particle:.2e}): phi0 is above jamming; use a lower phi0")
    return replace(relaxed, potential=packing.potential)


def compress(packing: Packing, settings: CompressionSettings, *, observers=(), engine_options=None) -> JamResult:
    """Run the compression/decompression bisection from ``packing`` (seed steps 2-4)."""
    from ..engine.lammps_lib import lammps_version

    start_time = time.perf_counter()
    base_box, base_phi = packing.box, packing.phi
    rows = {c: [] for c in HISTORY_COLUMNS}
    with LammpsEngine(packing, **(engine_options or {})) as engine:
        phi, dphi, side = base_phi, settings.dphi0, None
        for step in range(settings.max_steps):
            engine.set_box(base_box.scaled((base_phi / phi) ** (1.0 / packing.dim)))
            result = engine.minimize(settings.minimizer)
            state = engine.state()
            _record(rows, phi, result, state.pressure, dphi)
            for observe in observers:
                observe({"step": step, "phi": phi, "dphi": dphi, "result": result})
            v = result.energy_per_particle
            if settings.v_tol < v < 2 * settings.v_tol:
                return _finish(engine, phi, result, rows, settings, start_time, lammps_version())
            new_side = "below" if v <= settings.v_tol else "above"
            if side is not None and new_side != side:
                dphi /= 2.0
            side = new_side
            _check_resolution(phi, dphi, settings)
            phi = phi + dphi if side == "below" else phi - dphi
            if not 0.0 < phi < 1.0:
                raise JammingFailed(f"packing fraction left (0, 1) (phi = {phi}); start from a lower phi0")
    raise JammingFailed(f"no packing in the window {settings.v_tol:g} < V < {2 * settings.v_tol:g} after "
                        f"{settings.max_steps} minimisations (last phi = {phi}, dphi = {dphi:g}); raise "
                        "max_steps or check the minimiser's stop reasons in the history")


def _check_resolution(phi, dphi, settings):
    if dphi < 4 * np.finfo(float).eps * phi:
        raise JammingFailed(
            f"the increment dphi = {dphi:.3g} reached float64 resolution at phi = {phi:.15f} without V landing in "
            f"({settings.v_tol:g}, {2 * settings.v_tol:g}); the window is narrower than the energy step "
            "between adjacent representable densities or the minimiser is not converging. Use a larger "
            "vtol (>= 1e-20 is resolvable for N <= 10^4) or a tighter force tolerance.")


def _record(rows, phi, result: MinimizeResult, pressure, dphi):
    values = (phi, result.energy_per_particle, pressure, dphi, result.iterations, result.max_force, result.converged)
    for column, value in zip(HISTORY_COLUMNS, values):
        rows[column].append(value)
    rows.setdefault("reason", []).append(result.reason)


def _finish(engine, phi, result, rows, settings, start_time, version) -> JamResult:
    state = engine.state()
    packing = engine.packing()
    if not result.converged:
        warnings.warn(f"final minimisation stopped by '{result.reason}' with max force {result.max_force:.2e} "
                      f"(tolerance {settings.minimizer.resolved_force_tol(packing.box):.1e}); the packing is in "
                      "the energy window but force balance is only as good as that max force", stacklevel=3)
    history = {k: np.array(v) for k, v in rows.items()}
    history["reason"] = history["reason"].astype("S")
    return JamResult(packing, phi, result.energy_per_particle, state.pressure_tensor, result.max_force,
                     history, settings, time.perf_counter() - start_time, version)
