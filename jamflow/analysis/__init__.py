"""The analysis layer: what is measured on packings that exist. Normal modes and stability,
structure (g(r), S(k)), order parameters and correlation lengths, stress profiles, geometric
families joined from sampled paths, an independent check of ellipse packings. Reads the model
and the mechanics layers only."""

from jamflow.support.lazy import lazy_submodules as _lazy_submodules

__getattr__, __dir__ = _lazy_submodules(__name__, __path__)  # dir() lists the modules; each imports on use
