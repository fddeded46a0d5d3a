"""The protocols layer: how packings are made. Compression to onset (``compression``), above it,
at constant pressure, under gravity, quasistatic shear, geometric families, shape annealing, and
the strain sweeps of the moduli. Each runs minimisations on an engine."""
