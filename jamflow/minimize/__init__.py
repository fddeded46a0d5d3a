"""The minimisers layer: settings, the seed's stopping rules applied to any engine's windows
(``rules``), and the creep steps between windows (``polish``, ``soft_modes``)."""

from jamflow.minimize.rules import minimize
from jamflow.minimize.settings import (CONVERGED_REASONS, CREEP_METHODS, MD_DAMPINGS, METHODS, MinimizeResult,
                                       MinimizerSettings)

__all__ = ["CONVERGED_REASONS", "CREEP_METHODS", "MD_DAMPINGS", "METHODS", "MinimizeResult", "MinimizerSettings",
           "minimize"]
