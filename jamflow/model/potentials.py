"""Purely repulsive contact potentials of the chapter, each written once.

A potential is a law of the reduced distance s = r / sigma_ij (sigma_ij the contact
distance: (a_i + a_j)/2 for disks and spheres, the exact ellipse contact distance for
ellipses): V(s) > 0 for s < 1 and V = 0 for s >= 1. Energies in epsilon.

- ``Spring(alpha)``: V = eps/alpha (1 - s)^alpha  (chapter eq. 2.1; alpha = 2 linear,
  alpha = 5/2 Hertzian).
- ``RepulsiveLJ``: V = eps [s^-12 - 2 s^-6 + 1]  (chapter eq. 2.2).

The law of each potential is one pair of plain functions of (s, params) --
``energy_force`` (V and dV/ds) and ``curvature`` (d2V/ds2) -- valid for s < 1, written with
arithmetic only, so that numpy evaluates them on arrays (the reference engine, the Hessian)
and numba compiles the very same source for the compiled engine
(``jamflow.engines.compiled.laws``). The other engines' forms -- the C++ plugin
(``engine/plugin/pair_jamflow.cpp``) and the lepton expression below -- are tested against
these functions (tests/test_plugin.py). A new potential is one class here (with its law,
``lepton`` and ``plugin_style``) and its C++ law in the plugin.

``parse_potential`` reads the CLI spec: ``spring``, ``hertz``, ``spring:ALPHA``, ``rlj``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np


# --- the laws: plain functions of s = r / sigma (s < 1) and a NamedTuple of parameters ---------
class SpringParams(NamedTuple):
    """The numbers of the spring law, as the compiled kernels take them."""

    alpha: float  #: exponent (2 the linear spring, 5/2 Hertzian)
    epsilon: float  #: energy scale eps


def spring_energy_force(s, p: SpringParams):
    """V = eps/alpha (1 - s)^alpha and dV/ds = -eps (1 - s)^(alpha - 1) (chapter eq. 2.1). The linear
    spring is written with integer constants, so that exact rational s (``fractions.Fraction``) stays
    exact: the reference of the double-double kernel (tests/test_ddouble.py); for floats the bits are
    those of 0.5 eps x x (halving is exact)."""
    return spring_of_overlap(1 - s, p)


def spring_of_overlap(x, p: SpringParams):
    """``spring_energy_force`` at the reduced overlap x = 1 - s = (sigma - r) / sigma, for an x known
    more precisely than a float64 s carries it (double-double overlaps: at x ~ 1e-14, s = 1 - x keeps
    ~2 digits of x)."""
    if p.alpha == 2.0:
        return p.epsilon * x * x / 2, -p.epsilon * x
    return p.epsilon / p.alpha * x**p.alpha, -p.epsilon * x ** (p.alpha - 1.0)


def spring_curvature(s, p: SpringParams):
    """d2V/ds2 = eps (alpha - 1) (1 - s)^(alpha - 2); diverges at contact for alpha < 2."""
    return spring_curvature_of_overlap(1.0 - s, p)


def spring_curvature_of_overlap(x, p: SpringParams):
    """``spring_curvature`` at the reduced overlap x = 1 - s (``spring_of_overlap``)."""
    return p.epsilon * (p.alpha - 1.0) * x ** (p.alpha - 2.0)


def overlap_law_params(potential) -> SpringParams:
    """The parameters of ``potential`` for the laws of the reduced overlap: double-double overlaps
    are evaluated for the spring law only (ValueError for another)."""
    if not isinstance(potential.params, SpringParams):
        raise ValueError(f"double-double overlaps are evaluated for the spring law, not {potential.spec!r}")
    return potential.params


class RLJParams(NamedTuple):
    """The number of the repulsive Lennard-Jones law, as the compiled kernels take it."""

    epsilon: float  #: energy scale eps


def rlj_energy_force(s, p: RLJParams):
    """V = eps (s^-6 - 1)^2 = eps [s^-12 - 2 s^-6 + 1] (chapter eq. 2.2; the square form has no
    cancellation near contact) and dV/ds = -12 eps s^-6 (s^-6 - 1) / s."""
    q6 = 1.0 / (s * s * s * s * s * s)
    return p.epsilon * (q6 - 1.0) * (q6 - 1.0), -12.0 * p.epsilon * q6 * (q6 - 1.0) / s


def rlj_curvature(s, p: RLJParams):
    """d2V/ds2 = 12 eps (13 s^-12 - 7 s^-6) / s^2."""
    q6 = 1.0 / (s * s * s * s * s * s)
    return 12.0 * p.epsilon * (13.0 * q6 * q6 - 7.0 * q6) / (s * s)


# --- potential objects: the law plus what the engines need ------------------------------------
class _Law:
    """Vectorised V(r, sigma), dV/dr, d2V/dr2 (numpy) from the law of s = r / sigma."""

    def _reduced(self, r, sigma):
        r, sigma = np.broadcast_arrays(np.asarray(r, float), np.asarray(sigma, float))
        s = r / sigma
        inside = s < 1.0
        return np.where(inside, s, 0.5), sigma, inside  # 0.5: a harmless point outside contact

    def energy(self, r, sigma):
        """V(r) in eps; zero for r >= sigma."""
        s, _, inside = self._reduced(r, sigma)
        return np.where(inside, self.energy_force(s, self.params)[0], 0.0)

    def dv_dr(self, r, sigma):
        """dV/dr = V'(s) / sigma (negative: repulsive), eps / length."""
        s, sigma, inside = self._reduced(r, sigma)
        return np.where(inside, self.energy_force(s, self.params)[1] / sigma, 0.0)

    def d2v_dr2(self, r, sigma):
        """d2V/dr2 = V''(s) / sigma^2, eps / length^2."""
        s, sigma, inside = self._reduced(r, sigma)
        return np.where(inside, self.curvature(s, self.params) / sigma**2, 0.0)


@dataclass(frozen=True)
class Spring(_Law):
    """Repulsive spring V = eps/alpha (1 - r/sigma)^alpha for r < sigma (chapter eq. 2.1)."""

    alpha: float = 2.0  #: exponent: 2 the linear spring, 5/2 Hertzian
    epsilon: float = 1.0  #: energy scale eps

    name = "spring"  #: the law's name in files and on the command line
    soft_start = False  #: False: finite forces at any overlap, so random starts need no relaxation
    Params = SpringParams
    energy_force = staticmethod(spring_energy_force)
    curvature = staticmethod(spring_curvature)

    def __post_init__(self):
        if not (isinstance(self.alpha, (int, float)) and math.isfinite(self.alpha) and self.alpha > 1.0):
            raise ValueError(f"spring exponent alpha must be a finite number > 1, got {self.alpha!r}")
        _check_epsilon(self.epsilon)

    @property
    def params(self) -> SpringParams:
        """(alpha, epsilon) as the compiled kernels take them."""
        return SpringParams(float(self.alpha), float(self.epsilon))

    @property
    def spec(self) -> str:
        """The ``--potential`` string: ``spring``, ``hertz`` or ``spring:ALPHA``."""
        return "hertz" if self.alpha == 2.5 else ("spring" if self.alpha == 2.0 else f"spring:{self.alpha:g}")

    @property
    def contact_stiffness(self) -> float:
        """Scale of d2V/dr2 near contact (eps/diameter^2); sets the force round-off floor."""
        return self.epsilon

    @property
    def onset_exponent(self) -> float:
        """V ~ (phi - phi_J)^alpha just above jamming."""
        return self.alpha

    @property
    def lepton(self) -> str:
        """``lepton/sphere`` expression (``max``, not ``step``: a negative base to a
        non-integer power is NaN, and step(...) * NaN stays NaN beyond contact)."""
        return f"E/A*max(0,1-r/(radi+radj))^A; E={float(self.epsilon)!r}; A={float(self.alpha)!r}"

    def plugin_style(self, cutoff: float) -> str:
        """Arguments of ``pair_style`` for jamflow's C++ plugin."""
        return f"jamflow/spring {float(self.alpha)!r} {float(cutoff)!r}"


@dataclass(frozen=True)
class RepulsiveLJ(_Law):
    """Repulsive Lennard-Jones V = eps[(s/r)^12 - 2(s/r)^6 + 1] for r < s (chapter eq. 2.2)."""

    epsilon: float = 1.0  #: energy scale eps

    name = "rlj"  #: the law's name in files and on the command line
    spec = "rlj"  #: the ``--potential`` string
    alpha = math.nan  #: NaN: no spring exponent (stored as NaN in packing files)
    soft_start = True  #: True: forces diverge as r -> 0, so random starts are relaxed first (the chapter's step 1)
    Params = RLJParams
    energy_force = staticmethod(rlj_energy_force)
    curvature = staticmethod(rlj_curvature)
    onset_exponent = 2.0  #: V ~ (phi - phi_J)^2 just above jamming: harmonic at small overlap, V ~ 36 eps (1 - s)^2

    def __post_init__(self):
        _check_epsilon(self.epsilon)

    @property
    def params(self) -> RLJParams:
        """(epsilon,) as the compiled kernels take it."""
        return RLJParams(float(self.epsilon))

    @property
    def contact_stiffness(self) -> float:
        """d2V/dr2 at r = sigma is 72 eps/sigma^2: forces carry 72x the round-off of springs."""
        return 72.0 * self.epsilon

    @property
    def lepton(self) -> str:
        """``lepton/sphere`` expression of the law for LAMMPS."""
        return f"E*(max(1,(radi+radj)/r)^6-1)^2; E={float(self.epsilon)!r}"

    def plugin_style(self, cutoff: float) -> str:
        """Arguments of ``pair_style`` for jamflow's C++ plugin."""
        return f"jamflow/rlj {float(cutoff)!r}"


Potential = Spring | RepulsiveLJ
POTENTIALS = {"spring": Spring, "rlj": RepulsiveLJ}  # name -> class, for files and the CLI


def _check_epsilon(eps):
    if not (isinstance(eps, (int, float)) and math.isfinite(eps) and eps > 0):
        raise ValueError(f"energy scale epsilon must be a finite positive number, got {eps!r}")


def potential_from_attrs(name: str, alpha: float, epsilon: float) -> Potential:
    """The potential a packing file describes (root attributes potential, alpha, epsilon)."""
    if name in ("spring", "hertz") or name.startswith("spring:"):
        return Spring(float(alpha), float(epsilon))
    if name == "rlj":
        return RepulsiveLJ(float(epsilon))
    raise ValueError(f"unknown potential {name!r} in packing file; this jamflow knows {', '.join(POTENTIALS)}")


def parse_potential(spec: str) -> Potential:
    """``spring`` | ``hertz`` | ``spring:ALPHA`` | ``rlj`` -> a potential object.

    Parameters
    ----------
    spec : str
        ``spring`` (harmonic, alpha = 2), ``hertz`` (alpha = 5/2), ``spring:ALPHA`` (any
        exponent) or ``rlj`` (repulsive Lennard-Jones); case and surrounding blanks are ignored.

    Returns
    -------
    Spring or RepulsiveLJ
        The pair law with energy scale eps = 1.

    Raises
    ------
    ValueError
        Not a string, an unknown name, or an ALPHA that is not a number.
    """
    if not isinstance(spec, str):
        raise ValueError(f"potential must be a spec string such as 'spring' or a Spring/RepulsiveLJ object, "
                         f"got {spec!r}")
    text = spec.strip().lower()
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
