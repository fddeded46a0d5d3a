"""Small 2D packings jammed on the numpy reference energy, for shapes no compiled engine runs yet
(ellipses): the chapter's compression/decompression bisection on phi (section 2.1, stop when
V_tol < V/N < 2 V_tol) with every minimisation done by scipy's trust-region Newton method
(``trust-exact``) on V(xi), xi = (centres, d_k theta), gradient from the reference forces and
torques, Hessian from ``jamflow.mechanics.hessian``. In 2D theta is a global coordinate, so V(xi) is
an ordinary function for scipy. Used to make the stored test packings (tests/data/) and the
docs' small ellipse ensembles; N ~ 16-64 (all-pairs reference).

Usage: python benchmarks/reference_jam.py --shape ellipse:1.5 --n 32 --seeds 0 1 2 --out tests/data
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from scipy.optimize import minimize

from jamflow.mechanics.hessian import Coordinates, hessian
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.io.packing_file import save_packing
from jamflow.model.packing import random_packing
from jamflow.model.potentials import parse_potential
from jamflow.model.shapes import parse_shape
from jamflow.model.sizes import parse_sizes

V_TOL = 1e-16


def relax(packing, gtol=1e-15, maxiter=2000):
    """Minimise the reference energy from ``packing`` (2D); returns (packing, scipy result)."""
    if packing.dim != 2:
        raise ValueError("reference_jam.relax handles 2D packings (theta is then a global coordinate)")
    coords = Coordinates.of(packing)
    base = packing.with_positions(packing.box.wrap(packing.positions))

    def at(xi):
        u, w = coords.split(xi)
        theta = base.orientations + w[:, 0] / coords.lengths[:, 0]
        return base.with_positions(base.positions + u, orientations=theta)

    def fun(xi):
        ref = energy_forces_pressure(at(xi))
        grad = np.concatenate([-ref.forces.ravel(), -(ref.torques / coords.lengths[:, 0])])
        return ref.energy, grad

    def hess(xi):
        return hessian(at(xi)).toarray()

    res = minimize(fun, np.zeros(coords.size), jac=True, hess=hess, method="trust-exact",
                   options=dict(gtol=gtol, maxiter=maxiter))
    return at(res.x), res


def jam(start, dphi=1e-3, max_steps=400, log=None):
    """Bisection on phi until V_tol < V/N < 2 V_tol at a minimum; returns the packing."""
    p, res = relax(start)
    direction, phi = 0, start.phi
    for step in range(max_steps):
        v = res.fun / p.n
        if log:
            log(f"step {step:3d} phi {phi:.9f} V/N {v:.3e} |g| {np.abs(res.jac).max():.1e} it {res.nit}")
        if V_TOL < v < 2 * V_TOL:
            return p
        new = -1 if v >= 2 * V_TOL else 1
        if direction and new != direction:
            dphi *= 0.5
        direction = new
        phi += direction * dphi
        p, res = relax(p.scaled_to_phi(phi))
    raise RuntimeError(f"no jammed packing within {max_steps} steps (last V/N {res.fun / p.n:.3e})")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shape", default="ellipse:1.5")
    ap.add_argument("--n", type=int, default=32)
    ap.add_argument("--sizes", default="bi:1.4:0.5")
    ap.add_argument("--potential", default="spring")
    ap.add_argument("--phi0", type=float, default=0.80)
    ap.add_argument("--seeds", type=int, nargs="+", default=[0])
    ap.add_argument("--out", default="tests/data")
    args = ap.parse_args(argv)
    shape = parse_shape(args.shape, 2)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for seed in args.seeds:
        t0 = time.process_time()
        start = random_packing(args.n, 2, parse_sizes(args.sizes), args.phi0, seed,
                               parse_potential(args.potential), shape)
        p = jam(start, log=lambda m: print(m, file=sys.stderr))
        ref = energy_forces_pressure(p)
        name = out / f"{args.shape.replace(':', '')}_n{args.n}_s{seed}.h5"
        save_packing(name, p.with_positions(p.box.wrap(p.positions), seed=seed),
                     energy_per_particle=ref.energy / p.n, pressure_tensor=ref.pressure_tensor)
        print(f"{name}: phi_J {p.phi:.8f} V/N {ref.energy / p.n:.3e} max|F| {np.abs(ref.forces).max():.1e} "
              f"max|tau| {np.abs(ref.torques).max():.1e} ({time.process_time() - t0:.1f} s CPU)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
