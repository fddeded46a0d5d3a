"""Stress profile with height in a packing on a floor (walls on the last axis, e.g. under gravity).

- ``sigma_zz`` (the normal stress along the gravity axis, "z" = y in 2D) by the method of
  planes: the force the particles below a horizontal plane at height z exert, through the
  contacts crossing it, on the particles above, per unit area. At force balance it equals the
  weight above the plane per unit area, g N(z' > z) / A (``weight_above``), for every z: the
  profile a packing under gravity must show.
- ``sigma_xx`` (the stress along the first periodic axis) in horizontal slabs from the
  contact virial, each contact's r_x f_x spread uniformly along its bond's height
  (Irving-Kirkwood); its ratio to sigma_zz is the lateral stress ratio K.
Contacts: mobile-mobile and mobile-fixed pairs with r < sigma (``jamflow.model.pairs``) and the
smooth floor's contacts (bonds from z = 0 to the particle). Units: eps / diameter^d.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jamflow.model.packing import Packing
from jamflow.model.pairs import overlapping_pairs


@dataclass(frozen=True)
class ProfileResult:
    """Stresses against height (diameters from the floor), eps / diameter^d."""

    heights: np.ndarray  #: (B,) plane heights (sigma_zz, weight) = slab centres (sigma_xx)
    sigma_zz: np.ndarray  #: (B,) force across each plane per area
    weight_above: np.ndarray  #: (B,) g N(z > plane) / A
    sigma_xx: np.ndarray  #: (B,) slab virial stress along the first axis
    top: float  #: height of the highest particle top


class PressureProfile:
    """``bins`` planes between the floor and the top of the pile.

    Parameters
    ----------
    bins : int, default 40
        Planes (>= 2).
    """

    def __init__(self, bins: int = 40):
        if not (isinstance(bins, (int, np.integer)) and bins >= 2):
            raise ValueError(f"bins must be an integer >= 2, got {bins!r}")
        self.bins = int(bins)

    def compute(self, packing: Packing) -> ProfileResult:
        """sigma_zz across each plane, the weight of the particles above it per unit area, and the
        slab stress sigma_xx of a pile on a floor, all in eps / diameter^d.

        Raises
        ------
        ValueError
            The packing has no walls on its last axis (no floor).
        """
        if packing.box.periodic[-1]:
            raise ValueError("a pressure profile needs a floor: walls on the last axis (y in 2D, z in 3D)")
        i, j, dr, r, sigma = overlapping_pairs(packing)
        if packing.fixed is not None:
            live = ~(packing.fixed[i] & packing.fixed[j])
            i, j, dr, r, sigma = i[live], j[live], dr[live], r[live], sigma[live]
        f = (-packing.potential.dv_dr(r, sigma) / r)[:, None] * dr  # on i from j
        z = packing.positions[:, -1]
        mobile = packing.mobile
        floor = np.flatnonzero(mobile & (z < 0.5 * packing.diameters))  # smooth-floor contacts: bonds from z = 0
        push = np.zeros((len(floor), packing.dim))
        push[:, -1] = -packing.potential.dv_dr(z[floor], 0.5 * packing.diameters[floor])
        n = packing.n
        i, j = np.concatenate([i, floor]), np.concatenate([j, np.full(len(floor), n)])
        f, dr = np.vstack([f, push]), np.vstack([dr, np.zeros((len(floor), packing.dim))])
        z = np.append(z, 0.0)  # the floor, as node n
        top = float(np.max(z[:n][mobile] + 0.5 * packing.diameters[mobile]))
        edges = np.linspace(0.0, top, self.bins + 1)
        centres = 0.5 * (edges[1:] + edges[:-1])
        area = packing.box.volume / packing.box.lengths[-1]
        zi, zj = z[i], z[j]
        lo, hi = np.minimum(zi, zj), np.maximum(zi, zj)
        up = np.where(zi > zj, f[:, -1], -f[:, -1])  # force on the upper particle of each contact
        crossing = (lo[None, :] < centres[:, None]) & (centres[:, None] < hi[None, :])
        sigma_zz = (crossing * up[None, :]).sum(axis=1) / area
        weight = packing.gravity * (mobile[None, :] & (z[None, :n] > centres[:, None])).sum(axis=1) / area
        span = np.maximum(hi - lo, 1e-300)
        inside = np.clip(np.minimum(hi[None, :], edges[1:, None]) - np.maximum(lo[None, :], edges[:-1, None]), 0, None)
        share = np.where(hi - lo > 0, inside / span, ((lo >= edges[:-1, None]) & (lo < edges[1:, None])).astype(float))
        sigma_xx = (share * (dr[:, 0] * f[:, 0])[None, :]).sum(axis=1) / (area * np.diff(edges))
        return ProfileResult(centres, sigma_zz, weight, sigma_xx, top)
