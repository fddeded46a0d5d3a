"""Particle-shape annealing (chapter section 2.3.3): from a jammed packing of disks/spheres, grow
the aspect ratio in steps of dalpha (random, or all aligned, major-axis directions at the first
step), re-jamming
with the compression protocol of section 2.1 at every step.

Each step replaces the shape (a particle's size stays its b, a = ALPHA b), rescales the box
affinely back to the previous step's phi_J (the longer particles would otherwise start at
phi_J ALPHA / ALPHA_prev, deep above onset), and jams from there (``compress``: it
decompresses or compresses as the energy says). Every step's packing is checked
(``jamflow.mechanics.checks``); its phi_J, <z> and floaters are recorded.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np

from jamflow.model.nematic import Nematic
from jamflow.mechanics.checks import check_packing
from jamflow.model.packing import Packing
from jamflow.model.shapes.rotations import check_start, start_orientations
from jamflow.model.shapes.shape import SPHERE, Ellipsoid
from jamflow.protocols.settings import DEFAULT_PROTOCOL, PROTOCOLS, CompressionSettings
from jamflow.protocols.outcome import JammingFailed, JamResult
from jamflow.protocols.compression import check_resolution, check_window_reachable, jam

STEP_COLUMNS = ("alpha", "phi_j", "mean_z", "n_contacts", "n_floaters", "p2", "energy_per_particle", "max_force",
                "checks_passed", "minimizations", "iterations", "seconds")


@dataclass
class AnnealResult:
    """The last step's jam (``final``, packing and checks) and one row per step in ``steps``
    (columns ``STEP_COLUMNS``; row 0 is the input packing)."""

    final: JamResult  #: the jam at the last aspect ratio
    checks: object  #: its ``PackingChecks``
    steps: dict  #: STEP_COLUMNS -> array, one row per step (row 0: the input packing)

    def __repr__(self) -> str:
        """One line: N, shape, the aspect ratios walked, phi_J, checks; ``steps`` holds the table."""
        p, alpha = self.packing, self.steps["alpha"]
        return (f"AnnealResult(N={p.n}, dim={p.dim}, shape={p.shape.spec(p.dim)!r}, steps={len(alpha) - 1}, "
                f"alpha=[{alpha[0]:.4g}, {alpha[-1]:.4g}], phi_j={self.final.phi_j:.10f}, "
                f"checks_passed={getattr(self.checks, 'passed', None)})")

    @property
    def packing(self) -> Packing:
        """The annealed packing at the last aspect ratio."""
        return self.final.packing


MAX_STEPS = 1_000_000  # aspect-ratio steps of one anneal, each a minimisation


def anneal_alphas(alpha0: float, target: float, dalpha: float) -> np.ndarray:
    """The aspect ratios of the steps after ``alpha0``: alpha0 +- k dalpha, the last one ``target``
    exactly (a shorter final step if dalpha does not divide the change)."""
    change = target - alpha0
    n = max(1, math.ceil(abs(change) / dalpha - 1e-9))
    if n > MAX_STEPS:
        raise ValueError(f"{n:.4g} steps of dalpha (--dalpha) = {dalpha:g} from {alpha0:g} to {target:g}: more than "
                         f"{MAX_STEPS:,}; use a dalpha of at least {abs(change) / MAX_STEPS:.3g}")
    steps = alpha0 + math.copysign(dalpha, change) * np.arange(1, n + 1)
    steps[-1] = target
    return np.round(steps, 12)


def check_anneal(start: Packing, target: float, dalpha: float, contact: str | None = None,
                 orientations: str = "random") -> float:
    """Refuse, before any work, what cannot be annealed; returns the start's aspect ratio.
    ``orientations``: the first step's major-axis directions, "random", "aligned" or "nematic:S"
    (round starts; ``rotations.start_orientations``)."""
    for name, value in (("--to", target), ("--dalpha", dalpha)):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    alpha0 = start.shape.aspect_ratio
    if alpha0 is None:
        raise ValueError(f"shape annealing starts from disks/spheres (or ellipses/spheroids), not "
                         f"{start.shape.name(start.dim)} particles")
    if start.box.walls or start.fixed is not None or start.gravity:
        raise ValueError("shape annealing runs in a periodic box: the input has walls, fixed particles or gravity")
    alpha0 = float(alpha0)
    if check_start(orientations) is not None and start.shape.oriented:
        raise ValueError(f"--orientations {orientations} sets the first step's directions of a round start; the input "
                         f"{start.shape.name(start.dim)}s keep their own: leave --orientations out")
    if target == alpha0:
        raise ValueError(f"the input is already at aspect ratio {alpha0:g}; give --to another ALPHA")
    if (target - 1.0) * (alpha0 - 1.0) < 0:
        raise ValueError(f"--to {target:g} lies across ALPHA = 1 from the input's {alpha0:g} (prolate vs oblate): "
                         "anneal from a disk/sphere packing instead")
    if start.dim == 2 and target < 1:
        raise ValueError(f"--to {target:g}: an ellipse with ALPHA = {target:g} < 1 is the ellipse with ALPHA = "
                         f"{1 / target:g} turned by 90 degrees; use --to {1 / target:g}")
    shape = Ellipsoid(float(target), contact or getattr(start.shape, "contact", "exact"))
    shape.check(start.dim)  # an ellipse with ALPHA < 1
    shape.check_sizes(start.diameters, start.dim)  # gaussian / truncations outside their domain
    if dalpha > abs(target - alpha0):
        raise ValueError(f"--dalpha {dalpha:g} is larger than the whole change {alpha0:g} -> {target:g}; use a "
                         "smaller step (the chapter uses 0.05 and 0.005)")
    return alpha0


def _grown(packing: Packing, alpha: float, contact: str, rng: np.random.Generator, start: str = "random") -> Packing:
    """``packing`` with aspect ratio ``alpha`` (directors ``start``, random, aligned or nematic:S, if it was
    round), box and positions rescaled so that phi stays what it was."""
    orientations, metadata = packing.orientations, {**packing.metadata, "anneal": True}
    if orientations is None:
        orientations, metadata["orientations"] = start_orientations(start, packing.n, packing.dim, rng), start
    shape = SPHERE if alpha == 1.0 else Ellipsoid(float(alpha), contact)
    grown = replace(packing, shape=shape, orientations=orientations, metadata=metadata)
    return grown.scaled_to_phi(packing.phi)


def anneal(start: Packing, target: float, dalpha: float, settings: CompressionSettings | None = None, *,
           seed: int = 0, contact: str | None = None, engine: str = "auto", observers=(),
           orientations: str = "random") -> AnnealResult:
    """Anneal the shape of the jammed ``start`` to aspect ratio ``target`` in steps of ``dalpha``.

    ``seed``: the random major-axis directions of the first step (a round start only);
    ``orientations`` "aligned": all of them along x instead (a nematic start, Figure 2.23(c));
    "nematic:S": in a cone about x with P2 = S (``rotations.start_orientations``).
    ``observers``: callables ``f(row: dict)`` after each step (progress bars). JammingFailed
    if a step's protocol fails, or the last step's packing fails its checks.
    """
    settings = settings or PROTOCOLS[DEFAULT_PROTOCOL]()
    alpha0 = check_anneal(start, target, dalpha, contact, orientations)
    contact = contact or getattr(start.shape, "contact", "exact")
    rng = np.random.default_rng(seed)
    alphas = anneal_alphas(alpha0, float(target), float(dalpha))
    packing = _grown(start, alphas[0], contact, rng, orientations)
    check_resolution(packing, settings)
    check_window_reachable(packing, settings, engine, denser=None)  # before the first step, without --pressure
    rows = {c: [] for c in STEP_COLUMNS}
    _append(rows, alpha0, start, check_packing(start), None, 0.0)
    result = checks = None
    for k, alpha in enumerate(alphas):
        if k:
            packing = _grown(result.packing, alpha, contact, rng)
        t0 = time.perf_counter()
        result = jam(start=packing, settings=settings, engine=engine)
        checks = check_packing(result.packing, result.energy_per_particle, None, settings.v_tol,
                               _force_tol(result.packing, settings))
        _append(rows, alpha, result.packing, checks, result, time.perf_counter() - t0)
        for observe in observers:
            observe({c: rows[c][-1] for c in STEP_COLUMNS})
    if not checks.passed:
        raise JammingFailed(f"the annealed packing at ALPHA = {alphas[-1]:g}, phi_J = {result.phi_j:.10f} failed "
                            f"its checks: {'; '.join(checks.problems())}")
    return AnnealResult(result, checks, {c: np.asarray(v) for c, v in rows.items()})


def _force_tol(packing: Packing, settings: CompressionSettings) -> float:
    return settings.minimizer.force_tol_for(packing)


def _append(rows: dict, alpha: float, packing: Packing, checks, result: JamResult | None, seconds: float) -> None:
    p2 = Nematic().compute(packing).p2 if packing.shape.oriented else math.nan  # nematic order (section 4.3)
    values = dict(alpha=float(alpha), phi_j=packing.phi, mean_z=checks.mean_z, n_contacts=checks.n_contacts,
                  n_floaters=checks.n_floaters, p2=p2, energy_per_particle=checks.energy_per_particle,
                  max_force=checks.max_force, checks_passed=bool(checks.passed),
                  minimizations=0 if result is None else result.minimizations,
                  iterations=0 if result is None else result.iterations, seconds=float(seconds))
    for c in STEP_COLUMNS:
        rows[c].append(values[c])
