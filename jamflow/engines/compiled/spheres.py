"""Kernel for disks and spheres: V(r_ij / sigma_ij), sigma_ij = (a_i + a_j) / 2 (chapter eq. 2.1,
2.2, Fig. 2.1), over a pair list with fixed periodic image offsets. Units: eps, diameter."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from jamflow.model.packing import Packing
from jamflow.model.pairs import candidate_pairs
from jamflow.engines.compiled import jit
from jamflow.engines.compiled.laws import energy_force

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
    Pairs beyond contact add nothing. Disks and spheres feel no torque. The virial is summed
    in local scalars, term by term as before (the same bits): accumulated in the array, every
    pair waited on a store and reload of it, as the compiler cannot rule out that it aliases f."""
    n, d = x.shape
    f[:] = 0.0
    energy = 0.0
    w00 = w01 = w10 = w11 = w02 = w12 = w20 = w21 = w22 = 0.0  # w_ab += r_a f_b, f = fr r
    owner, fi0, fi1, fi2 = -1, 0.0, 0.0, 0.0  # f[owner] held in registers over its run of pairs
    for k in range(m.i.shape[0]):
        i, j, s = m.i[k], m.j[k], m.sigma[k]
        if i != owner:  # pairs are sorted by i and j > i: f[i] changes only here during its run
            if owner >= 0:
                f[owner, 0], f[owner, 1] = fi0, fi1
                if d == 3:
                    f[owner, 2] = fi2
            owner, fi0, fi1 = i, f[i, 0], f[i, 1]
            fi2 = f[i, 2] if d == 3 else 0.0
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
        fi0 += fr * dr0
        f[j, 0] -= fr * dr0
        fi1 += fr * dr1
        f[j, 1] -= fr * dr1
        if d == 3:
            fi2 += fr * dr2
            f[j, 2] -= fr * dr2
        w00 += fr * dr0 * dr0
        w01 += fr * dr0 * dr1
        w10 += fr * dr1 * dr0
        w11 += fr * dr1 * dr1
        if d == 3:
            w02 += fr * dr0 * dr2
            w12 += fr * dr1 * dr2
            w20 += fr * dr2 * dr0
            w21 += fr * dr2 * dr1
            w22 += fr * dr2 * dr2
    if owner >= 0:
        f[owner, 0], f[owner, 1] = fi0, fi1
        if d == 3:
            f[owner, 2] = fi2
    virial[0, 0], virial[0, 1], virial[1, 0], virial[1, 1] = w00, w01, w10, w11
    if d == 3:
        virial[0, 2], virial[1, 2], virial[2, 0], virial[2, 1], virial[2, 2] = w02, w12, w20, w21, w22
    return energy


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
