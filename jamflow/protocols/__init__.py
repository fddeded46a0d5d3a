"""The protocols layer: how packings are made. Compression to onset (``compression``), above it,
at constant pressure, under gravity, quasistatic shear, geometric families, shape annealing, and
the strain sweeps of the moduli. Each runs minimisations on an engine."""

from jamflow.support.lazy import lazy_submodules as _lazy_submodules

__getattr__, __dir__ = _lazy_submodules(__name__, __path__)  # dir() lists the modules; each imports on use
