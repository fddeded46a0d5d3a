"""jamflow's compiled engine (numba): FIRE 2.0 over translations, rotations and box strain,
with one force/torque kernel per particle shape and the potentials' own laws.

Layout: ``laws`` (the potentials of ``jamflow.model.potentials`` compiled from their own source),
``rotation`` (2D angles, 3D quaternions), ``fire`` (the integrator, written once), one module
per shape kernel (``spheres``, ``bodies``, ``ellipsoids``), ``kernels`` (the dispatch from a pair-list type to
its kernel), ``cells`` (a cell-list pair search), ``engine`` (``CompiledEngine``, the Python side),
``aot`` / ``aot_build`` (the disk/sphere kernels compiled ahead of time) and ``threads`` (the disk/sphere
FIRE and forces on several threads, opt-in: ``jit_parallel``). A new shape adds a kernel
module and registers it in ``kernels.MODULES``; the integrator does not change.

numba is imported on first use, not at import: ``jit`` returns a ``Deferred`` function, and the
first call of any of them (``start_numba``) imports numba, swaps every deferred function in jamflow's
loaded modules for its numba dispatcher (so compiled code calls compiled code, as with
``numba.njit`` at import) and runs the registrations (``overload`` and friends) queued by
``when_numba_starts``. A disk jam served by the ahead-of-time kernels never starts numba (~1 CPU s of
start-up; docs/notes/speed-2.md section 12). Code outside jamflow that calls jamflow's kernels from
its own numba functions calls ``start_numba()`` first (numba cannot type a ``Deferred``; see
benchmarks/kernel.py).

Kernels are cached on disk (numba ``cache=True``) under ``<jamflow cache>/numba/<digest>``,
the digest covering this package's sources, ``jamflow/model/potentials.py`` and
``jamflow/model/shapes/contact_distance.py``: numba's own cache check looks only at the file of the
cached function, not at the laws and formulas it inlines from other files, so a changed law would otherwise run stale machine code.

A kernel that is about to be compiled (no machine code for its argument types in this process nor
in the cache) says so first, in one line on stderr (``announce_compile``): a first run of a shape
takes tens of seconds, and should not be silent.
"""

from __future__ import annotations

import functools
import hashlib
import sys
from contextlib import contextmanager
from functools import lru_cache
from pathlib import Path

_SOURCES = [*sorted(Path(__file__).parent.glob("*.py")), Path(__file__).parents[2] / "model" / "potentials.py",
            Path(__file__).parents[2] / "model" / "ddouble.py",
            Path(__file__).parents[2] / "model" / "shapes" / "contact_distance.py"]
_DEFERRED: list = []  # every Deferred made before numba started
_REGISTRATIONS: list = []  # callables to run once numba has started
_started = False


@lru_cache(maxsize=1)
def source_digest() -> str:
    """sha256 (16 hex digits) of numba's version and the sources the kernels are compiled from."""
    import importlib.metadata

    digest = hashlib.sha256(importlib.metadata.version("numba").encode())
    for path in _SOURCES:
        digest.update(path.name.encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()[:16]


@lru_cache(maxsize=1)
def cache_dir() -> Path:
    from jamflow.support.cache import cache_root

    return cache_root() / "numba" / source_digest()


@contextmanager
def _cache_location():
    import numba

    old = numba.config.CACHE_DIR
    numba.config.CACHE_DIR = str(cache_dir())
    try:
        yield
    finally:
        numba.config.CACHE_DIR = old


def _njit(fn, parallel=False):
    import numba

    with _cache_location():
        dispatcher = numba.njit(cache=True, parallel=True)(fn) if parallel else numba.njit(cache=True)(fn)
    _guard_cache_writes(dispatcher)
    return dispatcher


_cache_unwritable = False  # a write to the kernel cache failed (full disk or quota): warned, no more writes


def _guard_cache_writes(dispatcher) -> None:
    """A kernel whose cache file cannot be written (ENOSPC, EDQUOT, ... : numba raises the OSError
    out of the compiling call) runs from memory: one warning, and no more cache writes in this
    process. (An unwritable directory never gets here: numba then picks no cache location.)"""
    cache = getattr(dispatcher, "_cache", None)
    save = getattr(cache, "save_overload", None)
    if save is None:
        return

    def save_or_warn(sig, data):
        global _cache_unwritable
        if _cache_unwritable:
            return
        try:
            save(sig, data)
        except OSError as err:
            _cache_unwritable = True
            import warnings

            warnings.warn(f"jamflow: the compiled kernels cannot be cached in {cache_dir()} ({err.strerror or err}); "
                          "they run from memory and are compiled again in every process (~seconds). Free space "
                          "there or point JAMFLOW_CACHE_DIR at another directory", RuntimeWarning, stacklevel=2)

    cache.save_overload = save_or_warn


class Deferred:
    """A kernel that numba compiles once numba has started; calling it from Python starts numba.
    ``py_func`` is the Python function (as on a numba dispatcher)."""

    def __init__(self, fn, parallel=False):
        functools.update_wrapper(self, fn)
        self.py_func = fn
        self.parallel = parallel
        self.dispatcher = None

    def __call__(self, *args, **kwargs):
        start_numba()
        return self.dispatcher(*args, **kwargs)


def jit(fn):
    """``numba.njit(cache=True)`` with the cache under jamflow's source digest, made when numba
    starts (a ``Deferred``) or at once if it has."""
    if _started:
        return _njit(fn)
    deferred = Deferred(fn)
    _DEFERRED.append(deferred)
    return deferred


def jit_parallel(fn):
    """``jit`` with ``parallel=True``: numba runs its ``prange`` loops on its thread pool (the
    threaded kernels of ``threads``; numba.pycc cannot compile these ahead of time)."""
    if _started:
        return _njit(fn, parallel=True)
    deferred = Deferred(fn, parallel=True)
    _DEFERRED.append(deferred)
    return deferred


def when_numba_starts(register):
    """Run ``register()`` (e.g. ``numba.extending.overload`` calls) once numba has started, or now."""
    if _started:
        register()
    else:
        _REGISTRATIONS.append(register)


def start_numba() -> None:
    """Import numba; replace every ``Deferred`` in jamflow's loaded modules by its dispatcher; run
    the queued registrations. Idempotent."""
    global _started
    if _started:
        return
    for deferred in _DEFERRED:
        deferred.dispatcher = _njit(deferred.py_func, deferred.parallel)
    _started = True
    for name, module in list(sys.modules.items()):
        if name == "jamflow" or name.startswith("jamflow."):
            for attr, value in list(vars(module).items()):
                if isinstance(value, Deferred):
                    setattr(module, attr, value.dispatcher)
    for register in _REGISTRATIONS:
        register()
    _REGISTRATIONS.clear()


_checked: set = set()  # (kernel, argument types) already looked up in this process
_announced: set = set()  # what's compile notices already printed


def will_compile(dispatcher, args) -> bool:
    """Whether calling the numba ``dispatcher`` with ``args`` compiles: no machine code for their
    types in this process, nor in its disk cache. False when that cannot be told (numba's cache
    internals differ): better no notice than a wrong one."""
    try:
        sig = tuple(dispatcher.typeof_pyval(a) for a in args)
        if sig in dispatcher.overloads:
            return False
        cache = getattr(dispatcher, "_cache", None)
        index = cache._cache_file._load_index() if cache is not None and hasattr(cache, "_cache_file") else {}
        magic = dispatcher.targetctx.codegen().magic_tuple()
        return not any(key[0] == sig and key[1] == magic for key in index)
    except Exception:
        return False


def announce_compile(what: str, seconds: float, kernel, args) -> None:
    """Before calling a compiled ``kernel`` with ``args``: if that compiles (``will_compile``), one
    line on stderr, once per ``what`` and process: ``jamflow: compiling the ellipse kernels once
    (~40 s) into DIR``. ``seconds``: the measured cold compile time of those kernels."""
    if what in _announced:
        return
    start_numba()
    dispatcher = getattr(kernel, "dispatcher", None) or kernel  # a Deferred's dispatcher, once numba started
    try:
        key = (dispatcher.py_func, tuple(dispatcher.typeof_pyval(a) for a in args))
    except Exception:
        return
    if key in _checked:
        return
    _checked.add(key)
    if will_compile(dispatcher, args):
        _announced.add(what)
        print(f"jamflow: compiling the {what} kernels once (~{seconds:.0f} s) into {cache_dir()}", file=sys.stderr,
              flush=True)
