"""Shifted semismooth Newton-Krylov minimisation of jammed and nearly jammed disks and spheres.

With the linear spring (chapter eq. 2.1, alpha = 2) the energy is V = 1/2 sum max(0, delta)^2 over
pairs, delta = 1 - r/sigma. About a configuration x its second-order model is piecewise quadratic:

    m(p) = 1/2 sum_k max(0, delta_k + J_k p)^2 + 1/2 p^T T p,

J = d delta / dx over the pairs within sigma + ``SKIN`` and T the tension term of the contacts
(delta > 0), -delta / (r sigma) (I - n n^T) on each pair's relative coordinate, of order -P. On
one active set A (the pairs in contact) m is the quadratic with the exact Hessian
H_A = J_A^T J_A + T, which is indefinite on a saddle (where FIRE creeps at rate ~ sqrt(P) for
1e5 iterations). A step (Nocedal & Wright, Numerical Optimization, ch. 4, 7 and 16):

1. Semismooth Newton on m + lambda/2 p^T M p: from the inner point dx, preconditioned conjugate
   gradients solve (H_A + lambda M) q = -grad on the pairs in contact at dx, and dx moves to the
   exact minimum of the model along q (``line_minimum``: the gaps q closes and the contacts it
   opens bend the model); it ends when a full step keeps the active set.
2. The shift lambda >= 0 keeps the model convex: negative curvature met by the conjugate
   gradients raises it past that curvature and the solve repeats, so a saddle is left by steps
   the active set can follow (a trust region's "hard case" handled by its shift; a step to the
   region's boundary along the negative curvature closes a gap at once, and the active set cycles).
3. The exact energy decides (the ratio test of a trust region, lambda in the radius's role);
   where the predicted decrease is below the energy's round-off, a step is kept if it lowers
   the max force without raising V. lambda falls by 4 after a good step, to 0: Newton's
   quadratic convergence once H_A is positive definite.

M = J_A^T J_A + mu I (mu the mean overlap, the scale of T) is also the preconditioner: its sparse
Cholesky factor is KEPT across steps and computed again only when the contacts differ from the
factorised ones by more than ``REFACTOR_FRACTION`` or a step's solves needed more than
``CG_SLOW`` iterations. CHOLMOD (the ``cholespy`` wheel) factorises it where installed, SciPy's
SuperLU otherwise. Measured against FIRE in docs/notes/newton-krylov.md.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np

from jamflow.minimize.cholesky import factorise
from jamflow.minimize.creep import CreepTrigger
from jamflow.minimize.polish import pair_geometry

log = logging.getLogger(__name__)

SKIN = 0.05  # candidate pairs within sigma + SKIN (diameters): gaps a step may close
REFACTOR_FRACTION = 0.02  # refactorise when this fraction of the factorised contacts changed
CG_SLOW = 60  # ... or when the last step's solves needed more conjugate-gradient iterations than this
CG_MAX = 400  # iterations of one conjugate-gradient solve
ACTIVE_SET_ROUNDS = 10  # semismooth rounds of one step
SHIFT_RAISES = 8  # raises of lambda within one solve
MAX_STEPS = 50  # Newton steps of one relaxation
STALLED_STEPS = 8  # refused steps in a row: the relaxation ends
ETA = 1e-8  # relative residual of the conjugate gradients: near a saddle the soft modes that decide are resolved
# only by tight solves (0.1 failed on states the Gauss-Newton polish converged: docs/notes/newton-krylov.md)
AFTER = 20_000  # FIRE iterations before the first Newton relaxation of a minimisation, and between attempts
START_RATIO = 1e-3  # Newton starts once the max force is below this fraction of the mean contact force


def newton_reason(packing) -> str:
    """'' if ``relax`` applies to this packing, else why not (one phrase)."""
    pot = packing.potential
    if not packing.shape.round:
        return f"the Newton minimiser needs disks or spheres, not {packing.shape.kind} particles"
    if getattr(pot, "name", "") != "spring" or float(pot.alpha) != 2.0:
        return "the Newton minimiser needs the linear spring (alpha = 2)"
    if packing.fixed is not None or not all(packing.box.periodic) or packing.gravity:
        return "the Newton minimiser needs a periodic box without walls, fixed particles or gravity"
    return ""


@dataclass
class Model:
    """The pairs within sigma + ``SKIN`` of a configuration: overlaps delta, Jacobian J (P x N d),
    and the tension matrix T of the contacts; ``gradient`` = J_A^T delta_A = dV/dx."""

    delta: np.ndarray
    jac: object  # scipy.sparse.csr_matrix
    tension: object  # scipy.sparse.csr_matrix (N d x N d)
    gradient: np.ndarray
    energy: float  # 1/2 sum max(0, delta)^2 (eps)

    @classmethod
    def at(cls, packing, x: np.ndarray) -> "Model":
        from jamflow.engines.compiled.spheres import build

        pairs = build(packing, x, SKIN)
        n, d = x.shape
        dr, r, delta, jac = pair_geometry(x, pairs)
        on = delta > 0
        blocks = _tension_blocks(packing.potential, dr[on], r[on], pairs.sigma[on])
        tension = _pair_blocks(pairs.i[on], pairs.j[on], blocks, n, d)
        grad = jac[on].T @ delta[on]
        return cls(delta, jac, tension, grad, 0.5 * float(delta[on] @ delta[on]))


def _tension_blocks(potential, dr, r, sigma) -> np.ndarray:
    """(K, d, d) tension blocks V'(r)/r (I - n n^T) of each contact on its relative coordinate
    u = x_i - x_j (the part of ``mechanics.hessian.pair_stiffness`` beyond J^T J; -delta / (r sigma)
    for the linear spring; eps/diameter^2)."""
    unit = dr / r[:, None]
    perp = np.eye(dr.shape[1])[None] - unit[:, :, None] * unit[:, None, :]
    return (potential.dv_dr(r, sigma) / r)[:, None, None] * perp


def _pair_blocks(i, j, blocks, n: int, d: int):
    """The N d x N d matrix sum_k B_k^T K_k B_k, B_k the difference x_i - x_j of pair k."""
    import scipy.sparse as sp

    a = np.arange(d)
    ri = (i[:, None] * d + a)[:, :, None]
    rj = (j[:, None] * d + a)[:, :, None]
    ci, cj = np.swapaxes(ri, 1, 2), np.swapaxes(rj, 1, 2)
    shape = blocks.shape
    rows = np.concatenate([np.broadcast_to(x, shape).ravel() for x in (ri, rj, ri, rj)])
    cols = np.concatenate([np.broadcast_to(x, shape).ravel() for x in (ci, cj, cj, ci)])
    vals = np.concatenate([blocks.ravel(), blocks.ravel(), -blocks.ravel(), -blocks.ravel()])
    return sp.csr_matrix((vals, (rows, cols)), shape=(n * d, n * d))


class Preconditioner:
    """A kept sparse Cholesky factor of J_A^T J_A + mu I; ``solve(b)``, ``norm_sq(p)`` = p^T M p."""

    def __init__(self, jac_active, mu: float, active: np.ndarray):
        import scipy.sparse as sp

        size = jac_active.shape[1]
        self.matrix = (jac_active.T @ jac_active + mu * sp.identity(size, format="csr")).tocsr()
        self.active = active.copy()
        self._solve = factorise(self.matrix)

    def solve(self, b: np.ndarray) -> np.ndarray:
        return self._solve(b)

    def norm_sq(self, p: np.ndarray) -> float:
        return float(p @ (self.matrix @ p))

    def stale(self, active: np.ndarray) -> bool:
        """The contacts differ from the factorised ones in more than ``REFACTOR_FRACTION`` of them."""
        if len(active) != len(self.active):
            return True
        return np.count_nonzero(active != self.active) > REFACTOR_FRACTION * max(1, np.count_nonzero(active))


def pcg(hess, grad: np.ndarray, precond: Preconditioner, eta: float):
    """Preconditioned conjugate gradients for hess p = -grad to relative residual ``eta`` (in the
    M^-1 norm). Returns (p, iterations, None), or (None, iterations, d.H d / d.M d) at the first
    direction d of non-positive curvature."""
    p = np.zeros_like(grad)
    r = grad.copy()
    z = precond.solve(r)
    d = -z
    rz = float(r @ z)
    stop = eta * np.sqrt(max(rz, 0.0))
    for k in range(1, CG_MAX + 1):
        hd = hess @ d
        curvature = float(d @ hd)
        if curvature <= 0:
            return None, k, curvature / max(precond.norm_sq(d), 1e-300)
        alpha = rz / curvature
        p = p + alpha * d
        r = r + alpha * hd
        z = precond.solve(r)
        rz_new = float(r @ z)
        if np.sqrt(max(rz_new, 0.0)) <= stop:
            return p, k, None
        d = -z + (rz_new / rz) * d
        rz = rz_new
    return p, CG_MAX, None


def model_value(model: Model, p: np.ndarray) -> float:
    """m(p) = 1/2 sum max(0, delta + J p)^2 + 1/2 p^T T p (eps)."""
    lin = np.maximum(model.delta + model.jac @ p, 0.0)
    return 0.5 * float(lin @ lin) + 0.5 * float(p @ (model.tension @ p))


@dataclass(frozen=True)
class NewtonResult:
    converged: bool  # max force below the tolerance
    steps: int  # Newton steps kept
    rejected: int  # steps the ratio test refused
    cg_iterations: int
    factorisations: int
    max_force: float
    seconds: float  # process (CPU) time


def relax(engine, ftol: float, max_steps: int = MAX_STEPS) -> NewtonResult:
    """Newton-Krylov steps on ``engine``'s configuration (disks/spheres, linear spring, periodic
    box) until its max force component is below ``ftol`` (eps/diameter), ``max_steps`` steps or
    ``STALLED_STEPS`` refusals in a row. The engine keeps the last kept configuration, evaluated;
    a relaxation that ends unconverged with a larger max force than it started with gives the
    start back (it met a rearrangement, which FIRE follows more cheaply)."""
    reason = newton_reason(engine.template)
    if reason:
        raise ValueError(f"{reason}; minimise with FIRE alone")
    c0 = time.process_time()
    x0 = x = engine.positions()
    engine.set_positions(x)
    state = engine.evaluate()
    worst = start_worst = state.max_force
    noise_unit = 8 * np.finfo(float).eps
    precond, shift = None, 0.0
    kept = rejected = refused_in_row = cg_total = factorisations = last_cg = 0
    while worst >= ftol and kept + rejected < max_steps and refused_in_row < STALLED_STEPS:
        model = Model.at(engine.template.with_positions(x, box=engine.box), x)
        on = model.delta > 0
        if not on.any():
            break  # no contacts: nothing for Newton to balance (FIRE's rules decide "unjammed")
        if precond is None or last_cg > CG_SLOW or precond.stale(on):
            precond = Preconditioner(model.jac[on], float(model.delta[on].mean()), on)
            factorisations += 1
        step, active, last_cg, shift = _step(model, precond, shift, ETA)
        cg_total += last_cg
        predicted = model.energy - model_value(model, step)
        trial_x = x + step.reshape(x.shape)
        engine.set_positions(trial_x)
        trial = engine.evaluate()
        actual = state.energy - trial.energy
        noise = noise_unit * float(np.sum(np.maximum(model.delta, 0.0)))
        if predicted > noise:
            rho = actual / predicted
        else:  # the predicted decrease is below the energy's round-off: the max force decides
            rho = 1.0 if trial.max_force < worst and actual >= -noise else 0.0
        if rho > 0.05:
            x, state, worst = trial_x, trial, trial.max_force
            kept += 1
            refused_in_row = 0
        else:
            rejected += 1
            refused_in_row += 1
        shift = _next_shift(shift, rho)
        log.debug("newton step: active %d, cg %d, rho %.3g, shift %.3g, max force %.3g", active, last_cg, rho, shift,
                  worst)
    if worst >= ftol and worst >= start_worst:
        x, kept = x0, 0
    engine.set_positions(x)
    state = engine.evaluate()
    return NewtonResult(state.max_force < ftol, kept, rejected, cg_total, factorisations, state.max_force,
                        time.process_time() - c0)


def _next_shift(shift: float, rho: float) -> float:
    """lambda after a step of ratio ``rho``: / 4 after a good one (0 below 1e-6), x 4 (at least
    1) after a poor one."""
    if rho > 0.75:
        return shift / 4 if shift > 1e-6 else 0.0
    if rho < 0.25:
        return max(4 * shift, 1.0)
    return shift


def _step(model: Model, precond: Preconditioner, shift: float, eta: float):
    """One step: the minimum of the shifted piecewise model by semismooth Newton (the module's
    docstring). Returns (step, contacts at its end, CG iterations, the shift it ended with)."""
    dx = np.zeros(model.jac.shape[1])
    lin = model.delta.copy()
    iterations = 0
    for _ in range(ACTIVE_SET_ROUNDS):
        on = lin > 0
        ja = model.jac[on]
        for _ in range(SHIFT_RAISES):
            quad = _Hessian(ja, model.tension, precond.matrix, shift)
            curv_dx = quad.curvature(dx)
            q, k, negative = pcg(quad, ja.T @ lin[on] + curv_dx, precond, eta)
            iterations += k
            if negative is None:
                break
            shift = max(2 * shift, shift - 1.5 * negative, 1e-3)  # past the curvature met, in units of M
        if q is None:
            break
        b = model.jac @ q
        t = line_minimum(lin, b, float(q @ quad.curvature(q)), float(q @ curv_dx))
        if t <= 0:
            break
        dx += t * q
        lin = lin + t * b
        if t >= 1.0 and np.array_equal(lin > 0, on):
            break
    return dx, int(np.count_nonzero(lin > 0)), iterations, shift


def line_minimum(a: np.ndarray, b: np.ndarray, q: float, c: float = 0.0) -> float:
    """The t in [0, 1] that minimises f(t) = 1/2 sum max(0, a + t b)^2 + c t + q t^2 / 2 (a
    piecewise quadratic, not convex where q < 0): f' = S1 + t (S2 + q) on each interval between the
    breakpoints t_k = -a_k / b_k, with S1 = c + sum b a and S2 = sum b^2 over the pairs in contact
    there; the candidates are the breakpoints, the ends and each interval's stationary point."""
    inside = (b != 0) & (-a * b > 0) & (-a < np.abs(b))  # breakpoints in (0, 1): a and b of opposite signs
    inside &= (-a / np.where(b == 0, 1.0, b)) < 1.0
    on0 = a > 0
    s1, s2 = c + float(b[on0] @ a[on0]), float(b[on0] @ b[on0])
    tk = -a[inside] / b[inside]
    sign = np.where(b[inside] > 0, 1.0, -1.0)  # b > 0: the pair closes at t_k (joins); b < 0: opens (leaves)
    order = np.argsort(tk, kind="stable")
    tk, sign = tk[order], sign[order]
    ab, bb = (a[inside] * b[inside])[order], (b[inside] ** 2)[order]
    ends = np.concatenate([[0.0], tk, [1.0]])
    c1 = s1 + np.concatenate([[0.0], np.cumsum(sign * ab)])  # S1 on each interval
    c2 = s2 + np.concatenate([[0.0], np.cumsum(sign * bb)]) + q  # S2 + q on each interval
    lo, hi = ends[:-1], ends[1:]
    rise = c1 * (hi - lo) + 0.5 * c2 * (hi**2 - lo**2)  # f(hi) - f(lo)
    f_ends = np.concatenate([[0.0], np.cumsum(rise)])
    with np.errstate(divide="ignore", invalid="ignore"):
        ts = np.where(c2 > 0, -c1 / c2, np.nan)
    interior = (ts > lo) & (ts < hi)
    f_stat = f_ends[:-1] + c1 * (ts - lo) + 0.5 * c2 * (ts**2 - lo**2)
    candidates = np.concatenate([ends, ts[interior]])
    values = np.concatenate([f_ends, f_stat[interior]])
    return float(candidates[int(np.argmin(values))])


class _Hessian:
    """(H_A + lambda M) v = J_A^T (J_A v) + T v + lambda M v, J_A^T J_A not formed;
    ``curvature(v)`` = (T + lambda M) v, the part outside the pairs' max(0, .)^2."""

    def __init__(self, ja, tension, metric, shift: float):
        self.ja, self.tension, self.metric, self.shift = ja, tension, metric, shift

    def curvature(self, v):
        out = self.tension @ v
        return out + self.shift * (self.metric @ v) if self.shift else out

    def __matmul__(self, v):
        return self.ja.T @ (self.ja @ v) + self.curvature(v)


@dataclass
class NewtonSteps:
    """The "newton" strategy of ``minimize.creep``: one ``relax`` per attempt."""

    ftol: float

    def attempt(self, engine, attempt: int, done: int) -> int:
        ratio = force_ratio(engine)
        if not ratio < START_RATIO:
            log.debug("newton %d at iteration %d: not started, max force / mean contact force %.3g", attempt, done, ratio)
            return 0
        result = relax(engine, self.ftol)
        log.info("newton %d at iteration %d: %d steps kept, %d refused, %d CG iterations, %d factorisations, "
                 "max force %.3g, %.2f CPU s", attempt, done, result.steps, result.rejected, result.cg_iterations,
                 result.factorisations, result.max_force, result.seconds)
        return result.steps


def force_ratio(engine) -> float:
    """Max force component over the mean contact force of the engine's configuration (inf
    without contacts): small where the contact network is found and only its balance is left."""
    x = engine.positions()
    model = Model.at(engine.template.with_positions(x, box=engine.box), x)
    on = model.delta > 0
    if not on.any():
        return np.inf
    return float(np.abs(model.gradient).max()) / float(np.mean(model.delta[on]))


def newton_trigger(after: int) -> CreepTrigger:
    """Newton from ``after`` FIRE iterations on, whatever the max force, again every ``after``
    iterations while the minimisation has not converged."""
    return CreepTrigger(after, every=after, creep_force=np.inf)
