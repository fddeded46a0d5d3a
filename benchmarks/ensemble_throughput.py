"""The ensemble's throughput run (docs/notes/ensembles.md): 200 packings at N = 64 on a 2-worker local cluster.

    flock /tmp/jamflow-bench.lock python benchmarks/ensemble_throughput.py --work /tmp/jamflow-ens/throughput

1. `jamflow ensemble --n 64 --seeds 0:200 --workers 2` into a fresh store, timed; every file
   must pass the checks of jamflow.ensemble.checks (energy window, force balance against the
   numpy reference), re-read from the files by --rebuild-summary.
2. The same seeds as a plain loop of `jamflow jam` commands, two at a time (xargs -P 2: both
   cores), timed; phi_J of every seed compared with the ensemble's.
3. Robustness: the same command into another store; after 50 packings one worker process is
   killed (SIGKILL), after 120 the whole process group gets SIGINT (a terminal's Ctrl-C);
   then the same command again. Counts packings, duplicates, and compares phi_J with run 1.

Rows go to docs/notes/ensemble-throughput.csv and docs/notes/ensemble-robustness.csv; `uptime` is recorded.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil
from common import scratch, merge_rows  # (benchmarks/ is the script's directory)

JAMFLOW = [sys.executable, "-m", "jamflow.cli"]


def uptime() -> str:
    return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()


def timed(cmd, **kw):
    """(wall s, CPU s of the whole process tree, stdout). The tree is polled every 0.1 s (Dask
    workers are not reaped into RUSAGE_CHILDREN), so CPU may miss the last 0.1 s of a process."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)
    cpu = {}
    root = psutil.Process(proc.pid)
    while proc.poll() is None:
        try:
            for p in [root] + root.children(recursive=True):
                with contextlib.suppress(psutil.Error):
                    t = p.cpu_times()
                    cpu[p.pid] = t.user + t.system + t.children_user + t.children_system
        except psutil.Error:
            pass
        time.sleep(0.1)
    out, err = proc.communicate()
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"{cmd} failed ({proc.returncode}): {err[-2000:]}")
    return wall, sum(cpu.values()), out


def summary(directory) -> dict:
    with open(Path(directory) / "summary.csv", newline="") as fh:
        return {int(r["seed"]): r for r in csv.DictReader(fh)}


def ensemble_cmd(out, seeds, n):
    return JAMFLOW + ["ensemble", "--n", str(n), "--seeds", f"0:{seeds}", "--out", str(out), "--workers", "2", "--quiet"]


def throughput(work: Path, seeds: int, n: int) -> list[dict]:
    store, loop = work / "ensemble", work / "loop"
    for d in (store, loop):
        shutil.rmtree(d, ignore_errors=True)
    loop.mkdir(parents=True)
    rows = []
    load = uptime()
    wall, cpu, _ = timed(ensemble_cmd(store, seeds, n))
    timed(JAMFLOW + ["ensemble", "--out", str(store), "--rebuild-summary"])
    ens = summary(store)
    ok = sum(r["status"] == "ok" and r["in_window"] == "True" and r["balanced"] == "True" for r in ens.values())
    rows.append(dict(method="jamflow ensemble --workers 2", packings=len(ens), wall_s=round(wall, 1), cpu_s=round(cpu, 1),
                     packings_per_min=round(60 * len(ens) / wall, 1), checks_passed=ok, uptime_before=load,
                     uptime_after=uptime()))
    load = uptime()
    script = (f"{' '.join(JAMFLOW)} jam --n {n} --seed $0 --out {loop}/seed$0.h5 --quiet > /dev/null")
    wall, cpu, _ = timed(["bash", "-c", f"seq 0 {seeds - 1} | xargs -P 2 -I{{}} bash -c '{script}' {{}}"])
    from jamflow.io.packing_file import read_attrs

    same = sum(read_attrs(loop / f"seed{s}.h5")["phi"] == float(ens[s]["phi_j"]) for s in range(seeds))
    rows.append(dict(method="loop of jamflow jam, xargs -P 2", packings=len(list(loop.glob("*.h5"))),
                     wall_s=round(wall, 1), cpu_s=round(cpu, 1),
                     packings_per_min=round(60 * seeds / wall, 1), checks_passed="",
                     same_phi_j_as_ensemble=same, uptime_before=load, uptime_after=uptime()))
    return rows


def robustness(work: Path, seeds: int, n: int, reference: dict) -> list[dict]:
    store = work / "robust"
    shutil.rmtree(store, ignore_errors=True)
    cmd = ensemble_cmd(store, seeds, n)
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    count = lambda: len(list(store.glob("*.h5")))  # noqa: E731
    killed = None
    while proc.poll() is None:
        if killed is None and count() >= seeds // 4:
            workers = [c for c in psutil.Process(proc.pid).children(recursive=True)
                       if "multiprocessing" in " ".join(c.cmdline()) and "resource_tracker" not in " ".join(c.cmdline())]
            killed = workers[0].pid
            os.kill(killed, signal.SIGKILL)
        if killed is not None and count() >= (3 * seeds) // 5:
            os.killpg(proc.pid, signal.SIGINT)
            break
        time.sleep(0.05)
    out, err = proc.communicate(timeout=120)
    at_interrupt = count()
    first = dict(step="run 1: worker SIGKILLed, then Ctrl-C", returncode=proc.returncode, files=at_interrupt,
                 message=out.strip().splitlines()[-1], stderr_lines=len(err.strip().splitlines()), killed_pid=killed)
    wall, cpu, out2 = timed(cmd)
    rows = summary(store)
    seeds_ok = sorted(s for s, r in rows.items() if r["status"] == "ok")
    same = sum(float(rows[s]["phi_j"]) == float(reference[s]["phi_j"]) for s in seeds_ok)
    second = dict(step="run 2: the same command", returncode=0, files=count(), message=out2.strip().splitlines()[0],
                  summary_rows=len(rows), distinct_seeds=len(set(seeds_ok)), same_phi_j_as_clean_run=same,
                  debris=len(list(store.glob(".*.tmp"))))
    return [first, second]


def write(path, rows):
    merge_rows(path, rows)  # added to the rows of earlier runs
    print(open(path).read())


def plot(docs: Path) -> Path:
    """Bar chart of packings per minute from ensemble-throughput.csv."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with open(docs / "ensemble-throughput.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    labels = [r["method"] for r in rows]
    fig, ax = plt.subplots(figsize=(7, 3.2))
    values = [float(r["packings_per_min"]) for r in rows]
    bars = ax.barh(labels, values, color=["C0", "C1"])
    ax.bar_label(bars, fmt="%.3g")
    ax.set_title("packings per minute (wall clock, 2 cores)", fontsize=10)
    ax.set_xlim(0, 1.25 * max(values))
    fig.suptitle(f"{rows[0]['packings']} packings, N = 64, 2D bidisperse (load averages in the CSV)", fontsize=10)
    fig.tight_layout()
    out = docs / "ensemble-throughput.png"
    fig.savefig(out, dpi=110)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--work", default="/tmp/jamflow-ens/throughput", help="scratch directory for the stores")
    ap.add_argument("--seeds", type=int, default=200)
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--docs", default=str(scratch()))
    ap.add_argument("--plot-only", action="store_true", help="only redraw the chart from the CSV")
    args = ap.parse_args(argv)
    if args.plot_only:
        print(plot(Path(args.docs)))
        return
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    rows = throughput(work, args.seeds, args.n)
    write(Path(args.docs) / "ensemble-throughput.csv", rows)
    write(Path(args.docs) / "ensemble-robustness.csv", robustness(work, args.seeds, args.n, summary(work / "ensemble")))
    print(plot(Path(args.docs)))


if __name__ == "__main__":
    main()
