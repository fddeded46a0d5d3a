"""Particles numbered along a space-filling curve, so that neighbours in space are near in memory.

A random start numbers its particles in the order they were drawn: a particle's neighbours are
anywhere in the arrays, and at large N every pair in the force loop reads positions that are not
in the cache. Sorted along the Morton (Z-order) curve of their cell coordinates, particles close
in space are close in the arrays (Warren & Salmon, Proc. Supercomputing '93, 12; the ordering
HOOMD-blue and LAMMPS's ``atom_modify sort`` apply for the same reason). Only the labels change:
the particles, their sizes and the physics are the same. Per-iteration cost of the compiled FIRE
measured in ``benchmarks/spatial_order.py``.
"""

from __future__ import annotations

import numpy as np

MORTON_BITS = 10  # cells per axis 2^10: at N = 65536 in 2D ~16 cells per particle spacing, finer than needed
SPATIAL_ORDER_FROM = 8192  # random starts of at least this many particles are numbered along the curve


def morton_order(fractional: np.ndarray, bits: int = MORTON_BITS) -> np.ndarray:
    """The permutation that sorts points with cell coordinates ``fractional`` (N, d) in [0, 1)
    along the Morton curve of 2^bits cells per axis (ties kept in their given order)."""
    s = np.asarray(fractional, float)
    n, dim = s.shape
    cells = np.clip(np.floor((s - np.floor(s)) * (1 << bits)).astype(np.int64), 0, (1 << bits) - 1)
    code = np.zeros(n, dtype=np.int64)
    for b in range(bits):
        for a in range(dim):
            code |= ((cells[:, a] >> b) & 1) << (dim * b + a)
    return np.argsort(code, kind="stable")
