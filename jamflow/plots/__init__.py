"""The figures layer: matplotlib (Agg canvas) figures of packings, spectra, moduli, shear paths,
structure and walls, written atomically."""

from jamflow.support.lazy import lazy_submodules as _lazy_submodules

__getattr__, __dir__ = _lazy_submodules(__name__, __path__)  # dir() lists the modules; each imports on use
