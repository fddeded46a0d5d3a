"""Engines that evaluate and minimise a Packing: LAMMPS (``lammps``) and a numpy reference."""
