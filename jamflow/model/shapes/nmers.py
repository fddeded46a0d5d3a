"""Rigid n-mers of fused disks/spheres (chapter section 2.3.1, Figure 2.9 (b)-(d)) and their specs.

Figure 2.9 names the parameters alpha = L / D, s = D2 / D1 and c = h / L; it leaves the
reference lengths open, so jamflow fixes them as follows (lengths at scale 1; ``--sizes``
multiplies whole bodies):

- ``nmer:N:ALPHA`` (linear n-mer, Figure 2.9 b): N sites of diameter D = 1 on a line, equally
  spaced; L is the tip-to-tip length, so the site spacing is l = D (ALPHA - 1) / (N - 1).
  This is the dimer of Schreck, Xu and O'Hern, Soft Matter 6, 2960 (2010) for N = 2
  (alpha = 1 + l / D, 1 <= alpha <= 2). Range 1 < ALPHA <= N: at ALPHA = 1 the sites coincide
  (the spec gives the disk/sphere), at ALPHA = N neighbouring sites only touch.
- ``dimer:ALPHA:S`` (asymmetric dimer, Figure 2.9 c): sites D1 = 1 (the larger) and D2 = S D1,
  L = D1 / 2 + l + D2 / 2 the tip-to-tip length, ALPHA = L / D1. Range 0 < S <= 1 and
  1 < ALPHA <= 1 + S (at ALPHA = 1 the small site lies inside the large one: the disk/sphere;
  at 1 + S the sites only touch). S = 1 is ``nmer:2:ALPHA``.
- ``trimer:ALPHA:C`` (bent trimer, Figure 2.9 d): three sites of diameter D = 1, the outer two
  at (-+(L - D) / 2, 0) and the middle one at (0, h) above the midpoint of the line joining
  them; L is the tip-to-tip length of the outer sites along that line (ALPHA = L / D, as for the
  linear trimer, which is C = 0) and h = C L the height of the bend. Range 1 < ALPHA <= 3 and
  0 <= C <= C_max(ALPHA) = sqrt(1 - ((ALPHA - 1) / 2)^2) / ALPHA, where the middle site still
  touches the outer ones (a2 + h2 <= D2 with a = (L - D) / 2).

In 3D the same sites lie in the body's x-y plane. ``RigidBody`` moves them to the union's
centre of mass and principal axes.
"""

from __future__ import annotations

import math

from jamflow.model.shapes.shape import SPHERE, RigidBody

NMER_USAGE = "nmer:N:ALPHA (linear, N >= 2 sites, 1 < ALPHA <= N; ALPHA = L/D, L the tip-to-tip length)"
DIMER_USAGE = "dimer:ALPHA:S (asymmetric, S = D2/D1 in (0, 1], 1 < ALPHA <= 1 + S; ALPHA = L/D1)"
TRIMER_USAGE = ("trimer:ALPHA:C (bent, 1 < ALPHA <= 3, 0 <= C <= sqrt(1 - ((ALPHA - 1)/2)^2)/ALPHA; "
                "C = h/L, h the middle site's height above the line of the outer sites)")


def _numbers(spec: str, fields: list[str], usage: str) -> list[float]:
    try:
        values = [float(f) for f in fields]
    except ValueError:
        raise ValueError(f"shape {spec!r}: parameters must be numbers; use {usage}") from None
    if not all(math.isfinite(v) for v in values):
        raise ValueError(f"shape {spec!r}: parameters must be finite; use {usage}")
    return values


def _zeros(dim: int) -> list[float]:
    return [0.0] * (dim - 2)


def linear_nmer(n: int, alpha: float, dim: int, spec: str | None = None):
    """N equal sites on a line, tip-to-tip length ALPHA (diameter 1); ALPHA = 1 is the disk/sphere."""
    spec = spec or f"nmer:{n:g}:{alpha:g}"
    if not float(n).is_integer() or n < 2:
        raise ValueError(f"shape {spec!r}: an n-mer needs an integer N >= 2 sites, got {n:g}; use {NMER_USAGE}")
    n = int(n)
    if alpha == 1.0:
        return SPHERE
    if not 1.0 < alpha <= n:
        raise ValueError(f"shape {spec!r}: ALPHA = {alpha:g} is outside 1 < ALPHA <= {n} for {n} sites "
                         f"(below 1 the sites would pass through each other, above {n} they come apart); use {NMER_USAGE}")
    spacing = (alpha - 1.0) / (n - 1)
    sites = [[k * spacing, 0.0, *_zeros(dim)] for k in range(n)]
    return RigidBody(sites, [1.0] * n, f"nmer:{n}:{alpha:g}")


def asymmetric_dimer(alpha: float, s: float, dim: int, spec: str | None = None):
    """Sites of diameters 1 and S <= 1, tip-to-tip length ALPHA; ALPHA = 1 is the disk/sphere."""
    spec = spec or f"dimer:{alpha:g}:{s:g}"
    if s > 1.0:
        raise ValueError(f"shape {spec!r}: S = D2/D1 = {s:g} > 1, but D1 is the larger site; the same body is "
                         f"dimer:{alpha / s:g}:{1 / s:g} with --sizes scaled by {s:g}; use {DIMER_USAGE}")
    if not s > 0.0:
        raise ValueError(f"shape {spec!r}: S = D2/D1 must lie in (0, 1], got {s:g}; use {DIMER_USAGE}")
    if alpha == 1.0:
        return SPHERE
    if not 1.0 < alpha <= 1.0 + s:
        raise ValueError(f"shape {spec!r}: ALPHA = {alpha:g} is outside 1 < ALPHA <= 1 + S = {1 + s:g} "
                         "(at 1 the small site lies inside the large one, above 1 + S the sites come apart); "
                         f"use {DIMER_USAGE}")
    bond = alpha - 0.5 - 0.5 * s
    return RigidBody([[0.0, 0.0, *_zeros(dim)], [bond, 0.0, *_zeros(dim)]], [1.0, s], f"dimer:{alpha:g}:{s:g}")


def trimer_max_bend(alpha: float) -> float:
    """C_max(ALPHA): the largest c = h / L at which the middle site still touches the outer ones."""
    return math.sqrt(max(0.0, 1.0 - ((alpha - 1.0) / 2.0) ** 2)) / alpha


def bent_trimer(alpha: float, c: float, dim: int, spec: str | None = None):
    """Outer sites at -+(ALPHA - 1) / 2 on x, the middle one at height C ALPHA (diameter 1)."""
    spec = spec or f"trimer:{alpha:g}:{c:g}"
    if not 1.0 < alpha <= 3.0:
        raise ValueError(f"shape {spec!r}: ALPHA = {alpha:g} is outside 1 < ALPHA <= 3 (at 1 the outer sites "
                         "coincide, above 3 they cannot both touch the middle one); use " + TRIMER_USAGE)
    if c < 0.0:
        raise ValueError(f"shape {spec!r}: C = {c:g} < 0 is the trimer with C = {-c:g} turned by 180 degrees; "
                         f"use trimer:{alpha:g}:{-c:g}")
    c_max = trimer_max_bend(alpha)
    if c > c_max * (1.0 + 1e-12):
        raise ValueError(f"shape {spec!r}: C = {c:g} is above C_max({alpha:g}) = {c_max:.6g}, where the middle site "
                         f"comes apart from the outer ones; use 0 <= C <= {c_max:.6g} ({TRIMER_USAGE})")
    half = 0.5 * (alpha - 1.0)
    sites = [[-half, 0.0, *_zeros(dim)], [0.0, c * alpha, *_zeros(dim)], [half, 0.0, *_zeros(dim)]]
    return RigidBody(sites, [1.0, 1.0, 1.0], f"trimer:{alpha:g}:{c:g}")


def parse_body(spec: str, kind: str, fields: list[str], dim: int):
    """The body of an ``nmer:``, ``dimer:`` or ``trimer:`` spec (``kind`` and its ``fields``)."""
    usage = {"nmer": NMER_USAGE, "dimer": DIMER_USAGE, "trimer": TRIMER_USAGE}[kind]
    if len(fields) != 2:
        raise ValueError(f"shape {spec!r}: {kind} takes two parameters; use {usage}")
    first, second = _numbers(spec, fields, usage)
    return BODIES[kind](first, second, dim, spec)


BODIES = {"nmer": linear_nmer, "dimer": asymmetric_dimer, "trimer": bent_trimer}  # spec word -> its body
