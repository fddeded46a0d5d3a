"""The Dask engine: a local cluster over the machine's cores or an existing scheduler.

Dask is imported here only, so ``jamflow jam`` never pays for it.
"""

from __future__ import annotations

import contextlib
import logging
import os
import shutil
import signal
import tempfile
from pathlib import Path

from jamflow.support.spawn import GUARD, refuse_spawned_reimport

SCHEDULER_TIMEOUT = 5  # seconds to reach a scheduler before giving up with a clear error
WAIT_WORKERS = 60.0  # default seconds to wait for a first worker of an existing scheduler


@contextlib.contextmanager
def dask_client(workers: int | None = None, scheduler: str | None = None, client=None,
                wait_workers: float = WAIT_WORKERS):
    """A distributed.Client: ``client`` as given, connected to ``scheduler`` (an address such
    as tcp://host:8786 or a scheduler JSON file from dask-mpi / dask scheduler --scheduler-file),
    or a local cluster of ``workers`` single-threaded processes (default: all cores). A
    scheduler that has no worker after ``wait_workers`` seconds is an error."""
    if client is not None:
        yield client
        return
    refuse_spawned_reimport("a local Dask cluster")
    from distributed import Client, LocalCluster

    if scheduler is not None:
        with _connect(Client, scheduler) as c:
            try:
                c.wait_for_workers(1, timeout=wait_workers)
            except TimeoutError:
                raise ValueError(f"the Dask scheduler at {scheduler} has no workers after {wait_workers:g} s; start "
                                 "some (dask worker ADDRESS, cluster.scale() of dask-jobqueue, dask-mpi) or raise "
                                 "--wait-workers") from None
            yield c
        return
    for name in ("distributed", "distributed.nanny", "distributed.scheduler", "distributed.worker"):
        logging.getLogger(name).setLevel(logging.ERROR)
    with _scratch_directory() as scratch:
        yield from _local_client(Client, LocalCluster, workers, scratch)


@contextlib.contextmanager
def _scratch_directory():
    """A temporary directory for the local cluster's scratch space (Dask's ``temporary-directory``:
    its ``dask-scratch-space/`` with the workers' directories and lock files), removed at the end,
    also after an error or Ctrl-C, so that TMPDIR keeps nothing of the run."""
    import dask

    scratch = tempfile.mkdtemp(prefix="jamflow-dask-")
    try:
        with dask.config.set({"temporary-directory": scratch}):
            yield scratch
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def _local_client(Client, LocalCluster, workers, scratch):
    # workers ignore SIGINT (jamflow/ensemble/worker_setup.py): the disposition is inherited on spawn
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        cluster = LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1, processes=True,
                               dashboard_address=":0", silence_logs=logging.ERROR,
                               preload=["jamflow.ensemble.worker_setup"], local_directory=scratch)
    except RuntimeError as e:
        if "failed to start" not in str(e):
            raise
        raise RuntimeError(f"the local Dask cluster's worker processes failed to start ({e}); their own error is "
                           f"printed above; in a script, is the jamflow call under {GUARD}?") from None
    finally:
        signal.signal(signal.SIGINT, previous)
    try:
        with Client(cluster) as c:
            yield c
    finally:
        with contextlib.suppress(Exception):
            cluster.close(timeout=10)


def _connect(Client, scheduler: str):
    kwargs = {"scheduler_file": scheduler} if Path(scheduler).is_file() else {"address": scheduler}
    try:
        return Client(timeout=SCHEDULER_TIMEOUT, **kwargs)
    except (OSError, TimeoutError) as err:
        raise ValueError(f"cannot reach the Dask scheduler at {scheduler} within {SCHEDULER_TIMEOUT} s ({err}); "
                         "start one (dask scheduler) or check --scheduler") from None


def workers_state(client) -> dict | None:
    """{worker address: keys it is processing}, straight from the scheduler (not the client's
    cached identity, which can lack the workers); None if the scheduler does not answer."""
    try:
        return client.processing()
    except Exception:
        return None


def workers_line(processing: dict | None, lost: int) -> str:
    """One live line: workers connected, busy, lost so far."""
    if processing is None:
        return "workers: scheduler not answering"
    busy = sum(bool(keys) for keys in processing.values())
    return f"workers: {len(processing)} connected, {busy} busy, {lost} lost"
