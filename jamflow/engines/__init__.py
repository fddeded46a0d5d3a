"""The engines layer: what evaluates and minimises a Packing. The contract (``engines.base``),
the choice of an engine (``engines.choose``), the compiled in-process engine (``compiled``) and
LAMMPS with jamflow's plugin (``lammps``). Imports ``mechanics`` and ``model``."""

from jamflow.support.lazy import lazy_submodules as _lazy_submodules

__getattr__, __dir__ = _lazy_submodules(__name__, __path__)  # dir() lists the modules; each imports on use
