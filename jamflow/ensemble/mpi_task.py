"""One ensemble packing on several MPI ranks: ``mpirun -np K python -m jamflow.ensemble.mpi_task SPEC``.

Every rank runs the Python controller on LAMMPS over MPI.COMM_WORLD (domain decomposition;
positions and forces gathered over ranks, docs/guide/lammps.md); rank 0 writes
the packing file, or the failure record, atomically. SPEC is the JSON that
``jamflow.ensemble.tasks.make_packing`` passes (the ``JamSpec`` fields and the paths).
"""

import json
import sys
import time

from mpi4py import MPI  # first: this process is an MPI rank


def main(spec: dict) -> int:
    from jamflow.io.packing_file import save_jam_result
    from jamflow.protocols.spec import JamSpec, run_jam
    from jamflow.protocols.outcome import JammingFailed
    from jamflow.ensemble.store import write_failure

    comm = MPI.COMM_WORLD
    jam_spec = JamSpec(**spec["spec"])
    t0 = time.perf_counter()
    try:
        result, checks = run_jam(jam_spec, engine_options={"comm": comm}, destination=spec["path"])
    except JammingFailed as err:
        if comm.rank == 0:
            write_failure(spec["failure_path"], str(err), time.perf_counter() - t0)
        return 0
    if comm.rank == 0:
        save_jam_result(spec["path"], result, checks, target_pressure=jam_spec.pressure, stress=jam_spec.stress,
                        seconds=round(time.perf_counter() - t0, 3), mpi_ranks=comm.size)
    return 0


if __name__ == "__main__":
    sys.exit(main(json.loads(sys.argv[1])))
