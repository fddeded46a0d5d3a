"""Two measurements behind docs/damped-md.md.

1. The seed's MD stopping rule near V ~ 1e-16: the relative rms energy fluctuation
   <(V - <V>)^2>^(1/2) / <V> of each 10 000-step window (energies sampled every 10 steps)
   while damped MD sits at a minimum, for onset packings (phi_J from FIRE) and the same
   packings compressed by dphi, with viscous and pairwise damping. Is delta = 1e-16
   reachable? (The force tolerance is set to 1e-30 so that no rule stops the runs.)
2. The explicit-step limit of the pairwise damping: lambda_max of the contact damping
   matrix D / b = sum_contacts (e_i - e_j)(e_i - e_j)^T (x) n n^T of jammed packings
   against its Gershgorin bound max_contacts (z_i + z_j); and damped MD from rest, 1e-3
   above onset, at b dt just below and above 2 / lambda_max (fix jamflow/damping set up
   by hand: jamflow refuses b dt >= 1/12 before any work).

    flock /tmp/jamflow-bench.lock python benchmarks/damped_md_floor.py

Writes docs/damped-md-floor.csv, docs/damped-md-floor.png and docs/damped-md-limit.csv.
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np
from tqdm import tqdm

from jamflow import jam
from jamflow.engines.lammps.engine import LammpsEngine
from jamflow.engines.lammps.plugin_build import load_plugin
from jamflow.minimize.settings import MinimizerSettings
from jamflow.model.pairs import overlapping_pairs

DOCS = Path(__file__).resolve().parents[1] / "docs"
DPHIS = (0.0, 1e-6, 1e-4, 1e-2)


# 1. the fluctuation floor ---------------------------------------------------------------------------
def fluctuation_series(packing, damping: str, windows: int):
    """[(window, V per particle, max force, relative rms fluctuation)] of damped MD at rest."""
    s = MinimizerSettings(method="md", md_damping=damping, force_tol=1e-30)
    rows = []
    with LammpsEngine(packing) as engine, engine.minimizer_session(s, 1e-30) as window:
        for k in range(windows):
            _, energy, fmax, fluctuation, _ = window(s.window)
            rows.append((k, energy / packing.n, fmax, fluctuation))
    return rows


def floor_sweep(sizes, windows: int, out: Path):
    cases = [(n, dphi, damping) for n in sizes for dphi in DPHIS for damping in ("viscous", "pairwise")]
    onsets = {n: jam(n=n, dim=2, seed=1) for n in sizes}
    with out.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["n", "dphi", "damping", "window", "v", "max_force", "fluctuation"])
        for n, dphi, damping in tqdm(cases, desc="fluctuation floor", unit="case"):
            packing = onsets[n].packing.scaled_to_phi(onsets[n].phi_j + dphi)
            for k, v, f, fl in fluctuation_series(packing, damping, windows):
                w.writerow([n, dphi, damping, k, v, f, fl])
            fh.flush()


def floor_chart(path: Path, out: Path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = list(csv.DictReader(path.open()))
    sizes = sorted({int(r["n"]) for r in rows})
    fig, axes = plt.subplots(1, len(sizes), figsize=(5.5 * len(sizes), 4.6), squeeze=False)
    colours = dict(zip(DPHIS, ("C0", "C1", "C2", "C3")))
    for ax, n in zip(axes[0], sizes):
        for dphi in DPHIS:
            for damping, style in (("viscous", "--"), ("pairwise", "-")):
                rs = [r for r in rows if int(r["n"]) == n and float(r["dphi"]) == dphi and r["damping"] == damping]
                ax.semilogy([int(r["window"]) for r in rs], [max(float(r["fluctuation"]), 1e-18) for r in rs],
                            style, color=colours[dphi],
                            label=f"{damping}, dphi {dphi:g} (V {float(rs[-1]['v']):.1e})" if n == sizes[0] else None)
        ax.axhline(1e-16, color="k", lw=0.8)
        ax.text(0, 1.4e-16, r"seed's $\delta = 10^{-16}$", fontsize=8)
        ax.set_xlabel("window (10 000 MD steps, energy sampled every 10)")
        ax.set_ylabel(r"$\langle (V-\langle V\rangle)^2\rangle^{1/2} / \langle V\rangle$")
        ax.set_title(f"N = {n}, 2D bidisperse, onset + dphi")
    fig.legend(loc="lower center", ncol=4, fontsize=7.5)
    fig.tight_layout(rect=(0, 0.14, 1, 1))
    fig.savefig(out, dpi=110)


# 2. the explicit-step limit ---------------------------------------------------------------------------------
def damping_matrix_lambda(packing) -> tuple[float, int]:
    """(lambda_max of D / b, max over contacts of z_i + z_j) for the packing's contacts."""
    i, j, dr, r, _ = overlapping_pairs(packing)
    n, d = packing.n, packing.dim
    normals = dr / r[:, None]
    rows = np.zeros((len(i), n * d))  # B: one row per contact, n^T at i and -n^T at j
    for c, (a, b) in enumerate(zip(i, j)):
        rows[c, a * d:(a + 1) * d] = normals[c]
        rows[c, b * d:(b + 1) * d] = -normals[c]
    lam = float(np.linalg.eigvalsh(rows @ rows.T).max())  # = lambda_max(B^T B)
    z = np.bincount(np.r_[i, j], minlength=n)
    return lam, int((z[i] + z[j]).max())


def md_force_growth(packing, b: float, dt: float, steps: int = 3000) -> tuple[float, float]:
    """Pairwise-damped MD from rest at ``packing``: max |force| at the start and after ``steps``."""
    with LammpsEngine(packing) as engine:
        if not load_plugin(engine.lmp):
            raise RuntimeError("the jamflow plugin is needed (a C++ compiler)")
        start = engine.evaluate().max_force
        engine.run_commands([f"timestep {dt!r}", "velocity all set 0.0 0.0 0.0", "fix nve all nve",
                             f"fix damp all jamflow/damping {b!r}", f"run {steps}"])
        return start, engine.state().max_force


def limit_sweep(out: Path, dt: float = 0.1):
    """Per packing: lambda_max(D / b), its bound, and MD at b dt = 0.95 and 1.05 x 2 / lambda_max:
    relaxing (the force falls) below the limit, excited (the force grows) above it."""
    cases = [(2, 64, s) for s in range(5)] + [(2, 256, 0), (3, 128, 0)]
    with out.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["dim", "n", "seed", "lambda_max", "gershgorin_bound", "bdt_limit", "bdt", "start_max_force",
                    "end_max_force", "grew"])
        for dim, n, seed in tqdm(cases, desc="damping limit", unit="packing"):
            onset = jam(n=n, dim=dim, seed=seed, sizes="bi:1.4:0.5" if dim == 2 else "mono")
            above = onset.packing.scaled_to_phi(onset.phi_j + 1e-3)  # same contacts, finite forces
            lam, bound = damping_matrix_lambda(above)
            for factor in (0.95, 1.05):
                bdt = factor * 2.0 / lam
                start, end = md_force_growth(above, bdt / dt, dt)
                w.writerow([dim, n, seed, lam, bound, 2.0 / lam, bdt, start, end, end > start])
            fh.flush()


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, nargs="+", default=[64, 256])
    ap.add_argument("--windows", type=int, default=30)
    ap.add_argument("--skip-floor", action="store_true")
    ap.add_argument("--skip-limit", action="store_true")
    args = ap.parse_args()
    if not args.skip_floor:
        floor_sweep(args.n, args.windows, DOCS / "damped-md-floor.csv")
    floor_chart(DOCS / "damped-md-floor.csv", DOCS / "damped-md-floor.png")
    if not args.skip_limit:
        limit_sweep(DOCS / "damped-md-limit.csv")


if __name__ == "__main__":
    main()
