"""The mechanics layer: physics of a packing, engine-independent, in numpy. The reference energy,
forces, torques and stress; contacts and floaters; pair terms, the Hessian and the dynamical
matrix and its lowest eigenpairs; deformations and strains; the checks a packing must pass. Imports
``model`` only."""

from jamflow.support.lazy import lazy_submodules as _lazy_submodules

__getattr__, __dir__ = _lazy_submodules(__name__, __path__)  # dir() lists the modules; each imports on use
