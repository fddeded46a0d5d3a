"""The decks layer: jamflow's protocols as LAMMPS input decks that run in ``lmp`` alone (jamming
of disks/spheres and of ellipses/spheroids, quasistatic shear), and their cross-check against the
Python controller."""

from jamflow.support.lazy import lazy_submodules as _lazy_submodules

__getattr__, __dir__ = _lazy_submodules(__name__, __path__)  # dir() lists the modules; each imports on use
