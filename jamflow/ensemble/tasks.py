"""What one Dask task runs on a worker: jam one packing, write its file, return its row."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
import warnings
from pathlib import Path

from jamflow.io.packing_file import save_jam_result
from jamflow.protocols.spec import JamSpec, run_jam
from jamflow.protocols.outcome import JammingFailed
from jamflow.ensemble.checks import packing_row
from jamflow.ensemble.store import Task, failure_row, write_failure

MPI_LAUNCHER_VARIABLES = ("PMI_", "PMIX_", "HYDRA_", "MPI_LOCALRANKID", "MPI_LOCALNRANKS", "OMPI_")


def leave_mpi_launcher() -> None:
    """A worker that a nanny spawned under mpirun (dask-mpi) inherits the launcher's
    variables, and LAMMPS's MPI_Init would try to join that job and crash; without them the
    in-process LAMMPS starts as a one-process MPI world. A process that is an MPI rank itself
    (mpi4py loaded) is left alone."""
    if "mpi4py.MPI" in sys.modules:
        return
    for name in [k for k in os.environ if k.startswith(MPI_LAUNCHER_VARIABLES)]:
        del os.environ[name]


def make_packing(fixed: dict, task: Task, path: str, failure_path: str, mpi_ranks: int = 1) -> dict:
    """Jam ``task`` with the jam options ``fixed``; write ``path`` (or the failure record)
    atomically. ``mpi_ranks`` > 1: LAMMPS on that many MPI ranks, under mpirun."""
    leave_mpi_launcher()
    spec = JamSpec(**task.options(fixed))
    if mpi_ranks > 1:
        return _make_on_ranks(spec, task, fixed, path, failure_path, mpi_ranks)
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a final-cap warning is in the file's history/reason
            result, checks = run_jam(spec, destination=path)
    except JammingFailed as err:  # the protocol failed, or the packing failed its checks
        write_failure(failure_path, str(err), time.perf_counter() - t0)
        return failure_row(failure_path, task, fixed)
    save_jam_result(path, result, checks, target_pressure=spec.pressure, stress=spec.stress,
                    seconds=round(time.perf_counter() - t0, 3))
    return packing_row(path, task, fixed)


def _make_on_ranks(spec, task, fixed, path, failure_path, ranks):
    from jamflow.engines.lammps.library import lammps_env

    mpirun = Path(sys.prefix) / "bin" / "mpirun"
    job = json.dumps({"spec": spec.as_dict(), "path": path, "failure_path": failure_path})
    proc = subprocess.run([str(mpirun) if mpirun.exists() else "mpirun", "-np", str(ranks), sys.executable, "-m",
                           "jamflow.ensemble.mpi_task", job], capture_output=True, text=True, env=lammps_env(),
                          stdin=subprocess.DEVNULL)
    if proc.returncode != 0:
        raise RuntimeError(f"mpirun -np {ranks} exited with {proc.returncode}: {proc.stderr.strip()[-500:]}")
    if Path(failure_path).exists():
        return failure_row(failure_path, task, fixed)
    return packing_row(path, task, fixed)
