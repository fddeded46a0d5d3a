"""The disk/sphere kernels compiled ahead of time: a disk jam without numba's start-up.

numba's first call in a process costs ~1 CPU s (import, target set-up, cache load) and scipy.spatial's
import 0.3 s more, where a whole N = 64 jam needs 0.06 s (docs/notes/speed-2.md sections 7.1, 10). So the
compiled engine's FIRE and force evaluation for disks and spheres with the spring law (``alpha`` 2:
harmonic, 2.5: Hertzian), and the cell-list pair search of ``cells``, are compiled once with
numba.pycc (``aot_build``) into an extension module that imports no numba; ``CompiledEngine`` calls
it through ``AotKernels`` (the same arguments as ``fire.fire`` / ``fire.forces``, the same machine code
paths, bit-identical results: tests/test_aot.py) and ``jamflow.model.pairs`` uses its cell list in place of
cKDTree. Everything else (ellipsoids, rigid bodies, the rlj law) runs numba's kernels.

The module is built on first use, like the LAMMPS plugin: ~15-20 CPU s once, in a subprocess, into
``<jamflow cache>/aot/<digest>/``, the digest covering the kernels' sources and numba's version
(``compiled.source_digest``), numpy's and Python's versions and this CPU (the build targets the host
CPU, as numba does); it is moved into place atomically under a lock, so concurrent first jams build it
once. If it cannot be built (no C compiler, a numba without pycc, a failed build) jamflow warns once,
leaves a ``failed`` marker (delete it to retry; none when no C compiler is found, so installing one
is enough) and runs numba's kernels. ``JAMFLOW_AOT=0`` turns the
module off. The module is compiled from jamflow's sources and numba's runtime only (no LAMMPS headers).
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import platform
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import warnings
from functools import lru_cache
from pathlib import Path

from jamflow.model.pairs import use_compiled_cell_list
from jamflow.model.potentials import SpringParams
from jamflow.support.cache import cache_root, intact_shared_object

MODULE = "jamflow_kernels"
_module = None  # the loaded module, once loaded
_warned = False


_SWITCH = {"": True, "1": True, "on": True, "yes": True, "true": True,
           "0": False, "off": False, "no": False, "false": False}


def enabled() -> bool:
    """``JAMFLOW_AOT``: unset or 1 / on / yes / true (default) uses the module, 0 / off / no / false turns it off."""
    value = os.environ.get("JAMFLOW_AOT", "").strip().lower()
    if value not in _SWITCH:
        raise ValueError(f"JAMFLOW_AOT={os.environ['JAMFLOW_AOT']!r} is neither on nor off; set it to 0 (numba's "
                         "kernels) or 1 (the ahead-of-time disk kernels, the default), or unset it")
    return _SWITCH[value]


def _cpu_id() -> str:
    """The CPU model and flags (a host-targeted build may not run on another CPU sharing the cache)."""
    try:
        lines = Path("/proc/cpuinfo").read_text().splitlines()
    except OSError:
        return platform.machine() + " " + platform.processor()
    keep = ("model name", "flags")
    return "\n".join(sorted({line for line in lines if line.split(":")[0].strip() in keep}))


@lru_cache(maxsize=1)
def module_path() -> Path:
    """Where the built module lives in jamflow's cache."""
    import importlib.metadata

    from jamflow.engines.compiled import source_digest

    digest = hashlib.sha256("\0".join([source_digest(), importlib.metadata.version("numpy"), sys.version,
                                       _cpu_id()]).encode()).hexdigest()[:16]
    return cache_root() / "aot" / digest / (MODULE + sysconfig.get_config_var("EXT_SUFFIX"))


def loaded():
    """The module if this process has it or it is built (never builds); None when off or not built."""
    if not enabled():
        return None
    if _module is None and intact_shared_object(module_path()):
        _load(module_path())
    return _module


def module():
    """The module, building it first if needed; None when off or it cannot be built (warned once)."""
    if enabled() and loaded() is None:
        path = module_path()
        failed = path.parent / "failed"
        if not intact_shared_object(path) and c_compiler() is None:  # nothing to build with: no marker, retried once one exists
            _warn("no C compiler found (looked for $CC, then Python's CC, cc, gcc), so the ahead-of-time disk "
                  "kernels cannot be built; using numba's kernels (~1 s more start-up per process). Install one, "
                  "e.g. `apt-get install gcc`, or set JAMFLOW_AOT=0")
            return None
        try:
            if not failed.exists():
                _build_locked(path, failed)
        except OSError as err:  # a read-only or full cache: nothing written, numba serves
            _warn(f"the ahead-of-time disk kernels could not be built in {path.parent} ({err}); using numba's "
                  "kernels (~1 s more start-up per process). Point JAMFLOW_CACHE_DIR at a writable directory, or "
                  "set JAMFLOW_AOT=0")
            return None
        if intact_shared_object(path):
            _load(path)
        else:
            _warn(f"the ahead-of-time disk kernels could not be built ({_first_line(failed)}); using numba's "
                  f"kernels (~1 s more start-up per process). Delete {failed} to retry, or set JAMFLOW_AOT=0")
    return loaded()


def _build_locked(path: Path, failed: Path) -> None:
    """Build under a lock (one builder; the others wait, then find the module)."""
    import fcntl

    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path.parent / "build.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if intact_shared_object(path) or failed.exists():
            return
        for stale in path.parent.glob("tmp*"):  # an interrupted build's directory (we hold the lock)
            shutil.rmtree(stale, ignore_errors=True)
        print("jamflow: compiling the ahead-of-time disk kernels once (~20 s) into", path.parent, file=sys.stderr,
              flush=True)
        with tempfile.TemporaryDirectory(dir=path.parent) as tmp:  # removed also on an error or Ctrl-C
            done = subprocess.run(build_command(tmp), capture_output=True, text=True, env=build_environment(tmp))
            built = Path(tmp) / path.name
            if done.returncode == 0 and intact_shared_object(built):
                os.replace(built, path)
            else:
                lines = done.stderr.strip().splitlines() or ["no module written"]
                reason = next((line for line in reversed(lines) if "Error" in line), lines[-1])
                failed.write_text(f"exit {done.returncode}: {reason}\n\n{done.stderr[-4000:]}")


def c_compiler() -> str | None:
    """The C compiler pycc would run (``$CC`` if set, else Python's own ``CC``, ``cc``, ``gcc``), or None."""
    cc = os.environ.get("CC", "").split()
    if cc:
        return shutil.which(cc[0])
    python_cc = (sysconfig.get_config_var("CC") or "").split()
    for name in python_cc[:1] + ["cc", "gcc"]:
        found = shutil.which(name)
        if found:
            return found
    return None


def build_environment(out_dir: str) -> dict:
    """The build's environment: TMPDIR inside the build directory ``out_dir``, so that the
    compiler's scratch files (numba.pycc's ``pycc-build-*`` directory, kept when a compile fails
    or is interrupted) go with it instead of staying in the user's TMPDIR."""
    scratch = Path(out_dir) / "scratch"
    scratch.mkdir(exist_ok=True)
    return {**os.environ, "TMPDIR": str(scratch), "TEMP": str(scratch), "TMP": str(scratch)}


def build_command(out_dir: str) -> list[str]:
    """The build: ``aot_build`` in a fresh Python (numba and gcc stay out of this process)."""
    return [sys.executable, "-m", "jamflow.engines.compiled.aot_build", out_dir, "host"]


def _first_line(path: Path) -> str:
    try:
        return path.read_text().splitlines()[0]
    except (OSError, IndexError):
        return "no module written"


def _load(path: Path) -> None:
    global _module
    spec = importlib.util.spec_from_file_location(MODULE, path)
    loaded_module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(loaded_module)
    _module = loaded_module


def _warn(message: str) -> None:
    global _warned
    if not _warned:
        warnings.warn("jamflow: " + message, RuntimeWarning, stacklevel=3)
        _warned = True


class AotKernels:
    """``fire.fire`` and ``fire.forces`` (same arguments) for disks/spheres with the spring law."""

    def __init__(self, aot_module):
        self.module = aot_module

    @staticmethod
    def _flat(model, fld):
        return (model.i, model.j, model.shift, model.sigma, model.law.alpha, model.law.epsilon, fld.h, fld.walled,
                fld.half, fld.mobile, fld.any_fixed, fld.gravity, fld.basis, fld.pressure, fld.length)

    def fire(self, model, fld, *arrays):
        return self.module.fire_spheres_spring(*self._flat(model, fld), *arrays)

    def forces(self, model, fld, *arrays):
        return self.module.forces_spheres_spring(*self._flat(model, fld), *arrays)


def kernels_for(packing) -> AotKernels | None:
    """The ahead-of-time kernels if they serve ``packing`` (disks/spheres, the spring law) and can be had."""
    if not packing.shape.round or type(packing.potential.params) is not SpringParams:
        return None
    found = module()
    return AotKernels(found) if found is not None else None


use_compiled_cell_list(loaded)  # the model's pair search uses the compiled cell list wherever it is built
