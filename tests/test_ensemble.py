"""jamflow ensemble: store, resumability and failure handling on a 2-worker Dask cluster (N = 8-16)."""

import errno
import glob
import os
import re
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from jamflow.ensemble import Store, Task, jam_parameters, run_ensemble, seed_range
from jamflow.ensemble import runner as ensemble_runner
from jamflow.ensemble import tasks as ensemble_tasks
from jamflow.support.files import atomic_path
from jamflow.io.packing_file import load_packing, read_attrs
from jamflow.protocols.outcome import JammingFailed

JAMFLOW = [sys.executable, "-m", "jamflow.cli"]


@pytest.fixture(scope="module")
def cluster():
    """Two single-threaded worker processes, as the default local cluster makes them."""
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0") as lc, \
            Client(lc) as client:
        yield client


@pytest.fixture
def threaded():
    """One in-process worker thread: monkeypatches in this process reach the task."""
    from distributed import Client

    with Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=":0") as client:
        yield client


def packings(directory):
    return sorted(Path(directory).glob("*.h5"))


def debris(directory):
    return glob.glob(f"{directory}/.*.tmp") + glob.glob(f"{directory}/failed/.*.tmp")


def summary_seeds(directory, status="ok"):
    rows = Store(directory).read_summary()
    return sorted((int(r["n"]), int(r["seed"])) for r in rows if r["status"] == status)


# -- bad input, before any work ---------------------------------------------------------------
@pytest.mark.parametrize("seeds, what", [("5:5", "empty"), ("9:3", "reversed"), ("-2:4", "negative"),
                                         ("0-10", "write A:B"),
                                         ("0:9223372036854775808", "past 2\\^63 - 1"),  # was: OverflowError
                                         ("9223372036854775808:9223372036854775809", "past 2\\^63 - 1")])
def test_bad_seed_ranges_are_refused(seeds, what):
    with pytest.raises(ValueError, match=what):
        seed_range(seeds)


def test_unknown_jam_option_is_refused():
    with pytest.raises(ValueError, match="unknown jam option.*colour"):
        jam_parameters(colour="red")


def test_store_made_by_other_parameters_is_refused(tmp_path):
    Store(tmp_path).open(jam_parameters(sizes="mono"), ["n"]).close()
    with pytest.raises(ValueError, match=r"--sizes mono, this run asks bi:1.4:0.5"):
        Store(tmp_path).open(jam_parameters(), ["n"])
    with pytest.raises(ValueError, match=r"--vtol 1e-16, this run asks 1e-15"):
        Store(tmp_path).open(jam_parameters(sizes="mono", vtol=1e-15), ["n"])
    # an option jam gains later: accepted at its default, refused at another value
    later = {**jam_parameters(sizes="mono"), "later_option": 0.0}
    Store(tmp_path).open(later, ["n"], defaults={"later_option": 0.0}).close()
    with pytest.raises(ValueError, match=r"--later-option 0.0, this run asks 0.1"):
        Store(tmp_path).open({**later, "later_option": 0.1}, ["n"], defaults={"later_option": 0.0})
    with pytest.raises(ValueError, match="not an ensemble option"):
        jam_parameters(above=1e-3)


def test_unwritable_directory_is_refused(tmp_path):
    blocker = tmp_path / "plain-file"
    blocker.write_text("")
    with pytest.raises(ValueError, match="cannot write the ensemble store"):
        run_ensemble(blocker / "store", "0:2", 8)
    with pytest.raises(ValueError, match="is a file"):
        run_ensemble(blocker, "0:2", 8)


def test_bad_jam_option_fails_before_work(tmp_path):
    with pytest.raises(ValueError, match="unknown size spec 'banana'"):
        run_ensemble(tmp_path / "s", "0:2", 8, sizes="banana")
    assert not (tmp_path / "s").exists()


def test_unreachable_scheduler_fails_within_seconds(tmp_path):
    with socket.socket() as s:  # a loopback port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    t0 = time.monotonic()
    with pytest.raises(ValueError, match=f"cannot reach the Dask scheduler at tcp://127.0.0.1:{port}"):
        run_ensemble(tmp_path / "s", "0:2", 8, scheduler=f"tcp://127.0.0.1:{port}")
    assert time.monotonic() - t0 < 15


# -- the store on a 2-worker cluster ----------------------------------------------------------
def test_ensemble_writes_checked_packings_and_a_rebuildable_summary(tmp_path, cluster):
    out = tmp_path / "store"
    report = run_ensemble(out, "0:5", [8, 12], client=cluster, progress=False)
    assert (report.made, report.failed, report.errors) == (10, 0, [])
    assert [p.name for p in packings(out)][:2] == ["n12_seed000000.h5", "n12_seed000001.h5"]
    rows = Store(out).read_summary()
    assert len(rows) == 10 and all(r["in_window"] == "True" and r["balanced"] == "True" for r in rows)
    for row in rows:  # the row is the file's content
        attrs = read_attrs(out / row["file"])
        assert float(row["phi_j"]) == attrs["phi_j"] and float(row["phi"]) == attrs["phi"]  # phi_j: what jam reports
        assert float(row["phi_j"]) == pytest.approx(attrs["phi"], rel=1e-14) and int(row["seed"]) == attrs["seed"] == load_packing(
            out / row["file"]).metadata["seed"]
        assert 1e-16 < float(row["V"]) < 2e-16 and row["engine"] == "numba" and float(row["seconds"]) > 0
    before = (out / "summary.csv").read_text()
    (out / "summary.csv").unlink()
    Store(out).rebuild_summary()
    assert _without_mtimes(before) == _without_mtimes((out / "summary.csv").read_text())
    again = run_ensemble(out, "0:5", [8, 12], client=cluster, progress=False)  # a rerun does nothing
    assert (again.done_before, again.made) == (10, 0)


def _without_mtimes(text):
    return [line.rsplit(",", 1)[0] for line in text.splitlines()]


def test_corrupt_and_partial_files_are_detected_and_redone(tmp_path, cluster):
    out = tmp_path / "store"
    run_ensemble(out, "0:4", 8, client=cluster, progress=False)
    victim, garbage = out / "n8_seed000001.h5", out / "n8_seed000002.h5"
    data = victim.read_bytes()
    victim.write_bytes(data[: len(data) // 2])  # a truncated copy
    garbage.write_bytes(b"not hdf5")
    (out / ".n8_seed000003.h5.abc.tmp").write_bytes(b"left by a killed task")
    report = run_ensemble(out, "0:4", 8, client=cluster, progress=False)
    assert (report.done_before, report.made, len(report.corrupt)) == (2, 2, 2)
    assert len(packings(out)) == 4 and not debris(out)
    assert len(list((out / "corrupt").iterdir())) == 2
    assert summary_seeds(out) == [(8, s) for s in range(4)]


def test_killed_worker_loses_nothing(tmp_path, cluster, monkeypatch):
    """SIGKILL one worker process while it runs a task: the task is redone elsewhere and the run
    counts the worker lost. The runner counts a worker lost when an address it listed at one poll
    (workers_state) is gone at a later one, so the kill picks a busy worker the runner has listed
    and then waits until the scheduler has removed it: the order that made this test flaky
    (warm workers gave the first result, and the kill, before the runner's first poll; when the
    scheduler removed the worker before the next poll, it was never counted) now happens every run."""
    out = tmp_path / "store"
    listed, killed = set(), []
    polled = ensemble_runner.workers_state

    def listing(client):
        state = polled(client)
        listed.update(state or ())
        return state

    def kill_a_busy_worker(task, row, client):
        if killed:
            return
        busy = [w for w, keys in client.processing().items() if keys and w in listed]
        if not busy:
            return  # the runner has not listed a busy worker yet: try at the next result
        pid = client.run(os.getpid, workers=busy[:1])[busy[0]]
        os.kill(pid, signal.SIGKILL)
        killed.append(pid)
        deadline = time.monotonic() + 60
        while busy[0] in (polled(client) or busy[:1]) and time.monotonic() < deadline:
            time.sleep(0.02)
        assert busy[0] not in (polled(client) or busy[:1]), "the scheduler kept the killed worker for 60 s"

    monkeypatch.setattr(ensemble_runner, "workers_state", listing)
    report = run_ensemble(out, "0:12", 12, client=cluster, progress=False, on_result=kill_a_busy_worker)
    assert killed and report.workers_lost >= 1
    assert (report.made, report.failed, report.errors) == (12, 0, [])
    assert summary_seeds(out) == [(12, s) for s in range(12)] and len(packings(out)) == 12 and not debris(out)
    cluster.wait_for_workers(2, timeout=60)  # the nanny restarts the worker for the next test


def test_failed_packing_is_recorded_and_not_retried(tmp_path, threaded, monkeypatch):
    calls = []
    real = ensemble_tasks.run_jam

    def failing_for_seed_2(spec, **options):
        calls.append(spec.seed)
        if spec.seed == 2:
            raise JammingFailed("no packing in the window (injected)")
        return real(spec, **options)

    monkeypatch.setattr(ensemble_tasks, "run_jam", failing_for_seed_2)
    out = tmp_path / "store"
    report = run_ensemble(out, "0:4", 8, client=threaded, progress=False)
    assert (report.made, report.failed) == (3, 1)
    assert "injected" in (out / "failed" / "n8_seed000002.json").read_text()
    failed = [r for r in Store(out).read_summary() if r["status"] == "failed"]
    assert [(r["seed"], "injected" in r["reason"]) for r in failed] == [("2", True)]
    calls.clear()
    again = run_ensemble(out, "0:4", 8, client=threaded, progress=False)
    assert calls == [] and (again.done_before, again.failed) == (3, 1)
    run_ensemble(out, "0:4", 8, client=threaded, progress=False, retry_failed=True)
    assert calls == [2]


def test_full_disk_stops_cleanly_and_a_rerun_finishes(tmp_path, monkeypatch):
    """OSError(ENOSPC) in the writer after its temporary file exists: the run stops, finished
    packings are intact, the temporary file is gone; a rerun with space finishes. Two worker
    threads: when the first write fails the other task is still running; the run must wait for
    it (a cancelled Dask task runs on) before it cleans the store and returns, so nothing of
    the run writes into the store afterwards."""
    from distributed import Client

    real, saved, failures = ensemble_tasks.save_jam_result, [], []

    def disk_fills_after_three(path, result, checks, **info):
        if len(saved) >= 3:
            with atomic_path(path) as tmp:
                tmp.write_bytes(b"half a packing")
                failures.append(path)
                time.sleep(0 if len(failures) == 1 else 1.0)
                raise OSError(errno.ENOSPC, "No space left on device", str(tmp))
        saved.append(path)
        return real(path, result, checks, **info)

    monkeypatch.setattr(ensemble_tasks, "save_jam_result", disk_fills_after_three)
    out = tmp_path / "store"
    with Client(processes=False, n_workers=1, threads_per_worker=2, dashboard_address=":0") as two_threads:
        report = run_ensemble(out, "0:8", 8, client=two_threads, progress=False)
        assert "the disk is full" in report.stopped and "rerun" in report.stopped
        assert report.made == 3 and len(packings(out)) == 3 and not debris(out)
        writes_at_return = len(failures)
        time.sleep(1.5)  # a task of the run still going would write now
        assert len(failures) == writes_at_return and not debris(out) and len(packings(out)) == 3
        for path in packings(out):
            load_packing(path)
        monkeypatch.setattr(ensemble_tasks, "save_jam_result", real)
        again = run_ensemble(out, "0:8", 8, client=two_threads, progress=False)
        assert (again.done_before, again.made, again.stopped) == (3, 5, "")


# -- the command line: Ctrl-C and a scheduler in its own process -------------------------------
def test_ctrl_c_then_rerun_gives_every_packing_once(tmp_path):
    out = tmp_path / "store"
    cmd = JAMFLOW + ["ensemble", "--n", "12", "--seeds", "0:24", "--out", str(out), "--workers", "2", "--quiet"]
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while len(packings(out)) < 3 and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.1)
    os.killpg(proc.pid, signal.SIGINT)  # as a terminal's Ctrl-C: the whole process group
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    assert "interrupted" in stdout and "Traceback" not in stderr and not debris(out)
    interrupted_with = len(packings(out))
    assert 3 <= interrupted_with < 24
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    made, before = map(int, re.search(r"24 of 24 packings \((\d+) made now, (\d+) before\)", done.stdout).groups())
    assert made + before == 24 and before >= interrupted_with  # a worker may finish its task as the cluster closes
    assert summary_seeds(out) == [(12, s) for s in range(24)] and len(packings(out)) == 24


def test_scheduler_and_workers_in_separate_processes(tmp_path):
    """`dask scheduler` and `dask worker` started on loopback, as a cluster job would."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    dask = str(Path(sys.executable).with_name("dask"))
    scheduler = subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    worker = subprocess.Popen([dask, "worker", address, "--nworkers", "1", "--nthreads", "1", "--no-dashboard",
                               "--host", "127.0.0.1"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        result = subprocess.run(JAMFLOW + ["ensemble", "--n", "8", "--seeds", "0:3", "--out", str(tmp_path / "s"),
                                           "--scheduler", address, "--quiet"], capture_output=True, text=True, timeout=120)
        assert result.returncode == 0, result.stderr
        assert "3 of 3 packings" in result.stdout and len(packings(tmp_path / "s")) == 3
    finally:
        for proc in (worker, scheduler):
            proc.terminate()
            proc.wait(timeout=30)


def test_task_names_round_trip():
    from jamflow.ensemble.store import task_from_name

    task = Task((("n", 1024),), 17)
    assert task.name == "n1024_seed000017.h5" and task_from_name(task.stem, ["n"]) == task


def test_file_holding_another_task_is_not_accepted(tmp_path, cluster):
    out = tmp_path / "store"
    run_ensemble(out, "0:2", 8, client=cluster, progress=False)
    os.replace(out / "n8_seed000000.h5", out / "n8_seed000001.h5")  # seed 0's packing under seed 1's name
    with h5py.File(out / "n8_seed000001.h5", "r") as f:
        assert int(f.attrs["seed"]) == 0
    report = run_ensemble(out, "0:2", 8, client=cluster, progress=False)
    assert (report.made, len(report.corrupt)) == (2, 1)
    assert [int(read_attrs(p)["seed"]) for p in packings(out)] == [0, 1]
    assert np.isfinite(float(Store(out).read_summary()[0]["phi_j"]))


def test_packings_on_two_mpi_ranks_each(tmp_path):
    """--mpi-ranks 2: every task runs the controller on LAMMPS over 2 ranks (mpirun) and matches
    the one-process LAMMPS packing of the same seed to round-off of phi."""
    import mpi4py  # noqa: F401  (the test extra installs it: not skipped)
    from distributed import Client

    from jamflow import jam

    with Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=":0") as client:
        report = run_ensemble(tmp_path / "s", "0:1", 32, client=client, progress=False, mpi_ranks=2, engine="lammps")
    assert (report.made, report.errors) == (1, [])
    row = Store(tmp_path / "s").read_summary()[0]
    assert row["engine"] == "lammps" and row["balanced"] == "True"
    assert float(row["phi_j"]) == pytest.approx(jam(n=32, seed=0, engine="lammps").phi_j, abs=1e-9)


def test_mpi_ranks_need_the_lammps_engine(tmp_path):
    with pytest.raises(ValueError, match="add --engine lammps"):
        run_ensemble(tmp_path / "s", "0:1", 8, mpi_ranks=2)


def test_jam_command_does_not_import_dask():
    code = ("import sys, jamflow.cli.app; jamflow.cli.app.build_parser(); import jamflow.cli.commands.jam, jamflow.ensemble; "
            "print('distributed' in sys.modules, 'dask' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.stdout.split() == ["False", "False"], out.stderr


def test_a_damaged_manifest_is_bad_input_not_a_bug(tmp_path):
    """A store whose ensemble.json is not valid JSON: one line naming it, exit 2 (was: a
    JSONDecodeError traceback once ValueErrors from outside jamflow count as bugs)."""
    out = tmp_path / "store"
    out.mkdir()
    (out / "ensemble.json").write_text('{"schema": "jamflow.ens')
    done = subprocess.run([*JAMFLOW, "ensemble", "--seeds", "0:2", "--n", "8", "--out", str(out), "--workers", "1"],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2, done.stderr
    assert "ensemble.json is not a valid jamflow ensemble manifest: damaged JSON" in done.stderr
    assert "Traceback" not in done.stderr


# -- a huge seed range streams ----------------------------------------------------------------
def test_a_huge_seed_range_streams_in_chunks(tmp_path, monkeypatch, threaded):
    """Was: `--seeds 0:1000000000` built every task (and classified them all) before the first
    packing: ~140 MB/s of memory and no output. Now tasks are made CHUNK at a time."""
    from jamflow.ensemble.store import Store as StoreClass

    sizes, real = [], StoreClass.classify

    def recording(self, tasks, *args, **kwargs):
        sizes.append(len(tasks))
        return real(self, tasks, *args, **kwargs)

    def stop_after_three(task, row, client):
        made.append(task.seed)
        if len(made) == 3:
            raise KeyboardInterrupt  # as Ctrl-C: the run stops, keeps what it made

    made = []
    monkeypatch.setattr(StoreClass, "classify", recording)
    monkeypatch.setattr(ensemble_runner, "CHUNK", 4)
    report = run_ensemble(tmp_path / "s", "0:1000000000", 8, client=threaded, progress=False,
                          on_result=stop_after_three)
    assert report.requested == 1_000_000_000 and report.interrupted
    assert sizes and max(sizes) <= 4  # never the whole range
    assert len(packings(tmp_path / "s")) >= 3  # (a task running at the interrupt may still be writing)


# -- a script without the __main__ guard ---------------------------------------------------------
ENSEMBLE_SCRIPT = '''import jamflow

{guard}report = jamflow.run_ensemble("store", "0:1", [8], workers=1, dim=2, progress=False)
{indent}print("made", report.made)
'''


def run_script(tmp_path, guarded):
    """Run the ensembles guide's run_ensemble snippet as a script (python script.py), guarded or not."""
    script = tmp_path / "ensemble_script.py"
    script.write_text(ENSEMBLE_SCRIPT.format(guard='if __name__ == "__main__":\n    ' if guarded else "",
                                             indent="    " if guarded else ""))
    env = {**os.environ, "PYTHONPATH": str(Path(ensemble_runner.__file__).parents[2])}
    return subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=300)


def test_a_script_without_the_main_guard_is_told_to_add_it(tmp_path):
    """Was: the Dask worker re-imported the script, ran the ensemble again and died on the store's
    lock ("DirectoryLocked: another jamflow ensemble is writing store"), then "Nanny failed to
    start". Now the worker stops at the call with one line naming the guard."""
    done = run_script(tmp_path, guarded=False)
    assert done.returncode != 0 and "made" not in done.stdout
    lines = done.stderr.splitlines()
    assert ('jamflow: jamflow.run_ensemble was called again while a worker process imported '
            f'{tmp_path / "ensemble_script.py"}: put the call under if __name__ == "__main__":') in "\n".join(lines)
    assert "DirectoryLocked" not in done.stderr and "another jamflow ensemble is writing" not in done.stderr
    assert lines[-1].startswith("RuntimeError: the local Dask cluster's worker processes failed to start")


def test_a_guarded_script_runs_its_ensemble(tmp_path):
    done = run_script(tmp_path, guarded=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["made", "1"] and "called again" not in done.stderr
