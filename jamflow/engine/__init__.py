"""Engines that evaluate and minimise a Packing (contract: ``engine.base``): LAMMPS
(``lammps``), the compiled in-process engine (``compiled``), and the numpy reference."""
