"""A jammed-side protocol with a Newton corrector (docs/notes/speed-3.md): a prototype, measured
against the default ``fast`` protocol on the same seeds (docs/notes/speed-3.md; not kept as a
protocol: it did not pay).

Overshoot (``overshoot``): with ``--top P`` > 0, FIRE with the box as a degree of freedom
minimises the enthalpy at P from the random start (phi0 = 0.80, chapter step 1;
``jam_at_pressure``); with ``--top 0``, the fast protocol's compression phase up to its first
state with V > 1e-10, minimised to the force floor (to max force R x P with ``--loose-overshoot R``).
Then, at a fixed box, the ladder steps down in pressure by ``--ratio`` per step: each target phi
comes from phi = phi_c + p / s, fitted by weighted least squares (weights 1 / p^2: relative
errors) to the last three states (the first from the virial relation
phi - phi_c = alpha V phi^2 / (P v), as the fast protocol's Newton jump), the box and positions are
scaled affinely to it, and the state is corrected by Newton at the fixed box on the previous
state's network as bilateral springs: H dx = F on the backbone (floaters out, one particle
pinned), H the contact Hessian with its stress term (``mechanics.hessian.sphere_contact_hessian``),
one sparse LU (SuperLU, ``scipy.sparse.linalg.splu``) per step. After Newton the contacts are found
again (a contact in tension dropped, a new overlap added; a floater pushed by the moved backbone
moved along F / k) and Newton runs again (``--active-rounds`` solves at most); a network that
still changes, a floater that still touches, or a Newton step that does not converge (a network
that lost its rigidity) falls back at that box on FIRE (``minimize``, the default settings), with
``--gauss-newton`` first on the Gauss-Newton polish (``jamflow.minimize.polish``). The last step
aims at V = 1.5 V_tol by the secant on sqrt(V) (linear in phi for the spring) until
V_tol < V < 2 V_tol; the packing is checked by ``check_packing`` as ``jamflow jam``'s result is.

Counted per packing: FIRE iterations (overshoot, fallbacks), Newton steps, LU factorisations
(Newton's and the polish's), fallbacks, states, and the CPU seconds of the process
(``time.process_time``, split into overshoot / polish / FIRE fallback / the rest; the machine is
shared, so wall time is not recorded). The ``fast`` rows are ``jamflow.jam`` with its defaults on
the same seeds, run alternately with the ladder rows (fast, ladder, fast, ...).

    nice -n 19 python benchmarks/jammed_side.py --n 256 --seeds 1 5 --top 0 --out docs/notes/jammed-side-n256.csv
    nice -n 19 python benchmarks/jammed_side.py --n 1024 --seeds 1 3 --top 0 --out docs/notes/jammed-side-n1024.csv
    python benchmarks/jammed_side.py --report docs/notes/jammed-side-n1024.csv
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import sys
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.sparse.linalg as spla

import jamflow
from jamflow.engines.choose import open_engine
from jamflow.mechanics.checks import check_packing
from jamflow.mechanics.contacts import find_floaters
from jamflow.mechanics.hessian import sphere_contact_hessian
from jamflow.minimize.polish import polish
from jamflow.minimize.rules import minimize
from jamflow.minimize.settings import MinimizerSettings
from jamflow.model.pairs import candidate_pairs
from jamflow.protocols.compression import initial_packing
from jamflow.protocols.pressure import PressureSettings, jam_at_pressure

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import scratch

V_TOL = 1e-16
SKIN = 0.1  # candidate pairs within the largest diameter + this (diameters), found again every state
MAX_NEWTON = 12
RELIEF_SWEEPS = 20
LOOSE_OVERSHOOT = 0.0  # --loose-overshoot R: the first jammed state minimised to max force R x P only
GAUSS_NEWTON_FIRST = False  # --gauss-newton: a fallback tries minimize.polish before FIRE
MAX_STEP = 0.05  # a Newton step moving a particle further (diameters): the network is not rigid
COLUMNS = ["protocol", "n", "seed", "phi_j", "v", "max_force", "checks", "fire_iterations", "overshoot_iterations",
           "newton_steps", "factorisations", "fallbacks", "polish_steps", "polish_factorisations", "states", "top", "ratio", "loose_overshoot", "gauss_newton", "cpu_seconds", "cpu_overshoot", "cpu_polish",
           "cpu_fire_fallback", "cpu_newton_and_rest", "load", "error"]


@dataclass
class Counts:
    fire: int = 0
    overshoot: int = 0
    newton: int = 0
    lu: int = 0
    fallbacks: int = 0
    states: int = 0
    log: list = field(default_factory=list)
    polish: int = 0
    polish_lu: int = 0
    cpu: dict = field(default_factory=lambda: dict.fromkeys(("overshoot", "newton", "polish", "fire"), 0.0))


@dataclass
class Eval:
    """Unilateral evaluation of a state: contacts (overlap > 0), floaters, forces, V, P."""

    i: np.ndarray
    j: np.ndarray
    floater: np.ndarray
    forces: np.ndarray
    v: float  # energy per particle
    p: float


def pair_geometry(packing, x, i, j):
    dr = packing.box.minimum_image(x[i] - x[j])
    r = np.linalg.norm(dr, axis=1)
    sigma = 0.5 * (packing.diameters[i] + packing.diameters[j])
    return dr, r, sigma


def spring_forces(packing, x, i, j, dr, r, sigma):
    """Net forces of the pairs (i, j) as springs (chapter eq. 2.1, alpha = 2, bilateral), the
    energy and the virial pressure."""
    eps = packing.potential.epsilon
    f = eps * (sigma - r) / sigma**2  # > 0 repulsive
    fv = (f / r)[:, None] * dr
    forces = np.zeros_like(x)
    np.add.at(forces, i, fv)
    np.add.at(forces, j, -fv)
    energy = float(np.sum(0.5 * eps * (1 - r / sigma) ** 2))
    p = float(np.sum(f * r) / (packing.dim * packing.box.volume))
    return forces, energy, p


def evaluate(packing, x, cand) -> Eval:
    ci, cj = cand
    dr, r, sigma = pair_geometry(packing, x, ci, cj)
    on = r < sigma
    i, j = ci[on], cj[on]
    forces, energy, p = spring_forces(packing, x, i, j, dr[on], r[on], sigma[on])
    floater = find_floaters(packing.n, i, j, dr[on] / r[on, None], packing.dim + 1)
    return Eval(i, j, floater, forces, energy / packing.n, p)


def newton(packing, x, i, j, floater, ftol, counts):
    """Newton on the fixed network (i, j) as bilateral springs, floaters out, the first
    non-floater pinned; (x, converged)."""
    d = packing.dim
    live = np.flatnonzero(~floater)
    rows = (live[1:, None] * d + np.arange(d)).ravel()
    for _ in range(MAX_NEWTON):
        dr, r, sigma = pair_geometry(packing, x, i, j)
        forces, _, _ = spring_forces(packing, x, i, j, dr, r, sigma)
        if np.abs(forces[live]).max() < ftol:
            return x, True
        h = sphere_contact_hessian(packing, i, j, dr, r, sigma, r / sigma).tocsc()
        try:
            lu = spla.splu(h[rows][:, rows].tocsc())
        except RuntimeError:
            return x, False
        counts.lu += 1
        rhs = forces.ravel()[rows]
        dx = np.zeros(packing.n * d)
        dx[rows] = lu.solve(rhs)
        if not np.isfinite(dx).all() or np.abs(dx).max() > MAX_STEP:
            counts.log.append(f"step {np.abs(dx).max():.2e}")
            return x, False
        x = x + dx.reshape(x.shape)
        counts.newton += 1
    return x, False


def correct(packing, sim, x, network, ftol, rounds, counts):
    """Force balance at the packing's box: Newton on ``network`` (i, j, floater: the previous
    state's, as bilateral springs, so that the affine dilation does not cut it), then on the
    contacts found again (tension dropped, new overlaps added) while they change, ``rounds``
    solves at most; FIRE on a change that persists, a floater that touches or a network that is not
    rigid. (x, Eval, network)."""
    cand = candidate_pairs(packing.with_positions(x), float(packing.diameters.max()) + SKIN)
    counts.states += 1
    why = "network kept changing"
    for _ in range(rounds):
        i, j, floater = network
        x, ok = newton(packing, x, i, j, floater, ftol, counts)
        if not ok:
            why = "Newton did not converge"
            break
        e = evaluate(packing, x, cand)
        x, e = relieve(packing, x, e, cand, ftol)
        # a floater left touching at round-off (FIRE leaves them so) is balanced below ftol
        touching = e.floater.any() and np.abs(e.forces[e.floater]).max() >= ftol
        now = backbone(e)
        if set(zip(now[0].tolist(), now[1].tolist())) == set(zip(i.tolist(), j.tolist())) and not touching:
            return x, e, now
        if touching:
            why = "a floater touches"
            break  # FIRE frees it
        network = now
    counts.fallbacks += 1
    sim.set_box(packing.box)
    sim.set_positions(x)
    if GAUSS_NEWTON_FIRST:
        c0 = time.process_time()
        steps = polish(sim, ftol).steps
        counts.polish += len(steps)
        counts.polish_lu += sum(step.inner for step in steps)  # one sparse LU of J^T J per active-set iteration
        counts.cpu["polish"] += time.process_time() - c0
    c0 = time.process_time()
    result = minimize(sim, MinimizerSettings())
    counts.fire += result.iterations
    counts.cpu["fire"] += time.process_time() - c0
    x = sim.positions()
    e = evaluate(packing, x, candidate_pairs(packing.with_positions(x), float(packing.diameters.max()) + SKIN))
    counts.log.append(f"fallback at phi={packing.phi:.8f} V={e.v:.2e}: {result.iterations} it ({result.reason}); {why}")
    return x, e, backbone(e)


def relieve(packing, x, e, cand, ftol, sweeps=RELIEF_SWEEPS):
    """Floaters pushed by a backbone that Newton moved: each moves along its net force by F / k (k the
    sum of its contacts' stiffnesses eps / sigma^2), which opens a single contact exactly."""
    for _ in range(sweeps):
        push = e.floater & (np.abs(e.forces).max(axis=1) >= ftol)
        if not push.any():
            break
        mine = push[e.i] | push[e.j]
        sigma = 0.5 * (packing.diameters[e.i[mine]] + packing.diameters[e.j[mine]])
        k = np.zeros(packing.n)
        np.add.at(k, e.i[mine], packing.potential.epsilon / sigma**2)
        np.add.at(k, e.j[mine], packing.potential.epsilon / sigma**2)
        dx = np.zeros_like(x)
        dx[push] = e.forces[push] / k[push, None] * (1.0 + 1e-9)
        x = x + dx
        e = evaluate(packing, x, cand)
    return x, e


def backbone(e):
    keep = ~e.floater[e.i] & ~e.floater[e.j]
    return e.i[keep], e.j[keep], e.floater


def fit_phi_c(states):
    """phi_c of phi = phi_c + p / s, weights 1 / p^2, over the last three jammed states (phi, p)."""
    phi, p = np.array([s[0] for s in states[-3:]]), np.array([s[1] for s in states[-3:]])
    a = np.vstack([np.ones_like(p), p]).T / p[:, None]
    coef = np.linalg.lstsq(a, phi / p, rcond=None)[0]
    return float(coef[0])


def window_target(states, phi_c, v_target):
    """phi where V = v_target: the secant on sqrt(V) (linear in phi for the spring) through the last
    two jammed states, or from phi_c with one."""
    (f1, _, v1), (f0, _, v0) = states[-2:] if len(states) >= 2 else (states[-1], (phi_c, 0.0, 0.0))
    s1, s0 = math.sqrt(v1), math.sqrt(v0)
    return f0 + (math.sqrt(v_target) - s0) * (f1 - f0) / (s1 - s0)


def overshoot(start, top):
    """(jammed packing, FIRE iterations): ``top`` > 0, the enthalpy minimum at p = top
    (``jam_at_pressure``); ``top`` = 0, the fast protocol's compression phase (dphi doubling from
    1e-4 up to 1e-3, each minimisation stopped at V < 1e-10 or max force < 1e-10) up to its first
    state with V > 1e-10 (jammed), then minimised to the force floor."""
    if top > 0:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            over = jam_at_pressure(start, PressureSettings((top,)), engine="numba")
        return over.packing, over.iterations
    coarse = MinimizerSettings(v_min=1e-10, force_tol=1e-10)
    base_box, base_phi, phi, dphi, total = start.box, start.phi, start.phi, 1e-4, 0
    with open_engine(start, "fire", "numba") as sim:
        while True:
            sim.set_box(base_box.scaled((base_phi / phi) ** (1.0 / start.dim)))
            result = minimize(sim, coarse)
            total += result.iterations
            if result.reason != "energy-below-vmin" and result.energy_per_particle > 1e-10:
                break
            phi, dphi = phi + dphi, min(2 * dphi, 1e-3)
        loose = LOOSE_OVERSHOOT * sim.state().pressure  # the fast protocol's approach tolerance; Newton finishes
        total += minimize(sim, MinimizerSettings(force_tol=loose) if loose else MinimizerSettings()).iterations
        return sim.packing(), total


def ladder(n, seed, top, ratio, rounds, dim=2, sizes="bi:1.4:0.5"):
    """(packing, V, max force, counts) of the jammed-side protocol from seed's random start."""
    counts = Counts()
    start = initial_packing(n, dim, sizes, "spring", seed, 0.80)
    c0 = time.process_time()
    packing, counts.overshoot = overshoot(start, top)
    counts.fire = counts.overshoot
    counts.cpu["overshoot"] = time.process_time() - c0
    ftol = MinimizerSettings().force_tol_for(packing)
    x = packing.box.wrap(packing.positions)
    solids = float(packing.volumes.sum())
    mean_volume = solids / n
    with open_engine(packing, "fire", "numba") as sim:
        cand = candidate_pairs(packing.with_positions(x), float(packing.diameters.max()) + SKIN)
        network = backbone(evaluate(packing, x, cand))
        x, e, network = correct(packing, sim, x, network, ftol, rounds, counts)
        states = [(packing.phi, e.p, e.v)]
        phi_c = packing.phi - 2.0 * e.v * packing.phi**2 / (e.p * mean_volume)  # virial: alpha V phi^2 / (P v)
        base_box, base_phi = packing.box, packing.phi

        def at(phi, x_from, phi_from):
            factor = (phi_from / phi) ** (1.0 / dim)
            box = base_box.scaled((base_phi / phi) ** (1.0 / dim))
            return packing.with_positions(x_from * factor, box=box)

        final, below, tries = False, None, 0
        while tries < 40:
            tries += 1
            phi, _, v = states[-1]
            if len(states) >= 2:
                phi_c = fit_phi_c(states)
            v_target = 1.5 * V_TOL
            final = final or v * ratio**2 <= 1.5 * v_target  # the next ladder step would pass the window
            if final:
                target = window_target(states, phi_c, v_target)
                if below is not None and target <= below:
                    target = 0.5 * (below + phi)
            else:
                target = phi_c + (phi - phi_c) * ratio
            trial = at(target, x, phi)
            xt, et, nt = correct(trial, sim, trial.positions, network, ftol, rounds, counts)
            if et.v <= V_TOL:  # below jamming (or in the window's lower part): back up from the last jammed state
                below = target
                final = True
                counts.log.append(f"below at phi={target:.10f} V={et.v:.2e}")
                continue
            x, packing, network = xt, trial, nt
            states.append((target, et.p, et.v))
            if V_TOL < et.v < 2 * V_TOL:
                break
        else:
            raise RuntimeError("no state in the window after 40 steps")
        sim.set_box(packing.box)
        sim.set_positions(x)
        st = sim.evaluate()
        out = sim.packing()
    return out, st.energy / n, float(np.abs(st.forces).max()), counts


def run_ladder(n, seed, top, ratio, rounds):
    c0 = time.process_time()
    try:
        packing, v, fmax, counts = ladder(n, seed, top, ratio, rounds)
    except Exception as err:  # noqa: BLE001 - recorded
        return {"protocol": "ladder", "n": n, "seed": seed, "cpu_seconds": f"{time.process_time() - c0:.2f}",
                "error": f"{type(err).__name__}: {err}"}
    cpu = time.process_time() - c0
    checks = check_packing(packing, v, None, V_TOL)
    for line in counts.log:
        print("   ", line)
    return {"protocol": "ladder", "n": n, "seed": seed, "phi_j": repr(packing.phi), "v": f"{v:.4e}",
            "max_force": f"{fmax:.2e}", "checks": checks.passed, "fire_iterations": counts.fire,
            "overshoot_iterations": counts.overshoot, "newton_steps": counts.newton, "factorisations": counts.lu,
            "fallbacks": counts.fallbacks, "polish_steps": counts.polish,
            "polish_factorisations": counts.polish_lu, "states": counts.states, "top": top, "ratio": f"{ratio:.4g}", "loose_overshoot": LOOSE_OVERSHOOT, "gauss_newton": GAUSS_NEWTON_FIRST, "cpu_seconds": f"{cpu:.2f}",
            "cpu_overshoot": f"{counts.cpu['overshoot']:.2f}", "cpu_polish": f"{counts.cpu['polish']:.2f}",
            "cpu_fire_fallback": f"{counts.cpu['fire']:.2f}",
            "cpu_newton_and_rest": f"{cpu - sum(counts.cpu.values()):.2f}", "error": ""}


def run_fast(n, seed):
    c0 = time.process_time()
    res = jamflow.jam(n=n, seed=seed)
    cpu = time.process_time() - c0
    checks = check_packing(res.packing, res.energy_per_particle, None, V_TOL)
    return {"protocol": "fast", "n": n, "seed": seed, "phi_j": repr(res.phi_j), "v": f"{res.energy_per_particle:.4e}",
            "max_force": f"{res.max_force:.2e}", "checks": checks.passed, "fire_iterations": res.iterations,
            "states": res.minimizations, "cpu_seconds": f"{cpu:.2f}", "error": ""}


def variant(row) -> str:
    if row["protocol"] == "fast":
        return "fast"
    return (f"ladder top={float(row['top']):g}" + (f" ratio={float(row['ratio']):g}" if row.get("ratio") != "0.3162" else "") + (f" loose={float(row['loose_overshoot']):g}" if float(row.get("loose_overshoot") or 0)
            else "") + (" gauss-newton" if row["gauss_newton"] == "True" else " fire"))


def report(path) -> None:
    """Per variant: packings, checks passed, summed FIRE iterations, Newton steps, LU factorisations
    (Newton + polish), fallbacks and CPU seconds, and phi_J - phi_J(fast) on the same seeds."""
    with open(path, newline="") as fh:
        rows = [r for r in csv.DictReader(fh) if not r["error"]]
    fast = {r["seed"]: float(r["phi_j"]) for r in rows if r["protocol"] == "fast"}
    groups = {}
    for r in rows:
        groups.setdefault(variant(r), []).append(r)
    print("variant | packings | checks | FIRE iterations | Newton steps | LU (Newton + polish) | fallbacks | CPU s "
          "(overshoot / polish / FIRE fallback / rest) | phi_J - fast: mean +- s.e. (seeds)")
    for name, rs in groups.items():
        def total(key, rs=rs):
            return sum(float(r[key] or 0) for r in rs)

        diffs = [float(r["phi_j"]) - fast[r["seed"]] for r in rs if r["seed"] in fast]
        se = np.std(diffs, ddof=1) / math.sqrt(len(diffs)) if len(diffs) > 1 else math.nan
        cpu = "" if name == "fast" else (f" ({total('cpu_overshoot'):.2f} / {total('cpu_polish'):.2f} / "
                                         f"{total('cpu_fire_fallback'):.2f} / {total('cpu_newton_and_rest'):.2f})")
        print(f"{name} | {len(rs)} | {sum(r['checks'] == 'True' for r in rs)} | {total('fire_iterations'):.0f} | "
              f"{total('newton_steps'):.0f} | {total('factorisations') + total('polish_factorisations'):.0f} | "
              f"{total('fallbacks'):.0f} | {total('cpu_seconds'):.2f}{cpu} | {np.mean(diffs):+.6f} +- {se:.6f} "
              f"({' '.join(f'{d:+.6f}' for d in diffs)})")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=256)
    ap.add_argument("--seeds", type=int, nargs=2, default=[1, 5], help="first and last seed")
    ap.add_argument("--top", type=float, default=0.0, help="overshoot pressure (eps / diameter^d); 0: the fast protocol's compression to its first jammed state")
    ap.add_argument("--ratio", type=float, default=10 ** -0.5, help="pressure ratio per ladder step")
    ap.add_argument("--active-rounds", type=int, default=4, help="Newton solves with an updated network per state")
    ap.add_argument("--gauss-newton", action="store_true", help="a fallback tries the Gauss-Newton polish first")
    ap.add_argument("--loose-overshoot", type=float, default=0.0,
                    help="--top 0: minimise the first jammed state to max force R x P only (0: the force floor)")
    ap.add_argument("--protocols", nargs="+", default=["fast", "ladder"])
    ap.add_argument("--append", action="store_true", help="(no effect: rows are always added to --out)")
    ap.add_argument("--out", default=str(scratch("jammed-side.csv")))
    ap.add_argument("--report", default=None, help="CSV: print the summary per variant")
    args = ap.parse_args(argv)
    if args.report:
        report(args.report)
        return 0
    global GAUSS_NEWTON_FIRST, LOOSE_OVERSHOOT
    GAUSS_NEWTON_FIRST, LOOSE_OVERSHOOT = args.gauss_newton, args.loose_overshoot
    jamflow.jam(n=16, seed=0)  # compile / load the kernels outside the measurement
    path = Path(args.out)
    new = not path.exists()
    with open(path, "a", newline="") as fh:  # rows are added: earlier runs' rows are kept
        writer = csv.DictWriter(fh, COLUMNS, restval="")
        if new:
            writer.writeheader()
        for seed in range(args.seeds[0], args.seeds[1] + 1):
            for name in args.protocols:
                row = run_fast(args.n, seed) if name == "fast" else run_ladder(args.n, seed, args.top, args.ratio,
                                                                               args.active_rounds)
                row["load"] = f"{os.getloadavg()[0]:.1f}"
                writer.writerow(row)
                fh.flush()
                print(", ".join(f"{k}={row.get(k, '')}" for k in COLUMNS if row.get(k, "") != ""), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
