"""The decks layer: jamflow's protocols as LAMMPS input decks that run in ``lmp`` alone (jamming
of disks/spheres and of ellipses/spheroids, quasistatic shear), and their cross-check against the
Python controller."""
