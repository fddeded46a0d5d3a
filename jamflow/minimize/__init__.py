"""The minimisers layer: settings, the chapter's stopping rules applied to any engine's windows
(``rules``), and the creep steps between windows (``polish``, ``soft_modes``)."""

from jamflow.minimize.rules import minimize
from jamflow.minimize.settings import (CONVERGED_REASONS, CREEP_METHODS, MD_DAMPINGS, METHODS, MinimizeResult,
                                       MinimizerSettings)
from jamflow.support.lazy import lazy_submodules as _lazy_submodules

__all__ = ["CONVERGED_REASONS", "CREEP_METHODS", "MD_DAMPINGS", "METHODS", "MinimizeResult", "MinimizerSettings",
           "minimize"]

__getattr__, __dir__ = _lazy_submodules(__name__, __path__)  # dir() lists the modules; each imports on use
