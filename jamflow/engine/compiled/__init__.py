"""jamflow's compiled engine (numba): FIRE 2.0 over translations, rotations and box strain,
with one force/torque kernel per particle shape and the potentials' own laws.

Layout: ``laws`` (the potentials of ``jamflow.potentials`` compiled from their own source),
``rotation`` (2D angles, 3D quaternions), ``fire`` (the integrator, written once), one module
per shape kernel (``spheres``, ``bodies``, ``ellipsoids``), ``kernels`` (the dispatch from a pair-list type to
its kernel) and ``engine`` (``CompiledEngine``, the Python side). A new shape adds a kernel
module and registers it in ``kernels.KERNELS``; the integrator does not change.

Kernels are cached on disk (numba ``cache=True``) under ``<jamflow cache>/numba/<digest>``,
the digest covering this package's sources, ``jamflow/potentials.py`` and
``jamflow/shapes/contact_distance.py``: numba's own cache check looks only at the file of the
cached function, not at the laws and formulas it inlines from other files, so a changed law would otherwise run stale machine code.
"""

from __future__ import annotations

import hashlib
from contextlib import contextmanager
from functools import lru_cache
from pathlib import Path

import numba

_SOURCES = [*sorted(Path(__file__).parent.glob("*.py")), Path(__file__).parents[2] / "potentials.py",
            Path(__file__).parents[2] / "shapes" / "contact_distance.py"]


@lru_cache(maxsize=1)
def cache_dir() -> Path:
    from ..plugin_build import cache_root

    digest = hashlib.sha256(numba.__version__.encode())
    for path in _SOURCES:
        digest.update(path.name.encode() + b"\0" + path.read_bytes())
    return cache_root() / "numba" / digest.hexdigest()[:16]


@contextmanager
def _cache_location():
    old = numba.config.CACHE_DIR
    numba.config.CACHE_DIR = str(cache_dir())
    try:
        yield
    finally:
        numba.config.CACHE_DIR = old


def jit(fn):
    """``numba.njit(cache=True)`` with the cache under jamflow's source digest."""
    with _cache_location():
        return numba.njit(cache=True)(fn)
