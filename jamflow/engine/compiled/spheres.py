"""Kernel for disks and spheres: V(r_ij / sigma_ij), sigma_ij = (a_i + a_j) / 2 (seed eq. 2.1,
2.2, Fig. 2.1), over a pair list with fixed periodic image offsets. Units: eps, diameter."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ...packing import Packing
from ...pairs import candidate_pairs
from . import jit
from .laws import energy_force

KIND = "sphere"


class Pairs(NamedTuple):
    """Pairs i < j within sigma_ij + skin, with each pair's periodic image offset ``shift``
    (P, d), fixed when the list is built (positions are not rewrapped between builds)."""

    i: np.ndarray
    j: np.ndarray
    shift: np.ndarray
    sigma: np.ndarray
    law: tuple  # the potential's Params


@jit
def forces(m, x, o, f, tau, virial):
    """Fill f (N, d) and the virial sum_pairs r_ij f_ij (d, d); return the total energy.
    Pairs beyond contact add nothing. Disks and spheres feel no torque."""
    n, d = x.shape
    f[:] = 0.0
    virial[:] = 0.0
    energy = 0.0
    for k in range(m.i.shape[0]):
        i, j, s = m.i[k], m.j[k], m.sigma[k]
        dr0 = x[i, 0] - x[j, 0] + m.shift[k, 0]
        dr1 = x[i, 1] - x[j, 1] + m.shift[k, 1]
        dr2 = x[i, 2] - x[j, 2] + m.shift[k, 2] if d == 3 else 0.0
        r2 = dr0 * dr0 + dr1 * dr1 + dr2 * dr2
        if r2 >= s * s:
            continue
        r = math.sqrt(r2)
        v, dv = energy_force(m.law, r / s)
        energy += v
        fr = -dv / (s * r)  # -dV/dr / r
        f[i, 0] += fr * dr0
        f[j, 0] -= fr * dr0
        f[i, 1] += fr * dr1
        f[j, 1] -= fr * dr1
        if d == 3:
            f[i, 2] += fr * dr2
            f[j, 2] -= fr * dr2
        _tally(virial, fr, dr0, dr1, dr2, d)
    return energy


@jit
def _tally(virial, fr, dr0, dr1, dr2, d):
    """virial_ab += r_a f_b for a central pair force f = fr r."""
    virial[0, 0] += fr * dr0 * dr0
    virial[0, 1] += fr * dr0 * dr1
    virial[1, 0] += fr * dr1 * dr0
    virial[1, 1] += fr * dr1 * dr1
    if d == 3:
        virial[0, 2] += fr * dr0 * dr2
        virial[1, 2] += fr * dr1 * dr2
        virial[2, 0] += fr * dr2 * dr0
        virial[2, 1] += fr * dr2 * dr1
        virial[2, 2] += fr * dr2 * dr2


def build(packing: Packing, x: np.ndarray, skin: float) -> Pairs:
    """Pairs i < j within sigma_ij + skin and their periodic image offsets."""
    diameters = packing.diameters
    i, j = candidate_pairs(packing, float(diameters.max()) + skin)
    sigma = 0.5 * (diameters[i] + diameters[j])
    dr = packing.box.minimum_image(x[i] - x[j])
    keep = np.einsum("ij,ij->i", dr, dr) < (sigma + skin) ** 2
    if packing.fixed is not None:  # fixed (wall) particles do not interact with each other
        keep &= ~(packing.fixed[i] & packing.fixed[j])
    i, j, sigma, dr = i[keep], j[keep], sigma[keep], dr[keep]
    shift = dr - (x[i] - x[j])
    return Pairs(i.astype(np.int64), j.astype(np.int64), np.ascontiguousarray(shift), sigma,
                       packing.potential.params)
