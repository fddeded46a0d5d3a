"""Ensembles with walls, gravity and constant pressure, 20 starts each (2D bidisperse, N = 256),
checked with the independent numpy reference, and phi_J at constant pressure against the
compression protocol on the same starts.

    flock /tmp/jamflow-bench.lock python benchmarks/walls_gravity_pressure.py --out docs/notes/walls-gravity-pressure

Writes OUT-walls.csv, OUT-gravity.csv, OUT-compare.csv (one row per start and case; the
constant-pressure ensembles at P = 1e-4 and 1e-6 are the rows of the pressure sequences there),
OUT-summary.txt, OUT-gravity-seed0.h5, and the figures OUT-packing-{0..3}.png (walled and
settled packings), OUT-profile.png (pressure with height under gravity) and
OUT-phi-pressure.png (phi against P).
Every check uses ``jamflow.mechanics.reference`` (all pairs, numpy), not the engine that minimised:
- force balance: max |F_i| over the non-floaters (all particles under gravity), wall and
  gravity forces included;
- walls: the pressure on each wall, and the virial P_yy against it;
- gravity: the floor force against the total weight, the ceiling force (must be 0);
- pressure: the measured virial pressure against the target.
Times are CPU seconds of this process (the machine is shared), beside wall seconds.
"""

from __future__ import annotations

import argparse
import csv
import statistics
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from jamflow import jam
from jamflow.mechanics.contacts import Contacts
from jamflow.analysis.profile import PressureProfile
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.protocols.compression import initial_packing
from jamflow.protocols.gravity import pile_fraction
from jamflow.protocols.pressure import PressureSettings, extrapolate_phi_j, jam_at_pressure, shear_stress
from jamflow.model.walls import face_pressures
from common import scratch, merge_rows  # (benchmarks/ is the script's directory)

SIZES = "bi:1.4:0.5"


def timed(fn, *args, **kw):
    w, c = time.perf_counter(), time.process_time()
    out = fn(*args, **kw)
    return out, time.perf_counter() - w, time.process_time() - c


def balance(packing, ref, every: bool = False):
    """(max |F| over non-floaters -- all particles if ``every`` --, contacts result)."""
    c = Contacts().compute(packing)
    keep = np.flatnonzero(packing.mobile) if every else c.kept
    return float(np.max(np.abs(ref.forces[keep]))), c


def walls_rows(n, seeds):
    rows = []
    for kind in ("smooth", "rough"):
        for seed in tqdm(seeds, desc=f"walls {kind}"):
            res, wall, cpu = timed(jam, n=n, sizes=SIZES, seed=seed, walls="y", wall_type=kind)
            p = res.packing
            ref = energy_forces_pressure(p)
            fmax, c = balance(p, ref)
            lo, hi = face_pressures(p.box, ref.wall_forces)[0]
            rows.append(dict(case=f"walls-{kind}", seed=seed, phi_j=repr(res.phi_j), V=res.energy_per_particle,
                             P_yy=ref.pressure_tensor[1, 1], P_wall_lo=lo, P_wall_hi=hi,
                             max_force_nonfloaters=fmax, n_kept=c.n_kept, floaters=c.n_floaters,
                             N_c=c.n_contacts, N_c_iso=c.isostatic_count, wall_contacts=c.n_wall_contacts,
                             fixed=0 if p.fixed is None else int(p.fixed.sum()), iterations=res.iterations,
                             wall_s=f"{wall:.2f}", cpu_s=f"{cpu:.2f}", reason=res.history["reason"][-1].decode()))
    return rows


def gravity_rows(n, seeds, g, out):
    rows, profiles = [], []
    for seed in tqdm(seeds, desc=f"gravity {g:g}"):
        res, wall, cpu = timed(jam, n=n, sizes=SIZES, seed=seed, walls="y", gravity=g)
        p = res.packing
        ref = energy_forces_pressure(p)
        fmax, c = balance(p, ref, every=True)
        prof = PressureProfile(bins=30).compute(p)
        profiles.append(prof)
        if seed == seeds[0]:
            from jamflow.io.packing_file import save_packing

            save_packing(f"{out}-gravity-seed{seed}.h5", p, pressure_tensor=res.pressure_tensor,
                         wall_forces=res.wall_forces)
        rows.append(dict(case="gravity", seed=seed, g=g, phi_pile=repr(pile_fraction(p)), V=res.energy_per_particle,
                         max_force_all=fmax, floor_over_weight_minus_1=-ref.wall_forces[1, 0, 1] / (p.n_mobile * g) - 1,
                         ceiling_force=ref.wall_forces[1, 1, 1],
                         profile_max_rel_dev=float(np.max(np.abs(prof.sigma_zz - prof.weight_above)) / prof.sigma_zz.max()),
                         K_mid=float(np.median(prof.sigma_xx[5:20] / prof.sigma_zz[5:20])),
                         n_kept=c.n_kept, floaters=c.n_floaters, N_c=c.n_contacts, N_c_iso=c.isostatic_count,
                         wall_contacts=c.n_wall_contacts, iterations=res.iterations, wall_s=f"{wall:.2f}",
                         cpu_s=f"{cpu:.2f}", reason=res.history["reason"][-1].decode()))
    return rows, profiles


def pressure_run(start, targets, stress="iso"):
    """Each target from the previous minimum, checked by the reference after each: rows, phis."""
    rows, packing = [], start
    for target in targets:
        res, wall, cpu = timed(jam_at_pressure, packing, PressureSettings((target,), stress))
        packing = res.packing
        ref = energy_forces_pressure(packing)
        fmax, c = balance(packing, ref)
        rows.append(dict(target=target, stress=stress, phi=repr(res.phi), P=ref.pressure,
                         P_rel_error=ref.pressure / target - 1, shear_over_P=shear_stress(ref.pressure_tensor) / ref.pressure,
                         max_force_nonfloaters=fmax, max_box_force=float(res.history["max_box_force"][-1]),
                         n_kept=c.n_kept, floaters=c.n_floaters, N_c=c.n_contacts, N_c_iso=c.isostatic_count,
                         iterations=res.iterations, wall_s=f"{wall:.2f}", cpu_s=f"{cpu:.2f}",
                         reason=res.history["reason"][-1].decode()))
    return rows


SEQUENCES = {"iso from 1e-4": ((1e-4, 1e-5, 1e-6, 1e-7), "iso"), "tri from 1e-4": ((1e-4, 1e-5, 1e-6, 1e-7), "tri"),
             "iso from 1e-2": ((1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7), "iso")}


def compare_rows(n, seeds):
    rows = []
    for seed in tqdm(seeds, desc="compression vs constant pressure"):
        start = initial_packing(n, 2, SIZES, "spring", seed, 0.8)
        res, wall, cpu = timed(jam, start=start)
        ref = energy_forces_pressure(res.packing)
        fmax, c = balance(res.packing, ref)
        rows.append(dict(case="compression", seed=seed, target="", phi=repr(res.phi_j), P=ref.pressure,
                         P_rel_error="", shear_over_P=shear_stress(ref.pressure_tensor) / ref.pressure,
                         max_force_nonfloaters=fmax, n_kept=c.n_kept, N_c=c.n_contacts, N_c_iso=c.isostatic_count,
                         iterations=res.iterations, wall_s=f"{wall:.2f}", cpu_s=f"{cpu:.2f}"))
        for name, (targets, stress) in SEQUENCES.items():
            for r in pressure_run(start, targets, stress):
                rows.append(dict(case=name, seed=seed, **r))
    return rows


def write_csv(path, rows):
    merge_rows(path, rows)  # added to the rows of earlier runs


def mean_se(values):
    values = [float(v) for v in values]
    return statistics.mean(values), statistics.stdev(values) / len(values) ** 0.5


def summarize(walls, gravity, compare, out):
    lines = []
    for case in ("walls-smooth", "walls-rough"):
        rs = [r for r in walls if r["case"] == case]
        m, e = mean_se(r["phi_j"] for r in rs)
        dev = max(abs(r["P_wall_lo"] / r["P_wall_hi"] - 1) for r in rs)
        vir = max(abs(r["P_yy"] / r["P_wall_hi"] - 1) for r in rs)
        iso = sum(r["N_c"] == r["N_c_iso"] for r in rs)
        lines.append(f"{case}: {len(rs)} packings, phi_J = {m:.5f} +- {e:.5f}; max |F| (non-floaters, walls incl.) "
                     f"<= {max(r['max_force_nonfloaters'] for r in rs):.2e}; |P_lo/P_hi - 1| <= {dev:.1e}; "
                     f"|P_yy/P_wall - 1| <= {vir:.1e}; isostatic (N_c = N_c,iso, wall contacts counted) {iso}/{len(rs)}; "
                     f"excess N_c - iso in [{min(r['N_c'] - r['N_c_iso'] for r in rs)}, {max(r['N_c'] - r['N_c_iso'] for r in rs)}]; "
                     f"median CPU {statistics.median(float(r['cpu_s']) for r in rs):.2f} s")
    m, e = mean_se(r["phi_pile"] for r in gravity)
    lines.append(f"gravity g = {gravity[0]['g']:g}: {len(gravity)} packings, phi_pile = {m:.4f} +- {e:.4f}; max |F| (all, "
                 f"weight incl.) <= {max(r['max_force_all'] for r in gravity):.2e}; |floor/weight - 1| <= "
                 f"{max(abs(r['floor_over_weight_minus_1']) for r in gravity):.1e}; ceiling force = "
                 f"{max(abs(r['ceiling_force']) for r in gravity):g}; profile vs weight above <= "
                 f"{max(r['profile_max_rel_dev'] for r in gravity):.1e} (relative to the bottom stress); "
                 f"K = sigma_xx/sigma_zz (mid-height median) {statistics.mean(r['K_mid'] for r in gravity):.3f}; "
                 f"N_c - N_c,iso in [{min(r['N_c'] - r['N_c_iso'] for r in gravity)}, {max(r['N_c'] - r['N_c_iso'] for r in gravity)}], "
                 f"floaters {sum(r['floaters'] for r in gravity)}; median CPU {statistics.median(float(r['cpu_s']) for r in gravity):.2f} s")
    for target in (1e-4, 1e-6):
        rs = [r for r in compare if r["case"] == "iso from 1e-4" and r["target"] == target]
        lines.append(f"pressure {target:g} (iso, from 1e-4): {len(rs)} packings, max |P/P_target - 1| = "
                     f"{max(abs(r['P_rel_error']) for r in rs):.1e}; max |F| (non-floaters) <= "
                     f"{max(r['max_force_nonfloaters'] for r in rs):.2e}; all converged by force: "
                     f"{all(r['reason'] == 'force' for r in rs)}")
    comp = {int(r["seed"]): r for r in compare if r["case"] == "compression"}
    m, e = mean_se(r["phi"] for r in comp.values())
    lines.append(f"compression (fast protocol): phi_J = {m:.5f} +- {e:.5f}; |P_xy|/P = "
                 f"{statistics.mean(r['shear_over_P'] for r in comp.values()):.4f} mean "
                 f"(max {max(r['shear_over_P'] for r in comp.values()):.4f}); N_c - iso in "
                 f"[{min(r['N_c'] - r['N_c_iso'] for r in comp.values())}, {max(r['N_c'] - r['N_c_iso'] for r in comp.values())}]")
    phi_j = {"compression": [float(comp[s]["phi"]) for s in sorted(comp)]}
    for name in SEQUENCES:
        per_seed = {}
        for r in compare:
            if r["case"] == name:
                per_seed.setdefault(int(r["seed"]), []).append((r["target"], float(r["phi"]), r))
        est = {s: extrapolate_phi_j([t for t, _, _ in v], [f for _, f, _ in v], 2.0) for s, v in per_seed.items()}
        low = {s: v[-1][1] for s, v in per_seed.items()}
        shear = [v[-1][2]["shear_over_P"] for v in per_seed.values()]
        m, e = mean_se(est.values())
        d = [est[s] - float(comp[s]["phi"]) for s in est]
        dm, de = mean_se(d)
        lines.append(f"{name}: phi_J(P->0) = {m:.5f} +- {e:.5f} (phi at 1e-7: {statistics.mean(low.values()):.5f}); "
                     f"paired phi_J - compression = {dm:+.5f} +- {de:.5f} ({abs(dm) / de:.1f} SE); |P_xy|/P at 1e-7 = "
                     f"{statistics.mean(shear):.2e} mean (max {max(shear):.2e}); converged by force "
                     f"{sum(v[-1][2]['reason'] == 'force' for v in per_seed.values())}/{len(per_seed)}")
        phi_j[name] = [est[s] for s in sorted(est)]
    Path(f"{out}-summary.txt").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return phi_j


def figures(n, out, walls_seed, profiles, compare, phi_j):
    from jamflow.plots.walls import plot_packing, plot_phi_pressure, plot_profile

    shots = [("smooth walls on y", dict(walls="y")), ("rough walls on y", dict(walls="y", wall_type="rough")),
             ("closed box, smooth walls", dict(walls="x,y")), ("gravity 1e-5 on a floor", dict(walls="y", gravity=1e-5))]
    for k, (title, kw) in enumerate(shots):
        res = jam(n=n, sizes=SIZES, seed=walls_seed, **kw)
        label = f"N = {n}, seed {walls_seed}, {title}: phi = {res.phi_j:.4f}"
        plot_packing(res.packing, f"{out}-packing-{k}.png", label)
    z = profiles[0].heights
    szz = np.mean([np.interp(z, p.heights, p.sigma_zz) for p in profiles], axis=0)
    sxx = np.mean([np.interp(z, p.heights, p.sigma_xx) for p in profiles], axis=0)
    plot_profile(profiles[0], f"{out}-profile.png", f"gravity g = 1e-5, N = {n}: seed 0 (points), "
                 f"{len(profiles)} starts (lines)", mean=(z, szz, sxx))
    rows = [r for r in compare if r["case"] == "iso from 1e-2"]
    seeds = sorted({int(r["seed"]) for r in rows})
    pressures = sorted({r["target"] for r in rows}, reverse=True)
    phis = np.array([[float(r["phi"]) for r in rows if int(r["seed"]) == s] for s in seeds])
    bands = {r"$\phi_J$ compression": phi_j["compression"],
             **{rf"$\phi_J(P\to 0)$ {name}": phi_j[name] for name in SEQUENCES}}
    plot_phi_pressure(pressures, phis, phi_j["iso from 1e-2"], bands, f"{out}-phi-pressure.png",
                      f"2D bidisperse N = {n}, {len(seeds)} starts: phi(P), iso sequence from 1e-2 (points); "
                      "phi_J of each protocol (bands)")


def read_csv(path):
    """Rows of a CSV written by ``write_csv``, numbers as floats (seeds as ints)."""
    def value(key, text):
        if key == "seed":
            return int(text)
        try:
            return float(text)
        except ValueError:
            return text
    with open(path, newline="") as fh:
        return [{k: value(k, v) for k, v in row.items()} for row in csv.DictReader(fh)]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=256)
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--gravity", type=float, default=1e-5)
    ap.add_argument("--out", default=str(scratch("walls-gravity-pressure")))
    ap.add_argument("--figures-only", action="store_true",
                    help="redraw the figures from the CSVs (re-settles the gravity piles for the profiles)")
    args = ap.parse_args(argv)
    seeds = list(range(args.seeds))
    if args.figures_only:
        walls, compare = read_csv(f"{args.out}-walls.csv"), read_csv(f"{args.out}-compare.csv")
        gravity, profiles = gravity_rows(args.n, seeds, args.gravity, args.out)
        figures(args.n, args.out, 0, profiles, compare, summarize(walls, gravity, compare, args.out))
        return
    walls = walls_rows(args.n, seeds)
    write_csv(f"{args.out}-walls.csv", walls)
    gravity, profiles = gravity_rows(args.n, seeds, args.gravity, args.out)
    write_csv(f"{args.out}-gravity.csv", gravity)
    compare = compare_rows(args.n, seeds)
    write_csv(f"{args.out}-compare.csv", compare)
    phi_j = summarize(walls, gravity, compare, args.out)
    figures(args.n, args.out, 0, profiles, compare, phi_j)


if __name__ == "__main__":
    main()
