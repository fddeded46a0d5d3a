"""Kernel for rigid bodies of fused spherical sites (chapter section 2.3.1, Figure 2.9): the energy
is the sum of V(r_st / sigma_st) over site pairs s, t of different bodies, sigma_st =
(a_s + a_t) / 2; each site force acts on its body's centre and exerts the torque
lever x force (lever = site - centre). The virial is the molecular one,
sum over site pairs of (R_I - R_J) f_st with R the body centres. Units: eps, diameter."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from jamflow.model.packing import Packing
from jamflow.model.pairs import candidate_pairs
from jamflow.engines.compiled import jit
from jamflow.engines.compiled.laws import energy_force
from jamflow.engines.compiled.rotation import rotation_matrix

KIND = "rigid"


class Pairs(NamedTuple):
    """Site pairs (s < t, different bodies) within sigma_st + skin, with image offsets."""

    s: np.ndarray
    t: np.ndarray
    shift: np.ndarray  # (P, d)
    sigma: np.ndarray  # (P,)
    body: np.ndarray  # (S_total,) body of each site
    local: np.ndarray  # (S_total, d) body-frame offset of each site from its centre, scaled
    law: tuple
    lever: np.ndarray  # (S_total, d) scratch: world-frame offsets
    rot: np.ndarray  # (N, d, d) scratch: rotation matrices


@jit
def forces(m, x, o, f, tau, virial):
    """Fill f (N, d), tau (N, 1 | 3) (world frame) and the virial (d, d); return the energy."""
    n, d = x.shape
    f[:] = 0.0
    tau[:] = 0.0
    virial[:] = 0.0
    for b in range(n):
        rotation_matrix(o, b, m.rot[b])
    for s in range(m.body.shape[0]):
        b = m.body[s]
        for a in range(d):
            acc = 0.0
            for c in range(d):
                acc += m.rot[b, a, c] * m.local[s, c]
            m.lever[s, a] = acc
    energy = 0.0
    dr = np.zeros(3)
    for k in range(m.s.shape[0]):
        s, t, sig = m.s[k], m.t[k], m.sigma[k]
        bi, bj = m.body[s], m.body[t]
        r2 = 0.0
        for a in range(d):
            dr[a] = x[bi, a] + m.lever[s, a] - x[bj, a] - m.lever[t, a] + m.shift[k, a]
            r2 += dr[a] * dr[a]
        if r2 >= sig * sig:
            continue
        r = math.sqrt(r2)
        v, dv = energy_force(m.law, r / sig)
        energy += v
        fr = -dv / (sig * r)
        for a in range(d):
            f[bi, a] += fr * dr[a]
            f[bj, a] -= fr * dr[a]
            for c in range(d):  # molecular virial: centre separation (dr - lever_s + lever_t)
                virial[a, c] += (dr[a] - m.lever[s, a] + m.lever[t, a]) * fr * dr[c]
        if d == 2:
            tau[bi, 0] += fr * (m.lever[s, 0] * dr[1] - m.lever[s, 1] * dr[0])
            tau[bj, 0] -= fr * (m.lever[t, 0] * dr[1] - m.lever[t, 1] * dr[0])
        else:
            ls, lt = m.lever[s], m.lever[t]
            tau[bi, 0] += fr * (ls[1] * dr[2] - ls[2] * dr[1])
            tau[bi, 1] += fr * (ls[2] * dr[0] - ls[0] * dr[2])
            tau[bi, 2] += fr * (ls[0] * dr[1] - ls[1] * dr[0])
            tau[bj, 0] -= fr * (lt[1] * dr[2] - lt[2] * dr[1])
            tau[bj, 1] -= fr * (lt[2] * dr[0] - lt[0] * dr[2])
            tau[bj, 2] -= fr * (lt[0] * dr[1] - lt[1] * dr[0])
    return energy


def build(packing: Packing, x: np.ndarray, skin: float) -> Pairs:
    """Site pairs of different bodies within sigma_st + skin, and their image offsets."""
    shape, n, d = packing.shape, packing.n, packing.dim
    n_sites = shape.n_sites
    world = shape.world_sites(x, packing.orientations, packing.diameters).reshape(-1, d)
    site_d = (packing.diameters[:, None] * shape.site_diameters[None, :]).ravel()
    body = np.repeat(np.arange(n), n_sites)
    sites = Packing(packing.box.wrap(world), site_d, packing.box)
    s, t = candidate_pairs(sites, float(site_d.max()) + skin)
    s, t = s[body[s] != body[t]], t[body[s] != body[t]]
    sigma = 0.5 * (site_d[s] + site_d[t])
    dr = packing.box.minimum_image(world[s] - world[t])
    keep = np.einsum("ij,ij->i", dr, dr) < (sigma + skin) ** 2
    s, t, sigma, dr = s[keep], t[keep], sigma[keep], dr[keep]
    shift = dr - (world[s] - world[t])
    local = (packing.diameters[:, None, None] * shape.sites[None, :, :]).reshape(-1, d)
    return Pairs(s.astype(np.int64), t.astype(np.int64), np.ascontiguousarray(shift), sigma,
                     body.astype(np.int64), np.ascontiguousarray(local), packing.potential.params,
                     np.zeros((n * n_sites, d)), np.zeros((n, d, d)))
