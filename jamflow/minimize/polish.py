"""Gauss-Newton active-set polish of a disk/sphere minimisation near force balance (docs/notes/speed-2.md).

With the linear spring (alpha = 2, eps = 1) the energy is a nonlinear least-squares objective,
V = 1/2 sum_pairs max(0, delta_ij)^2 with delta = 1 - r_ij / sigma_ij (chapter eq. 2.1). Its
Gauss-Newton model about x, m(dx) = 1/2 sum max(0, delta + J dx)^2 + mu/2 |dx|^2 (J = d delta / dx
over the pairs within sigma + ``SKIN``), is convex and piecewise quadratic, and any dx with
m(dx) < m(0) = V is a descent direction of V. A polish step minimises m by semismooth Newton
(an active set A = {delta + J dx > 0}, the solve (J_A^T J_A + mu I) p = -grad m by sparse LU,
and the exact minimiser of m along p, so the gaps that p would close stop it and join A next),
then accepts x + alpha dx by Armijo backtracking on the engine's exact energy; where the predicted
decrease is below the energy's round-off, the step must lower the max force instead. The
Hessian's tension terms (-delta / (r sigma) (I - n n^T), of order -P) are left out: J^T J is
positive semidefinite, so a step never heads for a saddle, which is why this converges where
Newton on the full active-set Hessian did not (docs/notes/speed-2.md sections 3-4 and 8). The shift mu
(1e-12 of the largest diagonal) fixes the d translations and the rattlers, whose right-hand
side is zero. Convergence is linear near a minimum (rate ~ tension / stiffness along the
softest mode); its use is the creep of the final minimisations near onset, where FIRE spends
1e4-1e5 iterations rolling off a saddle whose soft mode (J^T J ~ 1e-11, Hessian ~ -P) ends at a
contact change that the model's active set finds in one step.

A full Newton step with the exact Hessian, tried first wherever H + mu I is positive definite,
was an option once: quadratic far above onset, but near onset H is indefinite at almost
every state and it was never accepted in the N = 256 / 1024 jams, so it was removed.

Rigid bodies of fused sites (n-mers) are polished the same way: their energy is the same
sum over site pairs of different bodies, delta = 1 - s with s = |r_s - r_t| / sigma, and J is
ds/dxi in the generalized coordinates of ``analysis.hessian.Coordinates`` (centres, then the
rotations d_k theta; ``hessian.distance_jacobian``, the rows the dynamical matrix uses), so the
model is linear in the rotations too and a step moves and turns the bodies rigidly
(``analysis.deformation.displaced``); its neglected terms are the tensions and the rotations'
second order, which the exact-energy line search absorbs. The creep it is for is the
contact-change kind that the soft-mode steps (``jamflow.minimize.soft_modes``) undo: 3D dimers creeping
1e5-1e6 iterations per minimisation at max force 1e-11 to 5e-9 (docs/notes/nmers.md).

Only the linear spring at a fixed periodic box (``polish_reason``); the engine is any
``jamflow.engines.base.Engine`` (positions, set_positions, evaluate, packing); disk and sphere
pairs come from the compiled disk kernel's builder. Measured in benchmarks/gauss_newton_polish.py
(docs/notes/speed-2.md section 8: N = 1024 median CPU time -19% to -38%, phi_J statistically equal).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np

from jamflow.minimize import cholesky
from jamflow.minimize.creep import CreepTrigger

RIGID_CREEP_FORCE = 1e-6  # rigid bodies: their minimisations also creep at 1e-9 - 5e-9 (docs/notes/nmers.md)
SKIN = 0.05  # candidate pairs within sigma + SKIN (diameters): the gaps a step may close
SHIFT = 1e-12  # mu, relative to the largest diagonal of J^T J
ARMIJO = 1e-4
ALPHAS = 0.5 ** np.arange(14)  # backtracking 1 ... 1.2e-4
INNER = 10  # active-set iterations per step
MAX_STEPS = 40
log = logging.getLogger(__name__)
AFTER = 20_000  # MinimizerSettings.creep_after default: iterations before a minimisation is polished (measured)


@dataclass(frozen=True)
class PolishStep:
    """One Gauss-Newton step: pairs in the model's final active set, active-set iterations,
    accepted step length (0: none accepted), max force component before and after (eps/diameter)."""

    active: int
    inner: int
    alpha: float
    force_before: float
    force_after: float


@dataclass(frozen=True)
class PolishResult:
    converged: bool  # max force below the tolerance
    steps: tuple
    max_force: float
    seconds: float  # process (CPU) time


def polish_reason(packing) -> str:
    """'' if ``polish`` applies to this packing, else why not (one phrase)."""
    pot = packing.potential
    if not packing.shape.sphere_contacts:
        return (f"the Gauss-Newton polish needs disks, spheres or rigid bodies of fused sites, not "
                f"{packing.shape.kind} particles")
    if getattr(pot, "name", "") != "spring" or float(pot.alpha) != 2.0:
        return "the Gauss-Newton polish needs the linear spring (alpha = 2), the least-squares energy"
    if packing.fixed is not None or not all(packing.box.periodic) or packing.gravity:
        return "the Gauss-Newton polish needs a periodic box without walls, fixed particles or gravity"
    return ""


def overlaps(x: np.ndarray, pairs) -> tuple[np.ndarray, sp.csr_matrix]:
    """delta = 1 - r / sigma over ``pairs`` (i, j, shift, sigma) and its Jacobian J (P x N d)."""
    return pair_geometry(x, pairs)[2:]


def pair_geometry(x: np.ndarray, pairs):
    """(dr, r, delta, J) of ``pairs`` (i, j, shift, sigma): dr = x_i - x_j + shift, r = |dr|,
    delta = 1 - r / sigma and its Jacobian J = d delta / dx (P x N d, sparse)."""
    import scipy.sparse as sp  # loaded only when a polish runs

    n, d = x.shape
    dr = x[pairs.i] - x[pairs.j] + pairs.shift
    r = np.sqrt(np.einsum("ij,ij->i", dr, dr))
    delta = 1.0 - r / pairs.sigma
    g = dr / (r * pairs.sigma)[:, None]  # d delta / d x_j = +g, d delta / d x_i = -g
    rows = np.repeat(np.arange(len(r)), 2 * d)
    cols = np.concatenate([pairs.i[:, None] * d + np.arange(d), pairs.j[:, None] * d + np.arange(d)], axis=1)
    jac = sp.csr_matrix((np.concatenate([-g, g], axis=1).ravel(), (rows, cols.ravel())), shape=(len(r), n * d))
    return dr, r, delta, jac


def model(packing):
    """(delta, J) of the pairs within sigma + ``SKIN`` at ``packing``:
    disks/spheres by ``overlaps`` on the compiled builder's pair list, rigid bodies over site pairs
    in generalized coordinates (``hessian.distance_jacobian``)."""
    if packing.shape.round:
        from jamflow.engines.compiled.spheres import build  # the disk/sphere pair list (i, j, shift, sigma)

        return overlaps(packing.positions, build(packing, packing.positions, SKIN))
    from jamflow.mechanics.hessian import distance_jacobian

    s, jac = distance_jacobian(packing, SKIN)
    return 1.0 - s, -jac


def moved(packing, dx: np.ndarray):
    """The packing after the generalized displacement dx (centres, then rotations d_k theta)."""
    if not packing.shape.oriented:
        return packing.with_positions(packing.positions + dx.reshape(packing.positions.shape))
    from jamflow.mechanics.deformation import displaced
    from jamflow.mechanics.hessian import Coordinates

    return displaced(packing, *Coordinates.of(packing).split(dx))


def _place(engine, packing) -> None:
    engine.set_positions(packing.positions, packing.orientations)


def model_value(delta: np.ndarray, jac, dx: np.ndarray, mu: float) -> float:
    """m(dx) = 1/2 sum max(0, delta + J dx)^2 + mu/2 |dx|^2."""
    lin = delta + jac @ dx
    return 0.5 * float(np.sum(np.maximum(lin, 0.0) ** 2)) + 0.5 * mu * float(dx @ dx)


def line_minimum(a: np.ndarray, b: np.ndarray, dx: np.ndarray, p: np.ndarray, mu: float) -> float:
    """The minimiser t >= 0 of m(dx + t p) = 1/2 sum max(0, a + t b)^2 + mu/2 |dx + t p|^2 (a convex
    piecewise quadratic: its slope increases with t), by bisection on the slope."""
    c0, c1 = mu * float(dx @ p), mu * float(p @ p)

    def slope(t):
        r = a + t * b
        on = r > 0
        return float(b[on] @ r[on]) + c0 + t * c1

    if slope(0.0) >= 0:
        return 0.0
    hi = 1.0
    while slope(hi) < 0 and hi < 1e6:
        hi *= 2.0
    lo = 0.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if slope(mid) < 0 else (lo, mid)
    return lo


def shift(jac: sp.csr_matrix) -> float:
    """mu of the model: ``SHIFT`` times the largest diagonal of J^T J (at least ``SHIFT``)."""
    return SHIFT * max(float(np.asarray(jac.multiply(jac).sum(axis=0)).max(initial=0.0)), 1.0)


def factorisation(ja: sp.csr_matrix, active: np.ndarray, mu: float):
    """A factorisation of J_a^T J_a + mu I with ``solve(b)`` (``ja`` the active rows of J;
    ``active`` unused here, given to every factorisation ``model_step`` may be passed): SciPy's
    SuperLU, and from ``cholesky.CHOLMOD_FROM_DOF`` coordinates on CHOLMOD, whose ordering does
    not slow down on particles numbered along a space-filling curve (``jamflow.minimize.cholesky``)."""
    import scipy.sparse as sp  # loaded only when a polish runs

    matrix = ja.T @ ja + mu * sp.identity(ja.shape[1], format="csc")
    if ja.shape[1] < cholesky.CHOLMOD_FROM_DOF:
        return cholesky.superlu(matrix)
    return _Solver(cholesky.factorise(matrix))


@dataclass(frozen=True)
class _Solver:
    solve: object  # b -> x


def model_step(delta: np.ndarray, jac: sp.csr_matrix, mu: float, factorise=factorisation) -> tuple[np.ndarray, int, int]:
    """Minimise m(dx) by semismooth Newton with exact line searches on m; ends when a full step
    keeps the active set. ``factorise(ja, active, mu)`` returns an object whose ``solve(b)`` solves
    (J_a^T J_a + mu I) x = b. Returns (dx, pairs in the last active set, active-set iterations)."""
    dx = np.zeros(jac.shape[1])
    k = 0
    for k in range(1, INNER + 1):
        lin = delta + jac @ dx
        active = lin > 0
        ja = jac[active]
        grad = ja.T @ lin[active] + mu * dx
        p = factorise(ja, active, mu).solve(-grad)
        t = line_minimum(lin, jac @ p, dx, p, mu) if float(grad @ p) < 0 else 0.0
        if t <= 0:
            break
        dx = dx + t * p
        if t >= 1.0 and np.array_equal(delta + jac @ dx > 0, active):
            break
    return dx, int((delta + jac @ dx > 0).sum()), k


def _line_search(engine, packing, dx, state, grad, noise: float):
    """Armijo backtracking on the exact energy along dx from ``packing`` (gradient ``grad``),
    ``noise`` the energy's round-off; (alpha, trial state, trial packing), alpha 0 if no step
    length is accepted."""
    slope = float(grad @ dx)
    if slope >= 0:
        return 0.0, state, packing
    worst = float(np.abs(grad).max(initial=0.0))
    for alpha in ALPHAS:
        trial_packing = moved(packing, alpha * dx)
        _place(engine, trial_packing)
        trial = engine.evaluate()
        rise = trial.energy - state.energy
        if -alpha * slope > noise:
            ok = rise <= ARMIJO * alpha * slope
        else:  # the predicted decrease is below the energy's round-off: the max force decides
            ok = rise <= noise and _worst(trial_packing, trial) < worst
        if ok:
            return float(alpha), trial, trial_packing
    return 0.0, state, packing


def _worst(packing, state) -> float:
    """Max |component| of -dV/dxi at ``packing``: forces and generalized torques tau_a / d_k
    (eps/diameter)."""
    from jamflow.mechanics.checks import generalized_forces

    return float(np.abs(generalized_forces(packing, state)).max(initial=0.0))


def polish(engine, ftol: float, max_steps: int = MAX_STEPS, on_step=None) -> PolishResult:
    """Gauss-Newton steps on ``engine``'s configuration until its max force and generalized torque
    component is below ``ftol`` (eps/diameter) or no step length is accepted; the engine keeps the
    last accepted configuration, evaluated. ``on_step(PolishStep)`` is called after every step."""
    from jamflow.mechanics.checks import generalized_forces

    reason = polish_reason(engine.template)
    if reason:
        raise ValueError(f"{reason}; minimise with FIRE alone")
    if not (np.isfinite(ftol) and ftol > 0):
        raise ValueError(f"the polish's force tolerance must be a finite positive number (eps/diameter), got {ftol!r}")
    c0 = time.process_time()
    packing = engine.packing()
    _place(engine, packing)  # the states compared below are all evaluated from arrays set here
    state = engine.evaluate()
    grad = -generalized_forces(packing, state)
    worst = float(np.abs(grad).max(initial=0.0))
    steps = []
    while worst >= ftol and len(steps) < max_steps:
        delta, jac = model(packing)
        mu = shift(jac)
        noise = 8 * np.finfo(float).eps * float(np.sum(np.maximum(delta, 0.0)))  # V = sum delta^2 / 2, each delta to ~eps
        before = worst
        dx, n_active, inner = model_step(delta, jac, mu)
        accepted, trial, trial_packing = _line_search(engine, packing, dx, state, grad, noise)
        if accepted:
            packing, state = trial_packing, trial
            grad = -generalized_forces(packing, state)
            worst = float(np.abs(grad).max(initial=0.0))
        step = PolishStep(n_active, inner, accepted, before, worst)
        steps.append(step)
        if on_step is not None:
            on_step(step)
        if not accepted:
            _place(engine, packing)
            state = engine.evaluate()
            break
    return PolishResult(worst < ftol, tuple(steps), worst, time.process_time() - c0)


@dataclass
class PolishSteps:
    """The "polish" strategy of ``minimize.creep``: one ``polish`` per attempt."""

    ftol: float

    def attempt(self, engine, attempt: int, done: int) -> int:
        result = polish(engine, self.ftol)
        kept = sum(1 for s in result.steps if s.alpha > 0)
        first = result.steps[0].force_before if result.steps else result.max_force
        log.info("polish %d at iteration %d: %d of %d steps kept, max force %.3g -> %.3g, %.2f CPU s", attempt, done,
                 kept, len(result.steps), first, result.max_force, result.seconds)
        return kept


def polish_trigger(packing, after: int) -> CreepTrigger:
    """The polish's measured trigger: rigid bodies every ``after`` iterations from
    ``RIGID_CREEP_FORCE`` (docs/notes/nmers.md, "The creep of rigid bodies"); disks and spheres once,
    below ``CREEP_FORCE`` (docs/notes/speed-2.md sections 8 and 11); at multiples of ``after``."""
    if packing.shape.made_of_sites:
        return CreepTrigger(after, every=after, creep_force=RIGID_CREEP_FORCE, aligned=True)
    return CreepTrigger(after, aligned=True)
