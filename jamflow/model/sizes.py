"""Particle size distributions (diameters in units of the small diameter).

Specs (CLI ``--sizes``):
- ``mono``: every diameter 1.
- ``bi:RATIO:FRACTION_SMALL``: round(FRACTION_SMALL * N) diameters 1, the rest RATIO
  (seed: ``bi:1.4:0.5`` for 50:50 and ``bi:1.4:0.6667`` for the 2:1 mixture).
- ``poly-uniform:WIDTH``: uniform on [1, 1 + WIDTH] (the chapter's "p = 1.4" is WIDTH 0.4).
- ``poly-normal:WIDTH[:MEAN]``: normal, mean MEAN (default 1), standard deviation WIDTH,
  truncated to diameters > MEAN/10 by redrawing.
- ``poly-lognormal:WIDTH[:MEAN]``: log-normal with mean MEAN (default 1) and standard
  deviation WIDTH of the diameter itself.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SizeSpec:
    """A size distribution (``parse_sizes``): its kind and parameters, diameters in units of the small one."""

    kind: str  #: mono | bi | poly-uniform | poly-normal | poly-lognormal
    params: tuple[float, ...] = ()  #: bi: (RATIO, FRACTION_SMALL); poly-uniform: (WIDTH,); poly-normal, poly-lognormal: (WIDTH, MEAN)

    @property
    def spec(self) -> str:
        """The spec string, e.g. ``bi:1.4:0.5``."""
        return ":".join([self.kind, *(f"{p:g}" for p in self.params)])

    @property
    def discrete(self) -> bool:
        """True when diameters take a few fixed values (LAMMPS atom types)."""
        return self.kind in ("mono", "bi")

    def draw(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """N diameters; deterministic for a given generator state."""
        if self.kind == "mono":
            return np.ones(n)
        if self.kind == "bi":
            ratio, frac = self.params
            n_small = int(round(frac * n))
            return np.concatenate([np.ones(n_small), np.full(n - n_small, ratio)])
        if self.kind == "poly-uniform":
            return 1.0 + self.params[0] * rng.random(n)
        width, mean = self.params
        if self.kind == "poly-lognormal":
            s2 = math.log1p((width / mean) ** 2)
            return rng.lognormal(math.log(mean) - 0.5 * s2, math.sqrt(s2), n)
        out = rng.normal(mean, width, n)
        while np.any(bad := out <= 0.1 * mean):
            out[bad] = rng.normal(mean, width, int(bad.sum()))
        return out


def parse_sizes(spec: str) -> SizeSpec:
    """Parse a ``--sizes`` spec (see module docstring); errors say what to write instead.

    Parameters
    ----------
    spec : str
        ``mono``, ``bi:RATIO:FRACTION_SMALL`` (RATIO >= 1, the large / small diameter;
        FRACTION_SMALL in [0, 1]), ``poly-uniform:WIDTH``, ``poly-normal:WIDTH[:MEAN]`` (WIDTH
        <= MEAN / 2) or ``poly-lognormal:WIDTH[:MEAN]``; WIDTH >= 0 and MEAN > 0 in diameters.

    Returns
    -------
    SizeSpec
        The distribution; ``SizeSpec.draw`` gives N diameters (the small diameter = 1).

    Raises
    ------
    ValueError
        An unknown kind, the wrong number of parameters, or parameters out of range.
    """
    text = str(spec).strip().lower()
    kind, *fields = text.split(":")
    usage = "use mono | bi:RATIO:FRACTION_SMALL | poly-uniform:WIDTH | poly-normal:WIDTH[:MEAN] | poly-lognormal:WIDTH[:MEAN]"
    try:
        values = tuple(float(f) for f in fields)
    except ValueError:
        raise ValueError(f"size spec {spec!r}: parameters must be numbers; {usage}") from None
    if any(not math.isfinite(v) for v in values):
        raise ValueError(f"size spec {spec!r}: parameters must be finite; {usage}")
    if kind == "mono" and not values:
        return SizeSpec("mono")
    if kind == "bi" and len(values) == 2:
        ratio, frac = values
        if ratio < 1.0:
            raise ValueError(f"size spec {spec!r}: RATIO (large/small diameter) must be >= 1")
        if not 0.0 <= frac <= 1.0:
            raise ValueError(f"size spec {spec!r}: FRACTION_SMALL must lie in [0, 1]")
        return SizeSpec("bi", values)
    if kind == "poly-uniform" and len(values) == 1:
        if values[0] < 0:
            raise ValueError(f"size spec {spec!r}: WIDTH must be >= 0")
        return SizeSpec(kind, values)
    if kind in ("poly-normal", "poly-lognormal") and len(values) in (1, 2):
        width, mean = (values + (1.0,))[:2]
        if width < 0 or mean <= 0:
            raise ValueError(f"size spec {spec!r}: WIDTH must be >= 0 and MEAN > 0")
        if kind == "poly-normal" and width > 0.5 * mean:
            raise ValueError(f"size spec {spec!r}: a normal WIDTH above MEAN/2 puts much weight on "
                             "non-positive diameters; use poly-lognormal for wide distributions")
        return SizeSpec(kind, (width, mean))
    raise ValueError(f"unknown size spec {spec!r}; {usage}")
