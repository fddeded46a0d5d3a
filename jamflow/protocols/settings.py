"""Settings of the compression protocol: the chapter's (``chapter``) and the fast one."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

from jamflow.minimize.settings import MinimizerSettings
from jamflow.model.shapes.parse import parse_shape
from jamflow.support.reprs import changed_fields_repr
from jamflow.support.settings_errors import SettingError

DEFAULT_PHI0 = {2: 0.80, 3: 0.55}


GRAVITY_PHI0 = {2: 0.5, 3: 0.35}  # random starts under gravity: the settled pile stays clear of the ceiling


BODY_PHI0 = {2: 0.45, 3: 0.25}  # rigid bodies start without overlaps (random sequential addition): below its limit


@dataclass(frozen=True)
class CompressionSettings:
    """Parameters of the compression protocol (dimensionless packing fractions;
    energies per particle in eps)."""

    phi0: float | None = None  #: initial packing fraction; None: ``DEFAULT_PHI0[dim]``, well below phi_J
    dphi0: float = 1e-4  #: initial packing-fraction increment Delta phi
    v_tol: float = 1e-16  #: V_tol of the window V_tol < V < 2 V_tol, energy per particle in eps
    max_steps: int = 100_000  #: most compression or decompression steps before the protocol gives up
    #: factor by which Delta phi grows below jamming until the first crossing; 1: the chapter's constant increment
    dphi_growth: float = 1.0
    dphi_max: float = 1e-3  #: cap on the grown increment
    newton: bool = False  #: above jamming, jump to the predicted window from V and P (the fast protocol)
    newton_ratio: float = 20.0  #: a Newton jump shrinks phi - phi_J by at most this factor (so it stays jammed)
    # ... and at most by this one from large_n particles on: a long jump from a jammed state of many particles
    # ends in an avalanche that FIRE follows for 1e5 iterations (docs/notes/newton-krylov.md, jump ratio)
    large_n_newton_ratio: float = 3.0  #: the same cap from ``large_n`` particles on
    large_n: int = 2048  #: number of particles from which ``large_n_newton_ratio`` applies
    #: before the first crossing, V below this (eps) counts as unjammed; None: the minimiser's v_min
    coarse_v_min: float | None = None
    #: before the final approach the force tolerance is this times the pressure; None: the minimiser's
    approach_force_rtol: float | None = None
    #: force tolerance before the first crossing when ``approach_force_rtol`` is set, eps / diameter
    coarse_force_tol: float = 1e-10
    minimizer: MinimizerSettings = field(default_factory=MinimizerSettings)  #: settings of each minimisation

    __repr__ = changed_fields_repr  # only the fields that differ from their defaults

    def __post_init__(self):
        for name in ("phi0", "dphi0", "v_tol"):
            value = getattr(self, name)
            if name == "phi0" and value is None:
                continue
            if not (isinstance(value, (int, float)) and math.isfinite(value)):
                raise SettingError(name, f"must be a finite number, got {value!r}")
        if self.phi0 is not None and not 0.0 < self.phi0 < 1.0:
            raise SettingError("phi0", f"must lie in (0, 1), got {self.phi0}")
        if not 0.0 < self.dphi0 < 0.1:
            raise SettingError("dphi0", f"must lie in (0, 0.1), got {self.dphi0}; the chapter uses 1e-4")
        if not self.v_tol > 0:
            raise SettingError("v_tol", f"must be positive, got {self.v_tol}; the chapter uses 1e-16")
        if not (math.isfinite(self.dphi_growth) and self.dphi_growth >= 1.0):
            raise SettingError("dphi_growth", f"must be >= 1 (1 = the chapter's constant increment), got "
                                              f"{self.dphi_growth}")
        if not (math.isfinite(self.dphi_max) and self.dphi_max > 0):
            raise SettingError("dphi_max", f"must be a finite positive number, got {self.dphi_max}")
        if self.minimizer.v_min > self.v_tol:
            raise ValueError(f"minimizer v_min = {self.minimizer.v_min:g} is above v_tol = {self.v_tol:g}: every "
                             "state in the window would be stopped as unjammed; set MinimizerSettings(v_min=v_tol)")
        if self.coarse_v_min is not None and not (math.isfinite(self.coarse_v_min) and self.coarse_v_min > 2 * self.v_tol):
            raise ValueError(f"coarse_v_min must be a finite number above 2 v_tol = {2 * self.v_tol:g}, got "
                             f"{self.coarse_v_min}; or None (no coarse stage)")
        for name in ("newton_ratio", "large_n_newton_ratio"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 1):
                raise ValueError(f"{name} must be a finite number > 1, got {value!r}")
        if isinstance(self.large_n, bool) or not isinstance(self.large_n, int) or self.large_n < 2:
            raise ValueError(f"large_n must be an integer >= 2, got {self.large_n!r}")
        if self.max_steps < 1:
            raise ValueError("max_steps must be a positive integer")

    def jump_ratio(self, n: int) -> float:
        """The largest factor by which a Newton jump shrinks phi - phi_J for ``n`` particles."""
        return min(self.newton_ratio, self.large_n_newton_ratio) if n >= self.large_n else self.newton_ratio

    def start_phi(self, dim: int, gravity: float = 0.0, shape=None) -> float:
        """phi0, or the default start for this dimension (a looser one under gravity, and for
        rigid bodies, which start without overlaps)."""
        if self.phi0 is not None:
            return self.phi0
        if gravity:
            return GRAVITY_PHI0.get(dim, math.nan)
        rigid = shape is not None and dim in (2, 3) and parse_shape(shape, dim).made_of_sites
        return (BODY_PHI0 if rigid else DEFAULT_PHI0).get(dim, math.nan)

    def as_dict(self) -> dict:
        """The settings as plain values (JSON-serialisable), the minimiser's nested."""
        out = {k: v for k, v in asdict(self).items() if k != "minimizer"}
        return {**out, **self.minimizer.as_dict()}


FAST_PROTOCOL = dict(dphi_growth=2.0, dphi_max=1e-3, newton=True, newton_ratio=10.0,
                     coarse_v_min=1e-10, approach_force_rtol=1e-5)


def chapter_protocol(**overrides) -> CompressionSettings:
    """The chapter's protocol exactly: constant dphi0 until the first crossing, halving."""
    return CompressionSettings(**overrides)


def fast_protocol(**overrides) -> CompressionSettings:
    """Same stopping rule, fewer and cheaper minimisations (docs/notes/speed.md measures its bias).
    The coarse stage (``coarse_v_min``, above 2 V_tol) is left out for a ``v_tol`` that is not below
    half of it, unless ``coarse_v_min`` is given."""
    settings = {**FAST_PROTOCOL, **overrides}
    v_tol = settings.get("v_tol", CompressionSettings.v_tol)
    if "coarse_v_min" not in overrides and isinstance(v_tol, (int, float)) and 2 * v_tol >= settings["coarse_v_min"]:
        settings["coarse_v_min"] = None
    return CompressionSettings(**settings)


PROTOCOLS = {"chapter": chapter_protocol, "fast": fast_protocol}

PROTOCOL_NAMES = tuple(sorted(PROTOCOLS))  # what --protocol accepts


def protocol_settings(name: str, **overrides) -> CompressionSettings:
    """The settings of the protocol ``name`` (``chapter`` or ``fast``)."""
    try:
        make = PROTOCOLS[name]
    except KeyError:
        raise ValueError(f"unknown protocol {name!r}; use one of {', '.join(PROTOCOL_NAMES)}") from None
    return make(**overrides)


# "fast" is the default since 20 seeds at N = 256 gave mean phi_J 0.83820 +- 0.00063 against
# 0.83784 +- 0.00064 for "chapter" (paired difference +0.00036 +- 0.00074), 4x faster in the median,
# and at N = 1024 0.84018 +- 0.00027 against 0.83980 +- 0.00039 (paired +0.00039 +- 0.00042),
# 3.5x fewer iterations: docs/notes/protocol-bias-n256.csv, -n1024.csv, made by benchmarks/protocol_bias.py.
DEFAULT_PROTOCOL = "fast"
