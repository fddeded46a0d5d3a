"""LAMMPS as a jamflow engine: the engine, its session, pair styles, rigid bodies, data files, C++ plugin."""
