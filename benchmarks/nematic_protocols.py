"""Nematic order P2 of jammed monodisperse ellipses at alpha = 3 made by several protocols (the chapter's
section 4.3, Figure 2.23(c, d): "two different packing-generation methods", one giving roughly
aligned ellipses with P2 = 0.64, the other randomly oriented ones with P2 = 0.11, N = 256).

    flock /tmp/jamflow-bench.lock python benchmarks/nematic_protocols.py --n 64 --alpha 3 --seeds 10 \
        --protocol compression --out docs/notes/nematic-protocols.csv --keep /tmp/nematic
    flock /tmp/jamflow-bench.lock python benchmarks/nematic_protocols.py --n 64 --alpha 3 --seeds 5 \
        --protocol anneal --dalpha 0.1 --out docs/notes/nematic-protocols.csv --keep /tmp/nematic
    python benchmarks/nematic_protocols.py --report docs/notes/nematic-protocols.csv --keep /tmp/nematic

``--orientations aligned``: every director along x at the start (compression) or at
the first annealing step; ``--phi0``: the compression's start packing fraction. Both go into
the protocol label (e.g. "compression aligned phi0=0.5").

``compression``: ``jam(shape="ellipse:ALPHA", sizes="mono", seed=s)``, isotropic compression from a
random start with orientations uniform on the circle. ``anneal``: seed s jams monodisperse disks,
then ``jamflow.protocols.anneal.anneal`` grows alpha to ALPHA in steps of DALPHA (random
major-axis directions at the first step, re-jammed at each step). Default protocol, compiled FIRE,
exact contact distance. One row per final packing (``anneal_vs_compression``'s columns; CPU
seconds of the whole protocol), written as it finishes; a done (protocol, dalpha, seed) is
skipped. ``--keep``: the final packings as HDF5 (``--report`` draws, per protocol, the packing nearest its median P2).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from jamflow import jam
from jamflow.mechanics.checks import check_packing
from jamflow.io.packing_file import load_packing, save_packing
from jamflow.model.shapes.rotations import check_start
from jamflow.protocols.anneal import anneal
from jamflow.protocols.settings import DEFAULT_PROTOCOL, PROTOCOLS

from common import ANNEAL_COLUMNS as COLUMNS, anneal_row as _row, pyplot, read_rows, save_figure, scratch, stats, write_rows  # (benchmarks/ is the script's directory)

SIZES = "mono"
FIGURE_C, FIGURE_D = 0.64, 0.11  # the chapter's P2 of Figure 2.23(c) (roughly aligned) and (d) (random)


def label(protocol: str, orientations: str = "random", phi0: float | None = None,
          jam_protocol: str = DEFAULT_PROTOCOL) -> str:
    """The protocol column: the protocol, then its start and compression settings if not the default."""
    return " ".join([protocol] + ([orientations] if orientations != "random" else [])
                    + ([f"phi0={phi0:g}"] if phi0 is not None else [])
                    + ([jam_protocol] if jam_protocol != DEFAULT_PROTOCOL else []))


def one(protocol: str, n: int, alpha: float, seed: int, dalpha: float, orientations: str = "random",
        phi0: float | None = None, jam_protocol: str = DEFAULT_PROTOCOL):
    """(row, final packing) of one protocol run."""
    t = time.process_time()
    if protocol == "compression":
        settings = PROTOCOLS[jam_protocol](phi0=phi0)
        packing = jam(n=n, sizes=SIZES, seed=seed, shape=f"ellipse:{alpha:g}", settings=settings,
                      orientations=orientations).packing
    else:
        disks = jam(n=n, sizes=SIZES, seed=seed)
        packing = anneal(disks.packing, alpha, dalpha, seed=seed, orientations=orientations).packing
    cpu = time.process_time() - t
    return _row(label(protocol, orientations, phi0, jam_protocol), dalpha if protocol == "anneal" else 0.0, seed, n, alpha, packing,
                check_packing(packing), cpu), packing


def name(protocol, dalpha, seed) -> str:
    return f"{protocol.replace(' ', '-')}-d{dalpha:g}-seed{seed}.h5"


def run(args) -> None:
    out, keep = Path(args.out), Path(args.keep) if args.keep else None
    if keep:
        keep.mkdir(parents=True, exist_ok=True)
    rows = read_rows(out)
    dalpha = args.dalpha if args.protocol == "anneal" else 0.0
    if args.phi0 is not None and args.protocol == "anneal":
        raise SystemExit("--phi0 is the compression's start; annealing starts from a jammed disk packing")
    if args.jam_protocol != DEFAULT_PROTOCOL and args.protocol == "anneal":
        raise SystemExit("--jam-protocol is the compression's settings; annealing uses the default")
    protocol = label(args.protocol, args.orientations, args.phi0, args.jam_protocol)
    done = {(r["protocol"], float(r["dalpha"]), int(r["seed"])) for r in rows}
    todo = [s for s in range(args.seeds) if (protocol, dalpha, s) not in done]
    for seed in tqdm(todo, desc=f"{protocol} alpha {args.alpha:g}", unit="packing"):
        row, packing = one(args.protocol, args.n, args.alpha, seed, dalpha, args.orientations, args.phi0,
                           args.jam_protocol)
        if keep:
            save_packing(keep / name(protocol, dalpha, seed), packing)
        rows.append(row)
        write_rows(out, rows, COLUMNS)


def start_order(protocol: str) -> float | None:
    """The start's nematic order S of a default compression label: 0 for the random start, 1
    for aligned, S for nematic:S; None for any other protocol."""
    words = protocol.split()
    if words[0] != "compression" or len(words) > 2 or not (len(words) == 1 or words[1] == "aligned"
                                                          or words[1].startswith("nematic:")):
        return None
    return 0.0 if len(words) == 1 else check_start(words[1])


def order_curve(groups):
    """Rows (S, P2, P2 s.e., phi_J, phi_J s.e., packings) of the default compression, by S."""
    curve = []
    for (protocol, _), g in groups.items():
        s = start_order(protocol)
        if s is not None:
            curve.append((s, *stats(r["p2"] for r in g)[:2], *stats(r["phi_j"] for r in g)))
    return sorted(curve)


def start_for(curve, target: float) -> float | None:
    """The start order S at which the measured mean P2 crosses ``target`` (linear interpolation
    between the neighbouring measured S), None if no pair brackets it."""
    for (s0, p0, *_), (s1, p1, *_) in zip(curve, curve[1:]):
        if (p0 - target) * (p1 - target) <= 0 and p0 != p1:
            return s0 + (target - p0) * (s1 - s0) / (p1 - p0)
    return None


def report(path: Path, keep: Path | None, draw=()) -> None:
    rows = read_rows(path)
    groups = {}
    for r in rows:
        groups.setdefault((r["protocol"], float(r["dalpha"])), []).append(r)
    print("| protocol | N | alpha | packings | P2 +- s.e. | P2 min .. max | <phi_J> +- s.e. | <z> +- s.e. | "
          "checks passed | median CPU s / packing |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for (protocol, dalpha), g in sorted(groups.items()):
        p2, p2_se, k = stats(r["p2"] for r in g)
        phi, phi_se, _ = stats(r["phi_j"] for r in g)
        z, z_se, _ = stats(r["mean_z"] for r in g)
        text = protocol if not protocol.startswith("anneal") else f"{protocol} (dalpha = {dalpha:g})"
        print(f"| {text} | {g[0]['n']} | {float(g[0]['alpha']):g} | {k} | {p2:.3f} +- {p2_se:.3f} | "
              f"{min(float(r['p2']) for r in g):.3f} .. {max(float(r['p2']) for r in g):.3f} | {phi:.4f} +- {phi_se:.4f} | "
              f"{z:.3f} +- {z_se:.3f} | {sum(r['checks_passed'] == 'True' for r in g)}/{k} | "
              f"{np.median([float(r['cpu_seconds']) for r in g]):.0f} |")
    keys = sorted(groups)
    if len(keys) == 2:
        (a, sa, _), (b, sb, _) = (stats(r["p2"] for r in groups[k]) for k in keys)
        print(f"\n{keys[1][0]} - {keys[0][0]}: P2 {b - a:+.3f} +- {np.hypot(sa, sb):.3f}; "
              f"1/sqrt(N) = {1 / np.sqrt(int(rows[0]['n'])):.3f}")
    curve = order_curve(groups)
    if len(curve) > 1:
        print("\nstart S -> jammed P2 +- s.e., phi_J +- s.e. (packings)")
        for s, p2, p2_se, phi, phi_se, k in curve:
            print(f"  S = {s:g}: P2 = {p2:.3f} +- {p2_se:.3f}, phi_J = {phi:.4f} +- {phi_se:.4f} ({k})")
        found = start_for(curve, FIGURE_C)
        print(f"  P2 = {FIGURE_C} (Figure 2.23(c)) at S = " + ("none bracketed" if found is None else f"{found:.3f}"))
    chart(groups, keep, path.with_suffix(".png"), curve, draw)


def tick(protocol: str) -> str:
    """A short axis label of a protocol label: the start, "random" for the plain compression."""
    return protocol.replace("compression", "", 1).strip() or "random"


def _median_row(rows):
    """The packing whose P2 is nearest the group's median (the one drawn)."""
    median = np.median([float(r["p2"]) for r in rows])
    return min(rows, key=lambda r: abs(float(r["p2"]) - median))


def chart(groups, keep, path: Path, curve=(), draw=()) -> None:
    from jamflow.plots.drawing import draw_into

    plt = pyplot()
    keys = sorted(groups)
    typical = [(k, _median_row(groups[k])) for k in keys if not draw or k[0] in draw] if keep else []
    drawn = [(k, r) for k, r in typical if (keep / name(k[0], k[1], int(r["seed"]))).exists()]  # the kept ones
    extra = len(curve) > 1
    fig, axes = plt.subplots(1, 1 + extra + len(drawn), figsize=(4.2 * (1 + extra + len(drawn)), 4.2))
    axes = np.atleast_1d(axes)
    if extra:
        order_panel(axes[1], curve)
    for x, k in enumerate(keys):
        p2 = [float(r["p2"]) for r in groups[k]]
        m, se, _ = stats(p2)
        axes[0].plot(np.full(len(p2), x) + np.linspace(-0.1, 0.1, len(p2)), p2, "o", alpha=0.6)
        axes[0].errorbar([x + 0.25], [m], yerr=[se], fmt="s", color="k", capsize=3)
    n = int(next(iter(groups.values()))[0]["n"])
    axes[0].axhline(1 / np.sqrt(n), ls=":", color="gray", lw=0.8, label=r"$1/\sqrt{N}$")
    for value, text in ((FIGURE_C, "Fig. 2.23(c)"), (FIGURE_D, "Fig. 2.23(d)")):
        axes[0].axhline(value, ls="--", color="tab:red", lw=0.8)
        axes[0].text(len(keys) - 0.6, value + 0.01, text, color="tab:red", fontsize=7)
    axes[0].set_xticks(range(len(keys)), [tick(k[0]) + (f" dalpha {k[1]:g}" if k[1] else "") for k in keys],
                       fontsize=7, rotation=40, ha="right")
    axes[0].set_xlim(-0.5, len(keys) - 0.3)
    axes[0].set_ylim(0, 1)
    axes[0].set_ylabel("nematic order $P_2$")
    axes[0].legend(fontsize=8)
    for ax, (k, r) in zip(axes[1 + extra:], drawn):
        packing = load_packing(keep / name(k[0], k[1], int(r["seed"])))
        draw_into(ax, packing, color_by="orientation", contacts=False)
        ax.set_title(f"{k[0]}, seed {r['seed']}: $P_2$ = {float(r['p2']):.2f}", fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle(f"monodisperse ellipses, alpha = {float(r['alpha']) if drawn else 3:g}, N = {n} (cf. chapter Figure 2.23(c, d))")
    save_figure(fig, path)


def order_panel(ax, curve) -> None:
    """Jammed P2 (left axis) and phi_J (right axis) against the start's order S, with s.e."""
    s, p2, p2_se, phi, phi_se, _ = (np.array(c, float) for c in zip(*curve))
    ax.errorbar(s, p2, yerr=p2_se, fmt="o-", color="k", capsize=3, label="jammed $P_2$")
    ax.plot([0, 1], [0, 1], ":", color="gray", lw=0.8, label="start $P_2$ = S")
    ax.axhline(FIGURE_C, ls="--", color="tab:red", lw=0.8)
    ax.set_xlabel("start nematic order S (--orientations nematic:S)")
    ax.set_ylabel("nematic order $P_2$")
    ax.set_xlim(-0.05, 1.05)
    ax.set_ylim(0, 1)
    ax.legend(fontsize=7, loc="upper left")
    twin = ax.twinx()
    twin.errorbar(s, phi, yerr=phi_se, fmt="s--", color="tab:blue", capsize=3, ms=4)
    twin.set_ylabel(r"$\phi_J$", color="tab:blue")


def main(argv=None) -> None:
    import argparse

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--alpha", type=float, default=3.0)
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--protocol", choices=("compression", "anneal"), default="compression")
    ap.add_argument("--dalpha", type=float, default=0.1)
    ap.add_argument("--orientations", default="random",
                    help="directors at the start (compression) or the first annealing step: random, aligned "
                         "or nematic:S (jamflow jam --orientations)")
    ap.add_argument("--jam-protocol", choices=sorted(PROTOCOLS), default=DEFAULT_PROTOCOL,
                    help="compression: its settings (jamflow jam --protocol; default the fast one)")
    ap.add_argument("--phi0", type=float, default=None, help="compression: start packing fraction (default 0.8)")
    ap.add_argument("--out", default=str(scratch("nematic-protocols.csv")))
    ap.add_argument("--keep", default=None, help="directory of the final packings (HDF5)")
    ap.add_argument("--report", default=None, metavar="CSV")
    ap.add_argument("--draw", action="append", default=[], metavar="PROTOCOL",
                    help="--report: draw the median packing of this protocol label (repeat; default every kept one)")
    args = ap.parse_args(argv)
    if args.report:
        report(Path(args.report), Path(args.keep) if args.keep else None, args.draw)
    else:
        run(args)


if __name__ == "__main__":
    main()
