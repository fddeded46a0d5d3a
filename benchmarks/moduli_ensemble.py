"""Ensemble moduli of docs/notes/moduli.md (not a test): G, B and P against phi - phi_J.

For each potential and seed it jams a 2D 50:50 bidisperse (ratio 1.4) packing of N disks at onset
(``jamflow.jam``), compresses it above onset by each DPHI (``jamflow.compress_above``: affine, then
minimised) and measures the moduli of that packing (``jamflow.protocols.moduli.Moduli``: both
strain sweeps and the Hessian route), caching every file in --out (onset_*.h5, above_*.h5,
above_*.moduli.h5), so a rerun only does what is missing. Then it writes one CSV row per packing,
the ensemble table (mean and standard error over seeds per DPHI), power-law fits of G, B, P and
G/B against DPHI with bootstrap errors over seeds, and the figures:

    OPENBLAS_NUM_THREADS=1 flock /tmp/jamflow-bench.lock python benchmarks/moduli_ensemble.py \
        --n 256 --seeds 20 --potentials spring hertz --out /tmp/jamflow-moduli --docs docs

Published: G ~ (phi - phi_J)^(alpha - 3/2), B ~ (phi - phi_J)^(alpha - 2), P ~ (phi - phi_J)^(alpha - 1)
(O'Hern, Silbert, Liu, Nagel, PRE 68, 011306 (2003)): 0.5, 0, 1 for the spring, 1, 0.5, 1.5 for Hertz.
"""

from __future__ import annotations

import argparse
import math
import time
import warnings
from pathlib import Path

import numpy as np
from tqdm import tqdm

from jamflow.protocols.moduli import Moduli
from jamflow.plots.moduli import family_figure, scaling_figure
from jamflow.protocols.sweeps import SweepSettings
from jamflow.io.moduli_file import read_moduli, save_moduli
from jamflow.io.packing_file import load_packing, save_packing
from jamflow.protocols.above import compress_above
from jamflow.protocols.outcome import JammingFailed
from jamflow.protocols.compression import jam

from common import merge_rows  # (benchmarks/ is the script's directory)

DPHIS = (1e-6, 3e-6, 1e-5, 3e-5, 1e-4, 3e-4, 1e-3, 3e-3, 1e-2)
PUBLISHED = {"spring": {"G": 0.5, "B": 0.0, "P": 1.0, "G/B": 0.5}, "hertz": {"G": 1.0, "B": 0.5, "P": 1.5, "G/B": 0.5}}
for _pot in PUBLISHED.values():  # the Hessian route's moduli follow the same laws
    _pot.update(G_hessian=_pot["G"], B_hessian=_pot["B"])
COLUMNS = ("potential", "seed", "dphi", "phi", "P", "G", "G_error", "G_hessian", "B", "B_error", "B_hessian",
           "G_rel_diff", "B_rel_diff", "G_linear_max", "B_linear_max", "yield_strain", "yield_reason",
           "bulk_yield_strain", "n_contacts", "n_floaters", "seconds")


def onset(path: Path, n: int, seed: int, potential: str) -> None:
    if path.exists():
        return
    res = jam(n=n, dim=2, sizes="bi:1.4:0.5", potential=potential, seed=seed)
    save_packing(path, res.packing, energy_per_particle=res.energy_per_particle, pressure_tensor=res.pressure_tensor,
                 protocol=res.settings.as_dict(), history=res.history, lammps_version=res.lammps_version)


def above(source: Path, path: Path, dphi: float) -> bool:
    """False if the compressed packing relaxed to an unjammed state (recorded in unjammed.csv)."""
    failed = path.with_name("unjammed.csv")
    if path.exists():
        return True
    if failed.exists() and path.name in failed.read_text().split():
        return False
    try:
        res = compress_above(load_packing(source), dphi)
    except JammingFailed:
        with open(failed, "a") as fh:
            fh.write(path.name + "\n")
        return False
    save_packing(path, res.packing, energy_per_particle=res.energy_per_particle, pressure_tensor=res.pressure_tensor,
                 protocol={"source": str(source), "above_reason": res.minimization.reason}, dphi_above=dphi)
    return True


def measure(path: Path, out: Path, dphi: float, moduli: Moduli) -> float:
    """Seconds (CPU of this process) of the measurement; 0 if cached."""
    if out.exists():
        return 0.0
    packing = load_packing(path)
    start = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = moduli.compute(packing)
    save_moduli(out, path, packing, result, dphi, moduli)
    return time.process_time() - start


def row(potential, seed, dphi, data, seconds) -> dict:
    rel = {m: data[m] / data[f"{m}_hessian"] - 1 for m in ("G", "B")}
    return dict(potential=potential, seed=seed, dphi=dphi, phi=data["phi"], P=data["pressure"], G=data["G"],
                G_error=data["G_error"], G_hessian=data["G_hessian"], B=data["B"], B_error=data["B_error"],
                B_hessian=data["B_hessian"], G_rel_diff=rel["G"], B_rel_diff=rel["B"],
                G_linear_max=data["G_linear_max"], B_linear_max=data["B_linear_max"],
                yield_strain=data["yield_strain"], yield_reason=data["yield_reason"],
                bulk_yield_strain=data["bulk_yield_strain"], n_contacts=data["n_contacts"],
                n_floaters=data["n_floaters"], seconds=seconds)


def power_fit(x, y):
    """(exponent, prefactor) of y = c x^b by least squares in log-log."""
    b, log_c = np.polyfit(np.log(x), np.log(y), 1)
    return float(b), float(math.exp(log_c))


def ensemble(rows, quantity):
    """{potential: (dphi, per-seed matrix (seeds, dphis))} of a quantity ("G/B" = G / B)."""
    out = {}
    for pot in sorted({r["potential"] for r in rows}):
        mine = [r for r in rows if r["potential"] == pot]
        dphis = np.array(sorted({r["dphi"] for r in mine}))
        seeds = sorted({r["seed"] for r in mine})
        m = np.full((len(seeds), len(dphis)), np.nan)
        for r in mine:
            value = r["G"] / r["B"] if quantity == "G/B" else r[quantity]
            m[seeds.index(r["seed"]), int(np.searchsorted(dphis, r["dphi"]))] = value
        out[pot] = (dphis, m)
    return out


def fits_with_bootstrap(rows, quantities=("G", "B", "P", "G/B"), resamples=1000, seed=0):
    """Table of means and standard errors, fitted exponents with bootstrap errors over seeds."""
    rng = np.random.default_rng(seed)
    table, fits, lines = {}, {}, []
    for quantity in quantities:
        for pot, (dphis, m) in ensemble(rows, quantity).items():
            mean = np.nanmean(m, axis=0)
            err = np.nanstd(m, axis=0, ddof=1) / np.sqrt(np.sum(np.isfinite(m), axis=0))
            table.setdefault(pot, {})[quantity] = (dphis, mean, err)
            exponent, prefactor = power_fit(dphis, mean)
            boot = []
            for _ in range(resamples):
                pick = m[rng.integers(0, len(m), len(m))]
                boot_mean = np.nanmean(pick, axis=0)
                if np.all(boot_mean > 0):
                    boot.append(power_fit(dphis, boot_mean)[0])
            spread = float(np.std(boot, ddof=1))
            fits[(pot, quantity)] = (exponent, spread, prefactor)
            lines.append(f"{pot:6s} {quantity:4s} exponent {exponent:+.4f} +- {spread:.4f} (bootstrap over "
                         f"{len(m)} seeds, {len(boot)} resamples; published {PUBLISHED.get(pot, {}).get(quantity, 'n/a')})")
    return table, fits, lines


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=256)
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--potentials", nargs="+", default=["spring", "hertz"])
    ap.add_argument("--dphi", type=float, nargs="+", default=list(DPHIS))
    ap.add_argument("--out", default="/tmp/jamflow-moduli")
    ap.add_argument("--docs", default=None, help="directory for the CSV files and figures (e.g. docs)")
    ap.add_argument("--per-decade", type=int, default=2, help="sweep amplitudes per decade from 1e-9 to 1e-3")
    ap.add_argument("--past-yield", type=int, default=2, help="sweep amplitudes measured beyond the first yield")
    ap.add_argument("--fit-min", type=float, default=1e-4,
                    help="also fit over DPHI >= this only (below it N = 256 nears the finite-size regime dphi N^2 < 1)")
    ap.add_argument("--report", action="store_true",
                    help="only report: every cached result of this N in --out (each potential with its own DPHIs)")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if not args.report:
        moduli = Moduli(SweepSettings(tuple(np.geomspace(1e-9, 1e-3, 6 * args.per_decade + 1)),
                                      past_yield=args.past_yield))
        jobs = [(pot, s, d) for pot in args.potentials for s in range(args.seeds) for d in args.dphi]
        for pot, seed, dphi in tqdm(jobs, desc="moduli", unit="packing", dynamic_ncols=True):
            base = out / f"onset_{pot}_n{args.n}_s{seed}.h5"
            onset(base, args.n, seed, pot)
            path = out / f"above_{pot}_n{args.n}_s{seed}_d{dphi:g}.h5"
            if not above(base, path, dphi):
                continue
            result = path.with_name(path.stem + ".moduli.h5")
            seconds = measure(path, result, dphi, moduli)
            if seconds:
                with open(out / "cpu_seconds.csv", "a") as fh:
                    fh.write(f"{result.name},{seconds:.3f}\n")
    report(collect(out, args.n), args)


def collect(out: Path, n: int) -> list:
    """One row per cached result of N particles (potential, seed, DPHI from the file name)."""
    seconds = {}
    if (out / "cpu_seconds.csv").exists():
        for line in (out / "cpu_seconds.csv").read_text().split():
            name, value = line.split(",")
            seconds[name] = float(value)
    rows = []
    for path in sorted(out.glob(f"above_*_n{n}_s*_d*.moduli.h5")):
        pot, _, seed, dphi = path.name[len("above_"):-len(".moduli.h5")].split("_")
        rows.append(row(pot, int(seed[1:]), float(dphi[1:]), read_moduli(path), seconds.get(path.name, math.nan)))
    return rows


def report(rows, args) -> None:
    table, fits, lines = fits_with_bootstrap(rows)
    upper = [r for r in rows if r["dphi"] >= args.fit_min]
    if len({r["dphi"] for r in upper}) >= 2:
        lines.append(f"fits over dphi >= {args.fit_min:g} only:")
        lines += fits_with_bootstrap(upper, ("G", "G_hessian", "B", "B_hessian", "P", "G/B"))[2]
    for pot in sorted({r["potential"] for r in rows}):
        mine = [r for r in rows if r["potential"] == pot]
        negative = sum(r["G"] < 0 for r in mine)
        lines.append(f"{pot}: {len(mine)} packings, {negative} with G < 0 (sweeps; the Hessian agrees in sign: "
                     f"{sum((r['G'] < 0) == (r['G_hessian'] < 0) for r in mine)}/{len(mine)})")
    for line in lines:
        print(line)
    for pot in sorted({r["potential"] for r in rows}):
        mine = [r for r in rows if r["potential"] == pot]
        for dphi in sorted({r["dphi"] for r in mine}):
            at = [r for r in mine if r["dphi"] == dphi]
            g = np.array([r["G_rel_diff"] for r in at])
            b = np.array([r["B_rel_diff"] for r in at])
            neg = sum(r["G_hessian"] < 0 for r in at)
            nolin = sum(not np.isfinite(r["G"]) for r in at)
            print(f"{pot:6s} dphi {dphi:7.0e}: |G/G_hessian - 1| median {np.nanmedian(np.abs(g)):.1e} max "
                  f"{np.nanmax(np.abs(g)):.1e}; |B/B_hessian - 1| median {np.nanmedian(np.abs(b)):.1e} max "
                  f"{np.nanmax(np.abs(b)):.1e}; <= 1e-6: G {np.sum(np.abs(g) <= 1e-6)}/{len(at)}, "
                  f"B {np.sum(np.abs(b) <= 1e-6)}/{len(at)}; G < 0: {neg}; no linear regime: {nolin}; yield strain "
                  f"median {np.nanmedian([r['yield_strain'] for r in at]):.1e}")
    if not args.docs:
        return
    docs = Path(args.docs)
    tag = f"n{args.n}"
    merge_rows(docs / f"moduli-ensemble-{tag}.csv", rows, COLUMNS)  # added to the rows of earlier runs
    with open(docs / f"moduli-scaling-{tag}.txt", "w") as fh:
        fh.write("\n".join(lines) + "\n")
    seeds = len({r["seed"] for r in rows})
    scaling_figure(docs / f"moduli-scaling-{tag}.png", table, fits,
                   title=f"2D bidisperse disks, N = {args.n}, {seeds} packings per point (sweep G, B)",
                   published=PUBLISHED)
    for pot in sorted({r["potential"] for r in rows}):
        draw_family(args, pot, sorted({r["dphi"] for r in rows if r["potential"] == pot}),
                    docs / f"moduli-stress-strain-{pot}-{tag}.png")


def draw_family(args, pot, dphis, path) -> None:
    """Shear stress-strain of seed 0 at every DPHI."""
    curves = {}
    for dphi in dphis:
        data = read_moduli(Path(args.out) / f"above_{pot}_n{args.n}_s0_d{dphi:g}.moduli.h5")
        curves[f"phi - phi_J = {dphi:g}"] = (data["shear/strain"], data["shear/response"], data["yield_strain"])
    family_figure(path, curves, title=f"{pot}, N = {args.n}, seed 0: shear stress against strain")


if __name__ == "__main__":
    main()
