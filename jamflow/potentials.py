"""Purely repulsive pair potentials of the seed chapter, in closed form.

Energies in units of epsilon, lengths in units of the small diameter. Both vanish for
r >= sigma_ij, the contact distance (sigma_ij = (a_i + a_j) / 2 for disks and spheres).

- ``Spring(alpha)``: V = eps/alpha (1 - r/sigma)^alpha  (seed eq. 2.1; alpha=2 linear,
  alpha=5/2 Hertzian).
- ``RepulsiveLJ``: V = eps [(sigma/r)^12 - 2 (sigma/r)^6 + 1]  (seed eq. 2.2).

``parse_potential`` reads the CLI spec: ``spring``, ``hertz``, ``spring:ALPHA``, ``rlj``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Spring:
    """Repulsive spring V = eps/alpha (1 - r/sigma)^alpha for r < sigma (seed eq. 2.1)."""

    alpha: float = 2.0
    epsilon: float = 1.0

    def __post_init__(self):
        if not (math.isfinite(self.alpha) and self.alpha > 1.0):
            raise ValueError(f"spring exponent alpha must be a finite number > 1, got {self.alpha}")
        _check_epsilon(self.epsilon)

    name = "spring"

    @property
    def contact_stiffness(self) -> float:
        """Scale of d2V/dr2 near contact (eps/diameter^2); sets the force round-off floor."""
        return self.epsilon

    @property
    def spec(self) -> str:
        return "hertz" if self.alpha == 2.5 else ("spring" if self.alpha == 2.0 else f"spring:{self.alpha:g}")

    def energy(self, r, sigma):
        x = _overlap(r, sigma)
        return self.epsilon / self.alpha * x**self.alpha

    def dv_dr(self, r, sigma):
        """dV/dr (negative: repulsive), units eps/diameter."""
        x = _overlap(r, sigma)
        return -self.epsilon / sigma * x ** (self.alpha - 1.0)

    def d2v_dr2(self, r, sigma):
        """Second derivative; for alpha < 2 it diverges as r -> sigma from below."""
        x = _overlap(r, sigma)
        inside = x > 0
        safe = np.where(inside, x, 1.0)
        return np.where(inside, self.epsilon * (self.alpha - 1.0) / sigma**2 * safe ** (self.alpha - 2.0), 0.0)


@dataclass(frozen=True)
class RepulsiveLJ:
    """Repulsive Lennard-Jones V = eps[(s/r)^12 - 2(s/r)^6 + 1] for r < s (seed eq. 2.2)."""

    epsilon: float = 1.0

    name = "rlj"
    spec = "rlj"

    @property
    def contact_stiffness(self) -> float:
        """d2V/dr2 at r = sigma is 72 eps/sigma^2: forces carry 72x the round-off of springs."""
        return 72.0 * self.epsilon

    def __post_init__(self):
        _check_epsilon(self.epsilon)

    def energy(self, r, sigma):
        r, sigma = np.asarray(r, float), np.asarray(sigma, float)
        q6 = (sigma / r) ** 6
        return np.where(r < sigma, self.epsilon * (q6 - 1.0) ** 2, 0.0)  # = q^12 - 2 q^6 + 1, no cancellation

    def dv_dr(self, r, sigma):
        r, sigma = np.asarray(r, float), np.asarray(sigma, float)
        q6 = (sigma / r) ** 6
        return np.where(r < sigma, -12.0 * self.epsilon / r * (q6 * q6 - q6), 0.0)

    def d2v_dr2(self, r, sigma):
        r, sigma = np.asarray(r, float), np.asarray(sigma, float)
        q6 = (sigma / r) ** 6
        return np.where(r < sigma, 12.0 * self.epsilon / r**2 * (13.0 * q6 * q6 - 7.0 * q6), 0.0)


Potential = Spring | RepulsiveLJ


def _overlap(r, sigma):
    """Dimensionless overlap max(0, 1 - r/sigma)."""
    return np.maximum(0.0, 1.0 - np.asarray(r, float) / np.asarray(sigma, float))


def _check_epsilon(eps):
    if not (math.isfinite(eps) and eps > 0):
        raise ValueError(f"energy scale epsilon must be a finite positive number, got {eps}")


def parse_potential(spec: str) -> Potential:
    """``spring`` | ``hertz`` | ``spring:ALPHA`` | ``rlj`` -> a potential object."""
    text = str(spec).strip().lower()
    if text == "spring":
        return Spring(2.0)
    if text == "hertz":
        return Spring(2.5)
    if text == "rlj":
        return RepulsiveLJ()
    if text.startswith("spring:"):
        try:
            alpha = float(text.split(":", 1)[1])
        except ValueError:
            raise ValueError(f"potential {spec!r}: ALPHA in spring:ALPHA must be a number, e.g. spring:2.5") from None
        return Spring(alpha)
    raise ValueError(f"unknown potential {spec!r}; use spring | hertz | spring:ALPHA | rlj")
