"""The model layer: what a packing is. Box, particle sizes, potentials, shapes, the ``Packing``
value object, the pair search, the wall geometry, and eigenvectors fixed by the problem rather than
the eigen-solver (``frames``). Imports nothing else of jamflow."""

from jamflow.support.lazy import lazy_submodules as _lazy_submodules

__getattr__, __dir__ = _lazy_submodules(__name__, __path__)  # dir() lists the modules; each imports on use
