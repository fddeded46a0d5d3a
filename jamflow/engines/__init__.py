"""The engines layer: what evaluates and minimises a Packing. The contract (``engines.base``),
the choice of an engine (``engines.choose``), the compiled in-process engine (``compiled``) and
LAMMPS with jamflow's plugin (``lammps``). Imports ``mechanics`` and ``model``."""
