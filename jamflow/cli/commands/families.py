"""Geometric families of small bidisperse disk packings (chapter section 2.2, Figure 2.7): jam
--starts random starts at every strain of a grid, follow each by quasistatic shear at zero
pressure to the neighbouring grid points, and join the segments with one contact network
into families (what identifies a family: see the docs, notes/shear). Writes to DIR:
points.h5 (every static packing met; written after every round of starts, --resume continues
it), families.h5 (family table, count against starts, mirror check), families.csv and
families.png (phi_J(gamma) of all families, the mirror overlay, the convergence)."""

from __future__ import annotations

from pathlib import Path

from jamflow.analysis.families import convergence, join, mirror_by_sightings, mirror_check, richness
from jamflow.cli.options import add_engine_argument, add_force_argument, add_quiet_argument
from jamflow.cli.progress import progress_bar
from jamflow.io.families_file import load_family_points, save_family_points, save_family_table
from jamflow.protocols.families import FamilySampling, sample
from jamflow.support.files import check_writable, lock_directory, output_directory, replacing, write_csv


def add_arguments(p) -> None:
    p.add_argument("--n", type=int, default=10, help="number of disks")
    p.add_argument("--sizes", default="bi:1.4:0.5", help="size spec (jamflow jam --sizes)")
    p.add_argument("--gamma-min", type=float, default=0.0, help="first grid strain")
    p.add_argument("--gamma-max", type=float, default=1.0,
                   help="last grid strain (1: both halves, so the mirror check about 1/2 compares independent samples)")
    p.add_argument("--spacing", type=float, default=0.01, help="Delta gamma between grid points")
    p.add_argument("--substeps", type=int, default=10, help="shear steps between grid points (delta gamma = spacing / substeps)")
    p.add_argument("--starts", type=int, default=20, help="random starts per grid point")
    p.add_argument("--seed", type=int, default=0, help="offset of the random seeds")
    add_engine_argument(p, help="engine for jamming and shear")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory (created if its parent exists)")
    p.add_argument("--resume", action="store_true", help="continue DIR/points.h5 of the same plan")
    add_force_argument(p)
    add_quiet_argument(p)


def plan_from_args(args) -> FamilySampling:
    return FamilySampling(n=args.n, sizes=args.sizes, gamma_min=args.gamma_min, gamma_max=args.gamma_max,
                          spacing=args.spacing, substeps=args.substeps, starts=args.starts, seed=args.seed,
                          engine=args.engine)


def run(args) -> int:
    plan = plan_from_args(args)
    out = Path(args.out)
    if not out.parent.is_dir() or (out.exists() and not out.is_dir()):
        raise ValueError(f"--out {out} must be a directory whose parent exists")
    points_file = out / "points.h5"
    outputs = [points_file] + [out / name for name in ("families.h5", "families.csv", "families.png")]
    for path in outputs if out.is_dir() else []:  # a new directory holds nothing to refuse
        check_writable(path, args.force, "--out")
    if not out.exists():
        check_writable(out, option="--out")  # its parent must be writable: the command makes the directory
    total = plan.starts * len(plan.grid)
    with output_directory(out, "--out"), replacing(outputs if args.force else []):  # an empty new --out is removed on failure
        # one run per directory: a second run into it is refused (it would replace the first's files)
        with lock_directory(out, f"another jamflow families run is writing {out}; wait for it to end (then "
                                 "--resume continues its points.h5) or use another --out"):
            done, failures = _resumed(points_file, plan) if args.resume else (None, [])
            if points_file.exists() and not args.resume:
                raise ValueError(f"{points_file} exists; pass --resume to continue it or choose another --out")
            _sample_and_report(plan, done, failures, points_file, out, total, args.quiet)
    return 0


def _sample_and_report(plan, done, failures, points_file, out, total, quiet) -> None:
    with progress_bar(total=total, desc="families", unit="start", disable=quiet) as bar:
        bar.update(0 if done is None else len(set(done["start"].tolist())) * len(plan.grid))
        points, failures = sample(plan, done=done, failures=failures, observers=[lambda k, s: bar.update(1)],
                                  checkpoint=lambda cols, why: save_family_points(points_file, plan, cols, why))
    report(plan, points, failures, out)


def _resumed(points_file: Path, plan: FamilySampling):
    if not points_file.exists():
        return None, []
    saved, points, failures = load_family_points(points_file, remedy=f"cannot --resume it: delete {points_file} to "
                                                                      "sample afresh, or use another --out")
    mine = {k: str(v) for k, v in plan.as_dict().items() if k != "starts"}
    if {k: str(saved.get(k)) for k in mine} != mine:
        raise ValueError(f"{points_file} was sampled with another plan ({saved}); use another --out")
    return points, failures


def report(plan: FamilySampling, points: dict, failures: list, out: Path) -> None:
    """Join, check, tabulate and draw; print the summary."""
    from jamflow.plots.shear import families_figure

    families = join(points, plan.step, plan.gamma_min)
    conv = convergence(points, plan.step, plan.gamma_min, lo=max(0.0, plan.gamma_min), hi=min(0.5, plan.gamma_max))
    centre = 0.5 * (plan.gamma_min + plan.gamma_max)  # the mirror gamma -> 2 centre - gamma (2 centre an integer)
    both_halves = abs(2 * centre - round(2 * centre)) < 1e-9
    mirror = mirror_check(families, center=centre if both_halves else 0.5)
    rich = richness(families)
    save_family_table(out / "families.h5", plan, families, conv, mirror, rich)
    write_csv(out / "families.csv", families.table())
    families_figure(out / "families.png", families, mirror if both_halves and centre == 0.5 else None, conv, rich,
                    title=f"(a) N = {plan.n} {plan.sizes}: {families.count} geometric families, "
                          f"{plan.starts} starts x {len(plan.grid)} strains")
    print(f"{families.count} families ({families.count_in(0.0, 0.5)} met in [0, 1/2], "
          f"{families.count_in(0.0, 0.5, min_strains=2)} of them over >= 2 strains) from {rich['sampled']} sampled "
          f"packings; Chao1 estimate {rich['chao1']:.0f} +- {rich['chao1_se']:.0f} ({rich['singletons']} found once, "
          f"{rich['doubletons']} twice)")
    print("families (met in [0, 1/2] / anywhere) against starts per grid point: "
          + ", ".join(f"{k}: {c}/{a}" for k, c, a in conv))
    if both_halves:
        for lo, hi in ((centre, plan.gamma_max), (plan.gamma_min, centre)):
            met = families.met_in(lo, hi)
            print(f"mirror gamma -> {2 * centre:g} - gamma: {mirror.matched(met)} of the {len(met)} families met in "
                  f"[{lo:g}, {hi:g}] land on a sampled family")
        rows = mirror_by_sightings(families, mirror, families.met_in(centre, plan.gamma_max))
        print(f"  families met in [{centre:g}, {plan.gamma_max:g}] by how many sampled paths: mirror found / families: "
              + ", ".join(f"{label}: {found}/{total}" for label, total, found in rows))
        print(f"matched families that do not pair up one to one: {len(mirror.unpaired)}; worst |d phi_J| "
              f"{mirror.worst_phi:.1e}, |d Sigma/P| {mirror.worst_mu:.1e} over the matched points")
    print(f"{len(failures)} jams or paths failed (JammingFailed; listed in {out / 'points.h5'}, attribute failures)")
    print(f"-> {out / 'families.h5'}, {out / 'families.csv'}, {out / 'families.png'}")

