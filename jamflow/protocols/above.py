"""Packings above jamming onset: the onset packing compressed affinely by dphi and minimised again.

The state the elastic moduli are measured on (chapter section 4.5; O'Hern et al., PRE 68, 011306
(2003)): phi_J -> phi_J + dphi by one affine compression of box and centres (LAMMPS
``change_box ... remap``; orientations unchanged), then one energy minimisation at that fixed
box with the chapter's stopping rules (``jamflow.minimize.rules``). The minimisation can rearrange the
packing; if it relaxes to V < V_min (measured: 3 of 20 2D N = 256 spring packings compressed by
1e-3 from onset, none of 20 at 1e-6, 1e-5, 1e-4, 1e-2; docs/notes/moduli.md) the result is not jammed and
``JammingFailed`` is raised.
``dphi`` is an absolute step in
packing fraction; the onset packing's own distance above phi_J (V ~ 1e-16: overlaps ~1e-8) is
far below any dphi >= 1e-6.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass

import numpy as np

from jamflow.engines.choose import open_engine
from jamflow.minimize.settings import MinimizerSettings, MinimizeResult
from jamflow.model.packing import Packing
from jamflow.protocols.outcome import JammingFailed, engine_label
from jamflow.minimize.rules import minimize


@dataclass(frozen=True)
class AboveResult:
    """A packing at phi_onset + dphi, minimised."""

    packing: Packing  #: the minimised packing at phi_onset + dphi (diameters)
    phi_onset: float  #: the input packing's packing fraction
    dphi: float  #: the compression step
    energy_per_particle: float  #: eps
    pressure_tensor: np.ndarray  #: (d, d), eps / diameter^d
    minimization: MinimizeResult  #: the minimisation at the compressed box (stop reason, iterations, max force)
    engine: str  #: "numba" or "lammps"
    seconds: float  #: wall time of the run
    kernels: str = ""  #: the engine's ``kernels`` (summary line only)

    def __repr__(self) -> str:
        """One line: N, dim, shape, phi, dphi, V, P, max|F|, the stop, engine."""
        p, m = self.packing, self.minimization
        return (f"AboveResult(N={p.n}, dim={p.dim}, shape={p.shape.spec(p.dim)!r}, phi={p.phi:.10f}, "
                f"dphi={self.dphi:g}, V={self.energy_per_particle:.3e}, P={self.pressure:.3e}, "
                f"max_force={m.max_force:.1e}, reason={m.reason!r}, engine={self.engine!r})")

    @property
    def pressure(self) -> float:
        """P = trace / d of the pressure tensor, eps / diameter^d."""
        return float(np.trace(self.pressure_tensor) / self.packing.dim)

    def summary(self) -> str:
        """The line ``jamflow jam --above`` prints: phi, V, P, max|F|, the stop, the engine, seconds."""
        m = self.minimization
        return (f"above onset by {self.dphi:g}: phi = {self.packing.phi:.10f}  V = {self.energy_per_particle:.3e}  "
                f"P = {self.pressure:.3e}  max|F| = {m.max_force:.1e}  stop: {m.reason}, {m.iterations} iterations "
                f"({engine_label(self.engine, self.kernels)}), {self.seconds:.2f} s")


def check_dphi(dphi, phi: float) -> float:
    """A compression step that keeps phi in (phi, 1); ValueError otherwise."""
    if isinstance(dphi, bool) or not isinstance(dphi, (int, float, np.floating)) or not math.isfinite(dphi):
        raise ValueError(f"--above must be a finite number (a step in packing fraction), got {dphi!r}")
    if dphi <= 0:
        raise ValueError(f"--above must be positive (a compression above onset), got {dphi:g}; "
                         "use e.g. --above 1e-4")
    if phi + dphi >= 1.0:
        raise ValueError(f"phi_J + dphi = {phi:.6f} + {dphi:g} >= 1: no packing fraction above 1; use a smaller --above"
                         if phi else f"--above {dphi:g} >= 1 would compress past phi = 1; use a small step such as 1e-4")
    if dphi < 64 * np.finfo(float).eps * phi:
        raise ValueError(f"--above {dphi:g} is below the float64 resolution of phi = {phi:.6f} "
                         f"({64 * np.finfo(float).eps * phi:.1e}); use dphi >= 1e-12")
    return float(dphi)


def compress_above(packing: Packing, dphi: float, minimizer: MinimizerSettings | None = None,
                   engine: str = "auto", engine_options: dict | None = None) -> AboveResult:
    """``packing`` (an onset packing) compressed affinely to phi + ``dphi`` and minimised at that
    box. Raises ValueError on a bad step or a packing under gravity (settled, not compressed).

    Parameters
    ----------
    packing : jamflow.Packing
        A packing at its onset phi_J (``jamflow.jam``, ``load_packing``), without gravity.
    dphi : float
        The compression step in packing fraction (dimensionless, > 0, phi_J + dphi < 1).
    minimizer : jamflow.MinimizerSettings, optional
        How the compressed packing is minimised (default ``MinimizerSettings()``); no target
        pressure (the box is fixed).
    engine : {"auto", "numba", "lammps"}, default "auto"
        The engine (auto: the compiled engine when it runs the scene, else LAMMPS).
    engine_options : dict, optional
        Options for the engine's constructor (LAMMPS: skin, comm, args; compiled: skin).

    Returns
    -------
    AboveResult
        The minimised packing at phi_J + dphi with its V (eps), pressure tensor
        (eps / diameter^d), the minimisation and the engine.

    Raises
    ------
    ValueError
        A bad ``dphi``, a packing under gravity or a minimiser with a target pressure.
    RuntimeError
        The minimisation diverged (blown up).
    jamflow.JammingFailed
        The packing relaxed below V_min: it is not jammed at phi_J + dphi.
    """
    minimizer = minimizer or MinimizerSettings()
    phi = packing.phi
    check_dphi(dphi, phi)
    if packing.gravity > 0:
        raise ValueError("a packing under gravity is settled, not compressed: --above needs a packing without gravity")
    if minimizer.pressure is not None:
        raise ValueError("--above compresses at a fixed box; it does not combine with a target pressure")
    start = time.perf_counter()
    with open_engine(packing, minimizer.method, engine, **(engine_options or {})) as sim:
        sim.set_box(packing.box.scaled((phi / (phi + dphi)) ** (1.0 / packing.dim)))
        result = minimize(sim, minimizer)
        state, out, name, kernels = sim.state(), sim.packing(), sim.name, sim.kernels
    if result.reason == "blown-up":
        raise RuntimeError(f"the minimisation at phi = {phi + dphi:.10f} diverged (V = {result.energy_per_particle:.3g}, "
                           f"max force {result.max_force:.3g}); lower the minimiser timestep")
    if result.energy_per_particle < minimizer.v_min:  # by either stop: a dilute relaxation can end at F = 0 exactly
        raise JammingFailed(f"the packing compressed by {dphi:g} relaxed to V = {result.energy_per_particle:.2e} < V_min: "
                            "the minimisation rearranged it into a packing that is not jammed at phi_J + dphi (its own "
                            "phi_J lies higher); use a smaller step, or another packing")
    if not result.converged:
        warnings.warn(f"the minimisation at phi_J + {dphi:g} stopped by '{result.reason}' with max force "
                      f"{result.max_force:.2e}; force balance is only that good", stacklevel=2)
    return AboveResult(out, phi, float(dphi), result.energy_per_particle, state.pressure_tensor, result, name,
                       time.perf_counter() - start, kernels)
