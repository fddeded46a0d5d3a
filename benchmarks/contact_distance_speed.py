"""Speed against accuracy of the contact-distance methods (vectorised numpy).

Writes docs/notes/contact-distance-speed.csv and docs/notes/contact-distance-speed.png.
Run from the repo root:  python benchmarks/contact_distance_speed.py [--n 100000] [--repeat 5]

Speed: evaluations per second of one vectorised call on a batch of n random pairs (uniform
random r_hat and directors, input validation included), best of --repeat runs, one thread of
numpy as configured on this machine. Accuracy: mean and max relative error against "exact" on
that batch; for "exact" itself, against an independent scipy maximisation of the matrix-form
contact function on 300 pairs. "exact (maximiser)" is the generic fallback path
(safeguarded Newton on dh/dlambda) forced where the polynomial would be used, for comparison;
"scipy loop" is that brute-force reference, one pair at a time.
"""

from __future__ import annotations

import argparse
import importlib
import platform
import time
from pathlib import Path

import numpy as np
from scipy.optimize import minimize_scalar

from common import scratch, merge_rows  # (benchmarks/ is the script's directory)

from jamflow.model.shapes import contact_distance

cdm = importlib.import_module("jamflow.model.shapes.contact_distance")
CASES = {
    # name: (dim, a_j / a_i, methods)
    "2D, a_j/a_i = 1.4, alpha = 2": (2, 1.4, ("exact", "cleaver", "linear", "quadratic")),
    "2D, identical, alpha = 2": (2, 1.0, ("exact", "gaussian", "linear", "quadratic")),
    "3D, identical prolate, alpha = 2": (3, 1.0, ("exact", "gaussian", "linear", "quadratic")),
    "3D, a_j/a_i = 1.4, alpha = 2": (3, 1.4, ("exact", "cleaver")),
}
ALPHA = 2.0


def batch(dim, ratio, n, seed=0):
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(3, n, dim))
    r, u_i, u_j = v / np.linalg.norm(v, axis=-1, keepdims=True)
    return (1.0, 1.0 / ALPHA, ratio, ratio / ALPHA, r, u_i, u_j)


def best_time(fn, repeat):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def maximiser_sigma(args):
    p = cdm._validate(*args)
    return cdm._sigma_at(p, cdm._lambda_maximise(p))


def scipy_sigma(a_i, b_i, a_j, b_j, r, u_i, u_j):
    """Independent reference: bounded Brent on the matrix-form contact function."""
    A = lambda a, b, u: (b / 2) ** 2 * np.eye(len(u)) + ((a / 2) ** 2 - (b / 2) ** 2) * np.outer(u, u)  # noqa: E731
    Ai, Aj = A(a_i, b_i, u_i), A(a_j, b_j, u_j)
    res = minimize_scalar(
        lambda t: -t * (1 - t) * r @ np.linalg.solve((1 - t) * Ai + t * Aj, r),
        bounds=(0, 1),
        method="bounded",
        options={"xatol": 1e-14},
    )
    return (-res.fun) ** -0.5


def scipy_batch(args, n):
    a_i, b_i, a_j, b_j, r, u_i, u_j = args
    return np.array([scipy_sigma(a_i, b_i, a_j, b_j, r[k], u_i[k], u_j[k]) for k in range(n)])


def measure(n, repeat):
    rows = []
    for case, (dim, ratio, methods) in CASES.items():
        args = batch(dim, ratio, n)
        exact = contact_distance(*args)
        small = tuple(x[:300] if np.ndim(x) else x for x in args)
        ref_small = scipy_batch(small, 300)
        entries = [(m, lambda m=m: contact_distance(*args, method=m)) for m in methods]
        entries.append(("exact (maximiser)", lambda: maximiser_sigma(args)))
        for name, fn in entries:
            dt = best_time(fn, repeat)
            if name.startswith("exact"):
                sig = fn()[:300] if name != "exact" else contact_distance(*small)
                err = np.abs(sig / ref_small - 1)
            else:
                err = np.abs(fn() / exact - 1)
            rows.append(dict(case=case, method=name, n_batch=n, evals_per_s=n / dt, mean_rel_error=err.mean(), max_rel_error=err.max()))
        dt = best_time(lambda: scipy_batch(small, 300), 1)
        rows.append(dict(case=case, method="scipy loop", n_batch=300, evals_per_s=300 / dt, mean_rel_error=0.0, max_rel_error=0.0))
        print(*(f"{r['case']:34s} {r['method']:18s} {r['evals_per_s']:11.3g}/s  mean {r['mean_rel_error']:.2e}  max {r['max_rel_error']:.2e}" for r in rows[-len(entries) - 1 :]), sep="\n")
    return rows


def plot(rows, path, floor=1e-17):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.5, 5))
    ax = fig.add_subplot()
    markers = {"exact": "o", "exact (maximiser)": "s", "gaussian": "^", "cleaver": "v", "linear": "D", "quadratic": "P", "scipy loop": "x"}
    colors = dict(zip(CASES, ("tab:blue", "tab:orange", "tab:green", "tab:red")))
    for r in rows:
        ax.scatter(max(r["mean_rel_error"], floor), r["evals_per_s"], marker=markers[r["method"]], color=colors[r["case"]], s=45)
    for name, mk in markers.items():
        ax.scatter([], [], marker=mk, color="gray", label=name)
    for case, c in colors.items():
        ax.scatter([], [], marker="o", color=c, label=case)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(f"mean relative error vs exact (exact: vs scipy brute force; shown >= {floor:g})")
    ax.set_ylabel("evaluations per second (vectorised numpy)")
    ax.set_title("Contact distance: speed against accuracy (random orientations)", fontsize=10)
    ax.legend(fontsize=7, loc="lower right", ncol=2)
    ax.grid(True, which="major", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=100_000)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--out-dir", type=Path, default=scratch(), help="where the CSV and PNG go (default: the scratch directory)")
    args = ap.parse_args(argv)
    rows = measure(args.n, args.repeat)
    merge_rows(args.out_dir / "contact-distance-speed.csv",
               [{k: (f"{v:.4g}" if isinstance(v, float) else v) for k, v in r.items()} for r in rows],
               comment=f"# {platform.processor() or platform.machine()}, numpy {np.__version__}, python {platform.python_version()}")
    plot(rows, args.out_dir / "contact-distance-speed.png")


if __name__ == "__main__":
    main()
