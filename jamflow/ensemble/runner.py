"""Run an ensemble: every (N, seed) task not yet in the store, one packing per Dask task."""

from __future__ import annotations

import contextlib
import errno
import itertools
import signal
import threading
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path

from jamflow.ensemble.checks import packing_row
from jamflow.ensemble.cluster import WAIT_WORKERS, dask_client, workers_line, workers_state
from jamflow.ensemble.parallel import progress as progress_bar
from jamflow.ensemble.store import Store, Task, failure_row, write_failure
from jamflow.protocols.spec import JamSpec, prepare
from jamflow.support.spawn import refuse_spawned_reimport

TASK_KEYS = ("n", "seed")  # set per task, not store parameters
SUMMARY_EVERY = 10.0  # seconds between summary.csv rewrites during a run
MAX_ERRORS_BEFORE_SUCCESS = 3  # the same broken set-up fails every task: stop early
SETTLED = ("finished", "error", "cancelled")  # future states with an outcome ("lost": being recomputed)
STOP_GRACE = 30.0  # seconds a stopped run waits for the tasks already running (cancelling cannot stop them)
MAX_SEED = 2**63 - 1  # seeds are stored as int64
CHUNK = 256  # tasks classified and submitted at a time (at least 4 per worker thread): memory does not grow with
# the seed range, and Dask stays fast (2000 pending futures: the client grew ~30 MB/s and made half the packings)


@dataclass
class EnsembleReport:
    """What a run did; ``rows`` holds the summary row of every task of the run."""

    directory: Path  #: the store's directory
    requested: int  #: tasks asked for: len(n) x len(seeds)
    done_before: int = 0  #: tasks whose packing the store already held
    made: int = 0  #: packings made by this run
    failed: int = 0  #: recorded failures (JammingFailed or a task that killed its workers), new and old
    errors: list = field(default_factory=list)  #: exceptions not recorded (the task is retried by a rerun)
    corrupt: list = field(default_factory=list)  #: unreadable files moved aside and redone
    workers_lost: int = 0  #: workers that left the scheduler during the run (died or restarted)
    interrupted: bool = False  #: stopped by Ctrl-C (finished packings are kept; a rerun continues)
    stopped: str = ""  #: why the run stopped early (disk full, broken set-up)
    rows: dict = field(default_factory=dict)  #: {task: summary row} of every task of the run


def jam_parameters(**options) -> dict:
    """The store parameters: the fields of ``JamSpec`` (``jamflow jam``'s options and defaults)
    updated with ``options``, without the per-task ``n`` and ``seed``."""
    if options.get("above") is not None:
        raise ValueError("above is not an ensemble option (the store keeps onset packings); run `jamflow jam --above` "
                         "or jamflow.compress_above on them")
    if options.get("precision", "double") != "double":
        raise ValueError("precision double-double is not an ensemble option (the store keeps float64 onset packings); "
                         "refine its packings with `jamflow refine PACKING.h5 --pressure P --out OUT.h5`")
    spec = JamSpec.from_options(**{k: v for k, v in options.items() if k not in TASK_KEYS})
    return {k: v for k, v in spec.as_dict().items() if k not in TASK_KEYS}


def seed_range(seeds) -> range:
    """'A:B' (seeds A to B-1) or a range; refuses empty, reversed and negative ranges."""
    if isinstance(seeds, str):
        try:
            a, b = (int(x) for x in seeds.split(":"))
        except ValueError:
            raise ValueError(f"--seeds {seeds!r}: write A:B, e.g. 0:200 for seeds 0 to 199") from None
        seeds = range(a, b)
    if not isinstance(seeds, range) or seeds.step != 1:
        raise ValueError("seeds must be a range of consecutive seeds, e.g. range(0, 200) or '0:200'")
    if seeds.start < 0 or seeds.stop <= seeds.start:
        raise ValueError(f"seed range {seeds.start}:{seeds.stop} is empty, reversed or negative; "
                         "give A:B with 0 <= A < B, e.g. 0:200")
    if seeds.stop > MAX_SEED:  # a packing file stores its seed as a 64-bit integer
        raise ValueError(f"seed range {seeds.start}:{seeds.stop} goes past 2^63 - 1 = {MAX_SEED} (seeds are 64-bit "
                         f"integers); give A:B with A < B <= {MAX_SEED}")
    return seeds


def run_ensemble(out, seeds, n=(64,), *, workers=None, scheduler=None, client=None, progress=True,
                 retry_failed=False, on_result=None, wait_workers=WAIT_WORKERS, mpi_ranks=1,
                 **jam_options) -> EnsembleReport:
    """Make one packing per (N in ``n``, seed in ``seeds``) into the store ``out``.

    Finished packings are skipped, recorded failures too (unless ``retry_failed``). The
    engine is ``client`` (a distributed.Client), else the scheduler at ``scheduler``, else a
    local cluster of ``workers`` processes (default: all cores). ``on_result(task, row,
    client)`` is called in this process after every finished task. A scheduler without a
    worker after ``wait_workers`` seconds stops the run with an error. ``mpi_ranks`` > 1 runs
    each packing with LAMMPS on that many MPI ranks (needs engine="lammps" and mpi4py).

    Parameters
    ----------
    out : str or os.PathLike
        The store's directory (made when missing; a store of other parameters is refused).
    seeds : range or str
        Consecutive seeds, ``range(A, B)`` or "A:B" (seeds A to B-1, 0 <= A < B < 2^63).
    n : int or iterable of int, default (64,)
        The particle numbers.
    workers : int, optional
        Processes of the local cluster (>= 1; default: all cores); not with ``scheduler`` or ``client``.
    scheduler : str, optional
        The address of a running Dask scheduler.
    client : distributed.Client, optional
        A Dask client to run the tasks on.
    progress : bool, default True
        Show a progress bar.
    retry_failed : bool, default False
        Run again the tasks recorded as failed.
    on_result : callable, optional
        ``on_result(task, row, client)``, called after every finished task.
    wait_workers : float, default 60
        Seconds to wait for a worker of the scheduler before stopping with an error (> 0).
    mpi_ranks : int, default 1
        MPI ranks per packing (> 1: LAMMPS with mpi4py).
    **jam_options
        ``JamSpec`` fields (``jamflow jam``'s options: dim, sizes, potential, shape, engine...),
        the same for every task; not ``above`` or double-double precision.

    Returns
    -------
    EnsembleReport
        Counts of the packings made, found done, failed and redone, and the summary row of
        every task.

    Raises
    ------
    ValueError
        Bad seeds, workers, wait time or jam options (all checked before any work).
    """
    refuse_spawned_reimport("jamflow.run_ensemble")  # before the store's lock, which the parent holds
    seeds = seed_range(seeds)
    sizes = sorted({int(x) for x in ([n] if isinstance(n, int) else n)})
    fixed = jam_parameters(**jam_options)
    if workers is not None and (scheduler is not None or client is not None):
        raise ValueError("--workers sizes the local cluster; with --scheduler the cluster's own workers run the tasks")
    if workers is not None and workers < 1:
        raise ValueError(f"--workers must be at least 1, got {workers}")
    _check_mpi(mpi_ranks, fixed["engine"])
    if not wait_workers > 0:
        raise ValueError(f"--wait-workers must be a positive number of seconds, got {wait_workers}")
    for size in sizes:  # every grid point is validated before any work
        prepare(JamSpec(**fixed, n=size, seed=seeds.start))
    tasks = (Task((("n", size),), seed) for size in sizes for seed in seeds)  # made CHUNK at a time, as needed
    with Store(out).open(fixed, ["n"], defaults=jam_parameters()) as store:
        report = EnsembleReport(store.dir, len(sizes) * (seeds.stop - seeds.start))
        cached, todo = store.summary_rows(), []
        bar = progress_bar(total=report.requested, desc="ensemble", unit="packing", disable=not progress, dynamic_ncols=True)
        try:
            with _interrupt_flag() as interrupted, contextlib.ExitStack() as cluster:
                c = None
                while not (report.stopped or report.interrupted):
                    if interrupted.is_set():
                        report.interrupted = True
                        break
                    chunk = list(itertools.islice(tasks, CHUNK if c is None else max(CHUNK, 4 * _threads(c))))
                    if not chunk:
                        break
                    done, failed, todo, corrupt = store.classify(chunk, fixed, retry_failed, cached)
                    report.done_before += len(done)
                    report.failed += len(failed)
                    report.corrupt += corrupt
                    report.rows.update({**done, **failed})
                    bar.update(len(done) + len(failed))
                    if todo:
                        c = c or cluster.enter_context(dask_client(workers, scheduler, client, wait_workers))
                        _run(c, store, fixed, todo, report, bar, on_result, interrupted, mpi_ranks)
        except KeyboardInterrupt:
            report.interrupted = True
        finally:
            bar.close()
            store.remove_debris()
            _collect_late(store, fixed, todo, report)
            _write_summary(store, report)
    return report


@contextlib.contextmanager
def _interrupt_flag():
    """An Event set by Ctrl-C, which the run loop polls (a KeyboardInterrupt inside Dask's
    event loop would print its tracebacks); a second Ctrl-C interrupts at once."""
    flag = threading.Event()
    if threading.current_thread() is not threading.main_thread():
        yield flag
        return

    def handler(signum, frame):
        if flag.is_set():
            raise KeyboardInterrupt
        flag.set()

    previous = signal.signal(signal.SIGINT, handler)
    try:
        yield flag
    finally:
        signal.signal(signal.SIGINT, previous)


def _collect_late(store, fixed, todo, report):
    """Rows of packings that workers finished after the run stopped listening (interrupt, stop)."""
    for task in todo:
        if task.name not in report.rows and store.packing_path(task).exists():
            try:
                report.rows[task.name] = packing_row(store.packing_path(task), task, fixed)
                report.made += 1
            except (OSError, KeyError, ValueError):
                pass  # an unreadable file is moved aside and redone by the next run


def _run(client, store, fixed, todo, report, bar, on_result, interrupted, mpi_ranks):
    """Make the packings of ``todo`` (one chunk of the run), advancing ``bar`` as they finish."""
    from distributed import wait

    todo = sorted(todo, key=lambda t: (-dict(t.point)["n"], t.seed))  # longest first balances the load
    run_id = uuid.uuid4().hex[:8]
    futures = {client.submit(_make_packing, fixed, task, str(store.packing_path(task)), str(store.failure_path(task)),
                             mpi_ranks, key=f"jam-{task.stem}-{run_id}", pure=False, priority=-k): task
               for k, task in enumerate(todo)}
    pending = set(futures)
    line = progress_bar(bar_format="{desc}", position=1, disable=bar.disable, leave=False)
    bar.set_postfix_str(f"failed={report.failed}, done before={report.done_before}")
    seen = set(workers_state(client) or {})  # worker addresses at the last poll (a worker lost before the first counts)
    last_write = time.monotonic()
    try:
        while pending and not report.stopped:
            if interrupted.is_set():
                report.interrupted = True
                break
            try:
                finished = wait(pending, timeout=1.0, return_when="FIRST_COMPLETED").done
            except TimeoutError:
                finished = set()
            for fut in finished:
                row = _settle(fut, pending, futures, store, fixed, report)
                if row is not None:
                    bar.update(1)
                    if on_result is not None:
                        on_result(futures[fut], row, client)
            processing = workers_state(client)
            if processing is not None:  # a worker gone from the scheduler's list is lost (a restart has a new address)
                report.workers_lost += len(seen - set(processing))
                seen = set(processing)
            line.set_description_str(workers_line(processing, report.workers_lost))
            bar.set_postfix_str(f"failed={report.failed}, errors={len(report.errors)}, done before={report.done_before}")
            if time.monotonic() - last_write > SUMMARY_EVERY:
                _write_summary(store, report)
                last_write = time.monotonic()
    finally:
        if report.stopped and not report.interrupted:
            _drain_running(client, pending, futures, store, fixed, report)
        client.cancel(list(pending))
        line.close()


def _drain_running(client, pending, futures, store, fixed, report):
    """After a stop (disk full, broken set-up): cancel the tasks not started and wait up to
    STOP_GRACE for those running, so none writes a file after the store is cleaned and unlocked."""
    from distributed import wait

    running = set().union(*(workers_state(client) or {}).values())
    started = {fut for fut in pending if fut.key in running}
    client.cancel(list(pending - started))
    pending.intersection_update(started)
    if started:
        with contextlib.suppress(TimeoutError):  # still running after the grace: left to the next run
            wait(started, timeout=STOP_GRACE)
    for fut in started:
        _settle(fut, pending, futures, store, fixed, report)


def _settle(fut, pending, futures, store, fixed, report):
    """Take a done future out of ``pending`` and record its row (returned, or None). Its status
    is read once: a result lost with its worker after wait() returned it turns the future back
    to pending (Dask computes it again), and it stays pending."""
    status = fut.status
    if status not in SETTLED:
        return None
    pending.discard(fut)
    row = _outcome(fut, status, futures[fut], store, fixed, report)
    if row is not None:
        report.rows[row["file"]] = row
    return row


def _threads(client) -> int:
    return sum(client.nthreads().values())


def _check_mpi(ranks, engine):
    if not (isinstance(ranks, int) and ranks >= 1):
        raise ValueError(f"--mpi-ranks must be a positive integer, got {ranks!r}")
    if ranks == 1:
        return
    if engine != "lammps":
        raise ValueError(f"--mpi-ranks {ranks} runs LAMMPS on {ranks} ranks: add --engine lammps (the compiled "
                         "engine is one process)")
    import importlib.util

    if importlib.util.find_spec("mpi4py") is None:
        raise ValueError("--mpi-ranks needs mpi4py: pip install -e '.[mpi]'")


def _make_packing(*args):
    from jamflow.ensemble.tasks import make_packing  # imported on the worker, where the jam runs

    return make_packing(*args)


def _outcome(fut, status, task, store, fixed, report):
    """The row of a finished future; records failures, notes errors, stops the run on a write failure."""
    from distributed.scheduler import KilledWorker

    if status == "finished":
        row = fut.result()  # a result lost since is computed again and waited for
        if row["status"] == "ok":
            report.made += 1
        else:
            report.failed += 1
        return row
    if status == "cancelled":
        return None
    exc = fut.exception()
    if isinstance(exc, KilledWorker):  # the task killed every worker it ran on: record it, do not retry
        write_failure(store.failure_path(task), f"killed the workers that ran it ({exc})", 0.0)
        report.failed += 1
        return failure_row(store.failure_path(task), task, fixed)
    if isinstance(exc, OSError):
        what = "the disk is full" if exc.errno in (errno.ENOSPC, errno.EDQUOT) else "a file could not be written"
        report.stopped = (f"stopped: {what} ({exc}); every finished packing in {store.dir} is intact; "
                          "free space (or fix the directory) and rerun the same command to finish")
        return None
    report.errors.append(f"{task.name}: {type(exc).__name__}: {exc}")
    if report.made == 0 and len(report.errors) >= MAX_ERRORS_BEFORE_SUCCESS:
        report.stopped = (f"stopped: the first {len(report.errors)} tasks all raised an error, the last: "
                          f"{report.errors[-1]}")
    return None


def _write_summary(store, report):
    """summary.csv: this run's rows plus earlier rows of files still in the store."""
    rows = dict(report.rows)
    for row in store.read_summary():
        if row["file"] not in rows and ((store.dir / row["file"]).exists()
                                        or store.failure_path(_task_of(row)).exists()):
            rows[row["file"]] = row
    try:
        store.write_summary(list(rows.values()))
    except OSError as err:
        report.stopped = report.stopped or (f"stopped: summary.csv could not be written ({err}); every packing "
                                            "file is intact; free space and rerun to rebuild it")


def _task_of(row) -> Task:
    return Task((("n", int(row["n"])),), int(row["seed"]))
