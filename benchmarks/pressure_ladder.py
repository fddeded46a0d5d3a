"""The pressure ladder (docs/guide/precision.md): jammed packings followed from p = 1e-2 down to 1e-14, two
pressures per decade, every state balanced in double-double (``jamflow.refine``), with the excess
contact number and the Hessian-route shear modulus at each state; the collapse against p N^2
(Goodrich, Liu & Nagel, PRL 109, 095704 (2012)); phi_J fitted from the lowest decades.

Per (d, N, seed): a float64 onset (``jamflow.jam``), then the ladder in descending order, each state
from the previous one. Above ``--switch`` (default 1.5e-9) the step down is a float64 state near the
next pressure, then balanced in double-double at that pressure (``jamflow.refine``): decompressing
through the contact rearrangements of the high pressures with the double-double Newton walk cost
10-40 s per state at N = 64 (its float64 FIRE fallback runs once per balance). The first float64
state is the enthalpy minimum at the top pressure (``jam_at_pressure``, the compiled FIRE with the
box free); the next ones (``--float64 fixed-box``, the default) the previous state rescaled to the
phi extrapolated from the last two balanced states and relaxed by FIRE at that box, or
(``--float64 enthalpy``, the route of the 2D rows) enthalpy minima again. The enthalpy FIRE stops at
its iteration cap (5e5) mid-rearrangement in 3D (30-60 s a state at N = 512, max|F|/<f> ~1e-3 left);
FIRE at a fixed box converges in a fraction of that (3D N = 512 seed 1: the ladder in 124 s against
>14 CPU min). At and below ``--switch`` every state is
``jamflow.refine(previous, p)``. Recorded per state: p and phi (hi + lo from the double-double box),
N_c (double-double contacts between non-floaters), N' (non-floaters), N_c - (d (N' - 1) + 1),
Delta z = z - z_iso with z = 2 N_c / N' and z_iso = 2 d (N' - 1) / N' (Goodrich et al.'s 2d - 2d/N':
the minimally rigid periodic packing, N_c = d (N' - 1) + 1, has Delta z = 2 / N', so N' Delta z -> 2
below the crossover), max|F| / <f>, G and B by the Hessian route on the double-double network
(``RefineResult.moduli``) and, up to ``--g64-max-dof`` degrees of freedom, G of ``HessianModuli`` on
the float64 positions, and what float64 sees of the network: the double-double contacts between
non-floaters it misses, those it adds, and its pairs touching a floater (round-off overlaps). A failed state is a row with its
error; the ladder of that packing stops there.

    python benchmarks/pressure_ladder.py --dim 2 --n 64 256 --seeds 10 --float64 enthalpy --out docs/notes/pressure-ladder.csv
    python benchmarks/pressure_ladder.py --dim 3 --n 128 512 --seeds 20 --out docs/notes/pressure-ladder-3d.csv
    python benchmarks/pressure_ladder.py --report docs/notes/pressure-ladder.csv docs/notes/pressure-ladder-3d.csv --figure docs/notes/pressure-ladder.png
    python benchmarks/pressure_ladder.py --quick --out X.csv                        (N = 16, 3 pressures)
    python benchmarks/pressure_ladder.py --n 256 --seeds 13 13 --float64 enthalpy --self-stress --out X.csv  (why N_c is one more)
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import time
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

import jamflow
from jamflow.mechanics.elastic import HessianModuli
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.model.pairs import overlapping_pairs
from jamflow.protocols.pressure import PressureSettings, jam_at_pressure
from jamflow.protocols.refine import relax_at_box

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import scratch

warnings.filterwarnings("ignore", message=".*carries extended precision.*")

COLUMNS = ["dim", "n", "seed", "target", "route", "status", "p", "phi", "phi_lo", "n_contacts", "n_prime",
           "excess", "z", "z_iso", "delta_z", "force_balance", "G", "B", "G_float64", "float64_same_network",
           "float64_missing", "float64_extra", "float64_floater_touching",
           "contacts_hash", "float64_seconds", "refine_seconds", "error"]
STEP_FLOOR = 10.0  # a fixed-box state below target / STEP_FLOOR is taken as unjammed
STEP_BACKOFFS = 8  # fixed-box steps halfway back towards the last state when a guess lands unjammed
F64_TRIES = 4  # jam_at_pressure calls per float64 state (each to the minimiser's iteration cap)
PUBLISHED = {"dz": 0.5, "G": 0.5}  # linear spring: Delta z ~ p^1/2, G ~ p^1/2 (p N^2 >> 1)


def ladder(top: float = 1e-2, bottom: float = 1e-14) -> list[float]:
    k0, k1 = round(-2 * math.log10(top)), round(-2 * math.log10(bottom))
    return [10.0 ** (-k / 2) for k in range(k0, k1 + 1)]


def _contacts(r) -> set:
    b = r.network.backbone
    return set(zip(r.network.i[b].tolist(), r.network.j[b].tolist()))


def state_row(dim, n, seed, target, route, r, g64_max_dof, t64, trf) -> dict:
    d = dim
    nprime = n - r.n_floaters
    nc = r.n_contacts
    z, z_iso = 2.0 * nc / nprime, 2.0 * d * (nprime - 1) / nprime
    m = r.moduli()
    row = {"dim": dim, "n": n, "seed": seed, "target": f"{target:.3e}", "route": route, "status": "ok", "p": f"{r.pressure:.12e}",
               "phi": repr(r.phi[0]), "phi_lo": repr(r.phi[1]), "n_contacts": nc, "n_prime": nprime,
               "excess": nc - (d * (nprime - 1) + 1), "z": f"{z:.10f}", "z_iso": f"{z_iso:.10f}", "delta_z": f"{z - z_iso:.10e}",
               "force_balance": f"{r.force_balance:.2e}", "G": f"{m.G:.10e}", "B": f"{m.B:.10e}", "G_float64": "",
               "float64_same_network": "", "contacts_hash": hash(frozenset(_contacts(r))) & 0xFFFFFFFF,
               "float64_seconds": f"{t64:.3f}", "refine_seconds": f"{trf:.3f}", "error": ""}
    hi = replace(r.packing, extended=None)
    i, j = overlapping_pairs(hi)[:2]
    live = ~r.network.floater
    f64 = set(zip(i.tolist(), j.tolist()))
    backbone = {(a, b) for a, b in f64 if live[a] and live[b]}
    dd = _contacts(r)
    row.update(float64_missing=len(dd - backbone), float64_extra=len(backbone - dd),
               float64_floater_touching=len(f64 - backbone), float64_same_network=int(backbone == dd))
    if n * d <= g64_max_dof:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                row["G_float64"] = f"{HessianModuli().compute(hi).G:.10e}"
            except Exception as err:  # noqa: BLE001 - recorded, not hidden
                row["G_float64"] = f"error: {type(err).__name__}"
    return row


def self_stresses(r) -> str:
    """Why N_c exceeds d (N' - 1) + 1: the rank of the equilibrium matrix of the backbone (a row per
    contact, n_c . (u_i - u_j)), its self-stresses N_c - rank and floppy modes d N' - d - rank, the
    smallest overlap over the mean, and the self-stress orthogonal to the contact forces: its
    participation number (1 / sum w^2, w its squared unit components), its contacts and diameters."""
    net, p = r.network, r.packing
    b = net.backbone
    i, j, overlap = net.i[b], net.j[b], net.overlap[b]
    live = np.flatnonzero(~net.floater)
    col = np.full(p.n, -1)
    col[live] = np.arange(len(live))
    d = p.dim
    dr = p.box.minimum_image(p.positions[i] - p.positions[j])
    normal = dr / np.linalg.norm(dr, axis=1)[:, None]
    a = np.zeros((len(i), d * len(live)))
    rows = np.arange(len(i))
    for k in range(d):
        a[rows, col[i] * d + k] = normal[:, k]
        a[rows, col[j] * d + k] = -normal[:, k]
    _, sv, vt = np.linalg.svd(a.T)
    rank = int((sv > 1e-10 * sv[0]).sum())
    text = (f"N_c = {len(i)}, N' = {len(live)}, rank {rank}: {len(i) - rank} self-stresses, "
            f"{d * len(live) - d - rank} floppy modes; smallest overlap / mean {(overlap / overlap.mean()).min():.2g}")
    force = overlap / (0.5 * (p.diameters[i] + p.diameters[j])) ** 2
    force /= np.linalg.norm(force)
    for stress in vt[rank:]:
        other = stress - (stress @ force) * force
        if np.linalg.norm(other) > 1e-6:
            w = (other / np.linalg.norm(other)) ** 2
            top = np.flatnonzero(w > 0.01 * w.max())
            parts = np.unique(np.concatenate([i[top], j[top]]))
            text += (f"; another self-stress: participation {1 / np.sum(w**2):.1f} contacts, {len(top)} carrying it, "
                     f"on particles {parts.tolist()} of diameters {sorted(set(p.diameters[parts].tolist()))}")
            break
    return text


def float64_enthalpy_minimum(packing, target, tries: int = F64_TRIES):
    """The float64 enthalpy minimum at ``target`` from ``packing``: ``jam_at_pressure`` again from
    where it stopped while it stops at its iteration cap (a rearrangement FIRE creeps through: 3D
    N = 128 seed 15 at p = 1e-6 stopped with every particle a floater, the box mid-way), at most
    ``tries`` times; a state still unconverged is passed on (refine balances it or fails)."""
    for _ in range(tries):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = jam_at_pressure(packing, PressureSettings((target,)), engine="numba")
        packing = result.packing
        if bool(result.history["converged"][-1]):
            break
    return packing


def float64_at_phi(packing, phi):
    """``packing`` rescaled affinely to packing fraction ``phi`` and relaxed there by float64 FIRE at
    that box, to force balance (``refine.relax_at_box``)."""
    return relax_at_box(replace(packing, extended=None).scaled_to_phi(phi))


def fixed_box_step(packing, points, target):
    """The float64 state for ``target`` by ``float64_at_phi`` at the phi of the secant through the
    last two (phi, p) ``points`` (p linear in phi near onset for the spring); a state whose pressure
    is below target / STEP_FLOOR (it rearranged below its onset: 3D N = 512 seed 13 at 3.2e-5 relaxed
    to p = 2e-17, every particle a floater) is tried again halfway back to the last point, at most
    STEP_BACKOFFS times."""
    (fa, pa), (fb, pb) = points[-2], points[-1]
    phi = fb + (target - pb) * (fb - fa) / (pb - pa)
    for _ in range(STEP_BACKOFFS):
        state = float64_at_phi(packing, phi)
        if energy_forces_pressure(state, pairs="near").pressure > target / STEP_FLOOR:
            return state
        phi = 0.5 * (phi + fb)
    raise RuntimeError(f"no jammed float64 state between phi = {phi:.10f} and {fb:.10f}")


def run_packing(dim, n, seed, pressures, switch, g64_max_dof, sizes, last=None, float64="fixed-box") -> list[dict]:
    """Above ``switch``: the float64 chain, each of its states balanced in double-double (a failure
    there is recorded and the chain goes on). Its first state is the enthalpy minimum at the top
    pressure from the onset; then, ``float64="enthalpy"``, each enthalpy minimum from the previous
    float64 state (``float64_enthalpy_minimum``), or, ``"fixed-box"``, the previous state rescaled
    to the phi extrapolated from the last two balanced states (the onset first, at p = 0) and
    relaxed at that box (``fixed_box_step``). At and below ``switch``: each state refined from the
    previous double-double one (a failure stops). ``last``: a list given the last RefineResult."""
    rows = []
    t0 = time.perf_counter()
    onset = jamflow.jam(n=n, dim=dim, seed=seed, engine="numba", sizes=sizes)
    t_onset = time.perf_counter() - t0
    f64_packing, dd_packing, first = onset.packing, None, True
    points = [(onset.packing.phi, 0.0)]
    for target in pressures:
        route = "float64+dd" if target > switch else "dd"
        if route == "float64+dd" and float64 == "fixed-box" and not first:
            route = "box+dd"
        t64 = t_onset if first else 0.0
        first = False
        try:
            t0 = time.perf_counter()
            if route == "float64+dd":
                start = f64_packing = float64_enthalpy_minimum(f64_packing, target)
            elif route == "box+dd":
                start = f64_packing = fixed_box_step(f64_packing, points, target)
            elif dd_packing is None:
                raise RuntimeError("no double-double state above to start from")
            else:
                start = dd_packing
            t64 += time.perf_counter() - t0
            t0 = time.perf_counter()
            r = jamflow.refine(start, target)
            trf = time.perf_counter() - t0
        except Exception as err:  # noqa: BLE001 - a failed state is recorded with its error
            rows.append({"dim": dim, "n": n, "seed": seed, "target": f"{target:.3e}", "route": route, "status": "failed",
                             "float64_seconds": f"{t64:.3f}", "error": f"{type(err).__name__}: {err}".replace("\n", " ")})
            print(f"FAILED d={dim} N={n} seed={seed} p={target:.1e}: {rows[-1]['error']}", flush=True)
            dd_packing = None
            if route == "dd":
                break
            continue
        rows.append(state_row(dim, n, seed, target, route, r, g64_max_dof, t64, trf))
        dd_packing = r.packing
        points.append((r.phi[0], r.pressure))
        if last is not None:
            last[:] = [r]
    return rows


def write(path, rows):
    """Add ``rows`` to the CSV at ``path`` (header first if it is new): earlier rows are kept."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    new = not path.exists()
    with open(path, "a", newline="") as fh:
        writer = csv.DictWriter(fh, COLUMNS, restval="")
        if new:
            writer.writeheader()
        writer.writerows(rows)


# --- report: fits, phi_J, figure ------------------------------------------------------------

def _slope(x, y):
    """Least-squares slope of log y on log x and its standard error."""
    lx, ly = np.log(x), np.log(y)
    a = np.vstack([lx, np.ones_like(lx)]).T
    coef, *_ = np.linalg.lstsq(a, ly, rcond=None)
    dof = len(lx) - 2
    s2 = float(np.sum((ly - a @ coef) ** 2) / dof) if dof > 0 else math.nan
    cov = s2 * np.linalg.inv(a.T @ a)
    return float(coef[0]), float(math.sqrt(cov[0, 0]))


def load(paths) -> list[dict]:
    rows = []
    for p in paths:
        with open(p, newline="") as fh:
            rows += list(csv.DictReader(fh))
    return rows


def _ensembles(rows) -> dict:
    """{(d, N): {seed: {target: row}}} of the balanced states."""
    out = {}
    for r in rows:
        if r["status"] == "ok":
            out.setdefault((int(r["dim"]), int(r["n"])), {}).setdefault(int(r["seed"]), {})[r["target"]] = r
    return out


def _means(seeds: dict, pick: list) -> tuple:
    """(p, <dz>, <G>) over the packings ``pick`` (seeds, repeats allowed) at each target pressure."""
    targets = sorted({t for s in pick for t in seeds[s]}, key=float)
    p, dz, g = [], [], []
    for t in targets:
        have = [seeds[s][t] for s in pick if t in seeds[s]]
        p.append(float(t))
        dz.append(np.mean([float(r["delta_z"]) for r in have]))
        g.append(np.mean([float(r["G"]) for r in have]))
    return np.array(p), np.array(dz), np.array(g)


def _collapse_slope(groups: dict, key: str, min_pn2: float, picks: dict):
    """Slope of log(N <y>) on log(p N^2) over the sizes in ``groups`` with p N^2 >= min_pn2 and <y> > 0."""
    xs, ys = [], []
    for (dim, n), seeds in groups.items():
        p, dz, g = _means(seeds, picks[(dim, n)])
        y = dz if key == "dz" else g
        ok = (p * n**2 >= min_pn2) & (y > 0)
        xs.append(p[ok] * n**2)
        ys.append(n * y[ok])
    x, y = np.concatenate(xs), np.concatenate(ys)
    return _slope(x, y)[0] if len(x) >= 3 else math.nan, len(x)


def fits(rows, min_pn2: float, boot: int = 400, seed: int = 0):
    """Exponents of the ensemble means <Delta z> and <G> (G of every state, negative ones included)
    against p over p N^2 >= min_pn2: per (d, N), and per d on the collapse N <y> against p N^2 over
    all N; errors are the standard deviation over ``boot`` bootstrap resamplings of the packings."""
    rng = np.random.default_rng(seed)
    groups = _ensembles(rows)
    out = {}
    sets = [((dim, n), {(dim, n): seeds}) for (dim, n), seeds in sorted(groups.items())]
    for dim in sorted({d for d, _ in groups}):
        sets.append(((dim, "all"), {k: v for k, v in groups.items() if k[0] == dim}))
    for name, sub in sets:
        for key in ("dz", "G"):
            full = {k: sorted(v) for k, v in sub.items()}
            slope, points = _collapse_slope(sub, key, min_pn2, full)
            if not math.isfinite(slope):
                continue
            draws = [_collapse_slope(sub, key, min_pn2, {k: list(rng.choice(v, len(v))) for k, v in full.items()})[0]
                     for _ in range(boot)]
            draws = np.array(draws)[np.isfinite(draws)]
            out[(name[0], name[1], key)] = {"slope": slope, "err": float(np.std(draws, ddof=1)),
                                                "packings": sum(len(v) for v in full.values()), "points": points}
    return out


def phi_j_fits(rows, p_max: float = 1.01e-10):
    """Per packing: phi = phi_J + p / s over its states with p <= p_max (phi from hi + lo), phi_J
    +- its standard error, the largest residual, and the contacts changed from the p_max state down."""
    out = []
    groups = {}
    for r in rows:
        if r["status"] == "ok":
            groups.setdefault((int(r["dim"]), int(r["n"]), int(r["seed"])), []).append(r)
    for key, states in sorted(groups.items()):
        low = [s for s in states if float(s["p"]) <= p_max]
        if len(low) < 3:
            continue
        ref_hi, ref_lo = float(low[0]["phi"]), float(low[0]["phi_lo"])
        p = np.array([float(s["p"]) for s in low])
        dphi = np.array([(float(s["phi"]) - ref_hi) + (float(s["phi_lo"]) - ref_lo) for s in low])
        a = np.vstack([p, np.ones_like(p)]).T
        coef, *_ = np.linalg.lstsq(a, dphi, rcond=None)
        resid = dphi - a @ coef
        s2 = float(np.sum(resid**2) / (len(p) - 2))
        cov = s2 * np.linalg.inv(a.T @ a)
        hashes = {s["contacts_hash"] for s in low}
        out.append({"dim": key[0], "n": key[1], "seed": key[2], "states": len(low), "phi_j": ref_hi + (ref_lo + coef[1]),
                        "phi_j_err": math.sqrt(cov[1, 1]), "slope": coef[0], "max_resid": float(np.abs(resid).max()),
                        "same_network": len(hashes) == 1})
    return out


def report(paths, figure, min_pn2, quiet=False) -> dict:
    from jamflow.plots.ladder import ladder_figure

    rows = load(paths)
    result = fits(rows, min_pn2)
    failed = [r for r in rows if r["status"] != "ok"]
    print(f"states: {len(rows)} ({len(failed)} failed)")
    for r in failed:
        print(f"  FAILED d={r['dim']} N={r['n']} seed={r['seed']} p={r['target']}: {r['error']}")
    print(f"exponents of the ensemble means over p N^2 >= {min_pn2:g} (+- bootstrap over packings):")
    for (dim, n, key), f in result.items():
        print(f"  {dim}D N={n!s:>5} {key:2s}: {f['slope']:.3f} +- {f['err']:.3f} ({f['packings']} packings, "
              f"{f['points']} mean points)  published {PUBLISHED[key]}")
    ok = [r for r in rows if r["status"] == "ok"]
    for dim in sorted({r["dim"] for r in ok}):
        sel = [r for r in ok if r["dim"] == dim]
        print(f"  {dim}D: G <= 0 (unstable to shear at fixed box shape) at {sum(float(r['G']) <= 0 for r in sel)} of "
              f"{len(sel)} states")
    for (dim, n), seeds in sorted(_ensembles(rows).items()):
        last = [states[min(states, key=float)] for states in seeds.values()]
        bottom = min(float(r["target"]) for r in last)
        at = [r for r in last if float(r["target"]) == bottom]
        print(f"  {dim}D N={n} at p = {bottom:.0e}: {len(at)} packings, N_c = d (N' - 1) + 1 in "
              f"{sum(int(r['excess']) == 0 for r in at)} (excess {sorted({int(r['excess']) for r in at})}), "
              f"max|F|/<f> <= {max(float(r['force_balance']) for r in at):.1e}, |p/target - 1| <= "
              f"{max(abs(float(r['p']) / float(r['target']) - 1) for r in at):.1e}")
    pj = phi_j_fits(rows)
    print("phi_J from phi = phi_J + p / s at p <= 1e-10 (hi + lo):")
    for f in pj if not quiet else pj[:3]:
        print(f"  {f['dim']}D N={f['n']} seed={f['seed']}: phi_J = {f['phi_j']:.16f} +- {f['phi_j_err']:.1e}  "
              f"dphi/dp = {f['slope']:.4f}  max resid {f['max_resid']:.1e}  ({f['states']} states, "
              f"network {'unchanged' if f['same_network'] else 'CHANGED'})")
    cost = {}
    for r in rows:
        if r["status"] == "ok":
            c = cost.setdefault((r["dim"], r["n"]), [0.0, 0.0, set(), 0, 0, 0])
            c[0] += float(r["float64_seconds"])
            c[1] += float(r["refine_seconds"])
            c[2].add(r["seed"])
            c[3] += 1
            if r["float64_same_network"] == "0":
                c[4] += 1
                c[5] = min(c[5] or 1.0, float(r["p"])) if c[5] else float(r["p"])
    for (dim, n), c in sorted(cost.items(), key=lambda kv: (int(kv[0][0]), int(kv[0][1]))):
        k = len(c[2])
        print(f"  cost {dim}D N={n}: {k} packings, float64 {c[0] / k:.1f} s, double-double {c[1] / k:.1f} s per "
              f"ladder ({c[3]} states); float64 positions lose/gain contacts at {c[4]} states")
    if figure:
        series = {}
        for r in rows:
            if r["status"] == "ok":
                s = series.setdefault(f"{r['dim']}D N={r['n']}", ([], [], [], []))
                for lst, v in zip(s, (float(r["n"]), float(r["p"]), float(r["delta_z"]), float(r["G"]))):
                    lst.append(v)
        series = {k: tuple(np.array(v) for v in s) for k, s in
                  sorted(series.items(), key=lambda kv: (kv[0][:2], int(kv[0].split("=")[1])))}
        fitted = {(f"{dim}D N={n}", key): (f["slope"], f["err"]) for (dim, n, key), f in result.items()}
        means = {}
        for (dim, n), seeds in _ensembles(rows).items():
            mp, mdz, mg = _means(seeds, sorted(seeds))
            means[f"{dim}D N={n}"] = (np.full(len(mp), float(n)), mp, mdz, mg)
        collapse = "; ".join(f"{dim}D collapse: Delta z {result[(dim, 'all', 'dz')]['slope']:.3f} +- "
                             f"{result[(dim, 'all', 'dz')]['err']:.3f}, G {result[(dim, 'all', 'G')]['slope']:.3f} +- "
                             f"{result[(dim, 'all', 'G')]['err']:.3f}" for dim in sorted({d for d, _, _ in result})
                             if (dim, "all", "dz") in result and (dim, "all", "G") in result)
        ladder_figure(figure, series, means, PUBLISHED, fitted,
                      title=f"Pressure ladder (double-double), fits over p N^2 >= {min_pn2:g}\n{collapse}")
        print(f"wrote {figure}")
    return result


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dim", type=int, default=2)
    ap.add_argument("--n", type=int, nargs="+", default=[64, 256])
    ap.add_argument("--seeds", type=int, nargs="+", default=[10], help="SEEDS: 1 .. SEEDS; A B: A .. B")
    ap.add_argument("--sizes", default="bi:1.4:0.5", help="size spec (default: 50:50 bidisperse 1 : 1.4)")
    ap.add_argument("--top", type=float, default=1e-2)
    ap.add_argument("--bottom", type=float, default=1e-14)
    ap.add_argument("--float64", choices=("fixed-box", "enthalpy"), default="fixed-box",
                    help="float64 steps below the top pressure: relaxations at the box of the extrapolated phi "
                         "(default), or enthalpy minimisations (the 2D and 3D N = 128 rows before 2026-12-03)")
    ap.add_argument("--switch", type=float, default=1.5e-9, help="float64 steps down above this pressure")
    ap.add_argument("--g64-max-dof", type=int, default=600, help="HessianModuli on float64 up to N d")
    ap.add_argument("--append", action="store_true", help="(no effect: rows are always added to --out)")
    ap.add_argument("--out", default=str(scratch("pressure-ladder.csv")))
    ap.add_argument("--report", nargs="+", default=None, help="CSV(s): fit, print and draw")
    ap.add_argument("--figure", default=str(scratch("pressure-ladder.png")))
    ap.add_argument("--min-pn2", type=float, default=10.0, help="fit over p N^2 >= this")
    ap.add_argument("--quick", action="store_true", help="N = 16, one seed, 3 pressures (seconds); --out required")
    ap.add_argument("--self-stress", action="store_true", help="print the self-stresses of each ladder's last state")
    args = ap.parse_args(argv)
    if args.report:
        report(args.report, args.figure, args.min_pn2)
        return 0
    if args.quick:
        args.n, args.seeds, args.top, args.bottom = [16], [1], 1e-3, 1e-4
        args.switch = 5e-4
    seeds = range(1, args.seeds[0] + 1) if len(args.seeds) == 1 else range(args.seeds[0], args.seeds[1] + 1)
    pressures = ladder(args.top, args.bottom)
    for n in args.n:
        for seed in seeds:
            t0 = time.perf_counter()
            last = []
            rows = run_packing(args.dim, n, seed, pressures, args.switch, args.g64_max_dof, args.sizes, last, args.float64)
            if args.self_stress and last:
                print(f"d={args.dim} N={n} seed={seed} at p = {last[0].pressure:.3e}: {self_stresses(last[0])}", flush=True)
            write(args.out, rows)
            ok = [r for r in rows if r["status"] == "ok"]
            print(f"d={args.dim} N={n} seed={seed}: {len(ok)}/{len(pressures)} states, {time.perf_counter() - t0:.1f} s"
                  + (f", last p = {ok[-1]['p']}, N_c - iso = {ok[-1]['excess']}" if ok else ""), flush=True)
    if args.quick:
        report([args.out], str(Path(args.out).with_suffix(".png")), 0.0, quiet=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
