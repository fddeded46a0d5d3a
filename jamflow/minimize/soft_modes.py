"""Newton steps along the softest modes of a creeping minimisation.

Near onset a hypostatic packing of rigid bodies has a few modes whose eigenvalues lie far below
the contact stiffness (the quartic modes of docs/notes/modes-rotations.md, held by the pressure
only; 3D dimers, alpha 1.5, N = 128: one at 2.6e-7 eps/diameter^2 below a band starting at
2.6e-5). FIRE relaxes such a mode at a rate ~ sqrt(lambda) per unit time, so the final
minimisation creeps: 7.8e5 iterations at max force 5e-11 in one seed of docs/notes/nmers.md, where
the residual force lay along that one mode (1.1e-10 of its 1.1e-10 norm).

``SoftModeSteps`` is a strategy of ``minimize.creep``: once a minimisation has run ``after``
iterations and its max force is below ``CREEP_FORCE`` without converging (its trigger), it
computes the ``MODES`` lowest eigenpairs (lambda_k, e_k) of the dynamical matrix of the
non-floaters (``analysis.hessian``, shift-invert Lanczos) and the gradient's components
c_k = e_k . dV/dxi on them, and takes the Newton step of that subspace,
xi -> xi - a sum_k c_k / |lambda_k| e_k over the modes with |lambda_k| > ``ZERO_MODE`` x the
contact stiffness (the trivial translations and free rotations excluded), with a in
``STEP_FACTORS`` the factor of lowest energy; the step is kept only if it lowers the energy,
else the configuration is put back. FIRE then resumes. It repeats every ``after`` iterations.
Unlike the disks' saddle escape of docs/notes/speed-2.md (negative modes only, measured not to pay),
it follows the positive soft modes too, where the creep of rigid bodies is.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from jamflow.mechanics.deformation import displaced
from jamflow.mechanics.hessian import Coordinates
from jamflow.mechanics.dynamical_matrix import DynamicalMatrix
from jamflow.mechanics.eigen import lowest_eigenpairs
from jamflow.mechanics.checks import generalized_forces
from jamflow.minimize.creep import CreepTrigger

# MinimizerSettings.creep_after defaults (``trigger``): iterations before the first attempt, and between attempts.
# Ellipses and spheroids: 10 000 (was 50 000; whole jams of 3D oblate 0.6 / prolate 1.5 spheroids, N = 64, took
# 2.4x / 1.5x fewer iterations, 2D ellipses 1.5 no more; docs/notes/ellipses.md). Other shapes (rigid bodies
# under laws other than the spring; disks or spheres with --creep soft-modes): 50 000 (2D Hertz dimers, N = 32:
# one seed of five took 2.6x more iterations with 10 000)
AFTER = 50_000
ELLIPSOID_AFTER = 10_000
AFTER_BY_SHAPE = {"ellipsoid": ELLIPSOID_AFTER}  # shape kinds whose measured trigger is not AFTER
MODES = 12  # lowest eigenpairs computed (beyond the d translations)
ZERO_MODE = 1e-10  # |lambda| below this x stiffness: a zero mode (no restoring force), left alone
SHIFT = 1e-8  # shift-invert about -SHIFT x stiffness (the matrix is positive semi-definite at a minimum)
STEP_FACTORS = (1.0, 0.5, 0.25, 2.0)
DENSE_LIMIT = 64  # matrices of up to this many rows are diagonalised densely
log = logging.getLogger(__name__)


def trigger(packing, after: int | None = None) -> CreepTrigger:
    """When the soft-mode steps run: every ``after`` iterations (None: the measured default,
    ``ELLIPSOID_AFTER`` for ellipses and spheroids, ``AFTER`` otherwise) while the max force is
    below ``CREEP_FORCE``."""
    after = after or AFTER_BY_SHAPE.get(packing.shape.kind, AFTER)
    return CreepTrigger(after, every=after)


@dataclass
class SoftModeSteps:
    """The "soft-modes" strategy of ``minimize.creep``: one Newton step along the softest modes
    per attempt (module docstring), kept only if it lowers the energy."""

    stiffness: float = 1.0  #: the contact stiffness scale of the zero-mode threshold and the shift, eps / diameter^2

    def attempt(self, engine, attempt: int, done: int) -> int:
        """One Newton step along the softest modes of the engine's packing; 1 if kept (it lowered the energy), else 0."""
        packing = engine.packing()
        try:
            dyn = DynamicalMatrix().compute(packing)
        except ValueError:  # no contact network left: nothing to step along
            return 0
        xi = newton_step(dyn, engine.state(), packing, self.stiffness)
        if xi is None:
            return 0
        return int(self._line_search(engine, packing, dyn, xi, attempt))

    def _line_search(self, engine, packing, dyn, xi, attempt: int) -> bool:
        e0 = engine.state().energy
        trials = []
        for a in STEP_FACTORS:
            moved = _moved(packing, dyn, a * xi)
            engine.set_positions(moved.positions, moved.orientations)
            trials.append((engine.evaluate().energy, a, moved))
        energy, factor, best = min(trials, key=lambda t: t[0])
        log.info("soft-mode step %d: |xi| %.3g, factor %g, energy %.6g -> %.6g (%s)", attempt,
                 float(np.linalg.norm(xi)), factor, e0, energy, "kept" if energy < e0 else "undone")
        chosen = best if energy < e0 else packing
        engine.set_positions(chosen.positions, chosen.orientations)
        engine.evaluate()
        return energy < e0


def newton_step(dyn, state, packing, stiffness: float = 1.0) -> np.ndarray | None:
    """The soft-subspace Newton step (module docstring) in the coordinates of ``dyn``'s
    non-floaters, or None when no mode qualifies. ``state`` holds the forces and torques of
    the whole ``packing``."""
    values, vectors = lowest_modes(dyn.matrix, MODES + dyn.dim, stiffness)
    grad = -generalized_forces(packing, state, dyn.particles)
    live = np.abs(values) > ZERO_MODE * stiffness
    if not live.any():
        return None
    c = vectors[:, live].T @ grad
    return -(vectors[:, live] @ (c / np.abs(values[live])))


def lowest_modes(matrix, k: int, stiffness: float) -> tuple[np.ndarray, np.ndarray]:
    """The k lowest eigenpairs of a symmetric sparse matrix (all of them for small ones), in
    ARPACK's order (``mechanics.eigen.lowest_eigenpairs``)."""
    return lowest_eigenpairs(matrix, k, SHIFT * stiffness, ascending=False, dense_limit=DENSE_LIMIT)


def _moved(packing, dyn, xi: np.ndarray):
    """The whole packing after the non-floaters move by xi (floaters stay)."""
    coords = Coordinates.of(dyn.packing)
    u_kept, rot_kept = coords.split(xi)
    u = np.zeros((packing.n, packing.dim))
    rot = np.zeros((packing.n, coords.n_rot))
    u[dyn.particles], rot[dyn.particles] = u_kept, rot_kept
    return displaced(packing, u, rot)
