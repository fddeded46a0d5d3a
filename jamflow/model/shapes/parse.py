"""Shape specs (--shape): the text form of every particle shape, parsed into shape objects."""

from __future__ import annotations

import math

from jamflow.model.shapes.shape import SPHERE, Ellipsoid

SHAPE_USAGE = ("disk | sphere | ellipse:ALPHA (2D) | spheroid:ALPHA (3D) | nmer:N:ALPHA | dimer:ALPHA:S | "
               "trimer:ALPHA:C")


def parse_shape(spec, dim: int, contact: str = "exact"):
    """A ``--shape`` spec -> a shape object for dimension ``dim``. ALPHA = 1 gives the disk/sphere
    (the cheapest exact model of that scene). Rigid n-mers (``nmer``, ``dimer``, ``trimer``):
    ``jamflow.model.shapes.nmers`` defines their parameters and ranges.

    Parameters
    ----------
    spec : str or Sphere, Ellipsoid, RigidBody
        ``disk`` | ``sphere`` | ``ellipse:ALPHA`` (2D) | ``spheroid:ALPHA`` (3D) |
        ``nmer:N:ALPHA`` | ``dimer:ALPHA:S`` | ``trimer:ALPHA:C``; ALPHA (> 0) is the aspect
        ratio a / b. A shape object is checked for ``dim`` and returned as it is.
    dim : int
        2 or 3, the packing's dimension.
    contact : str, default "exact"
        The contact-distance approximation of ellipses and spheroids (``contact_distance``'s
        ``method``).

    Returns
    -------
    Sphere, Ellipsoid or RigidBody
        The sphere shape (disk in 2D) for disks, spheres and ALPHA = 1, an ``Ellipsoid`` or a
        rigid body.

    Raises
    ------
    ValueError
        An unknown or malformed spec, or a shape of the other dimension.
    """
    if not isinstance(spec, str):
        if hasattr(spec, "kind"):
            spec.check(dim)
            return spec
        raise ValueError(f"shape must be a spec string ({SHAPE_USAGE}) or a shape object, got {spec!r}")
    text = spec.strip().lower()
    kind, _, rest = text.partition(":")
    if kind in ("disk", "sphere") and not rest:
        return SPHERE
    if kind in ("ellipse", "spheroid"):
        wanted = 2 if kind == "ellipse" else 3
        if dim != wanted:
            raise ValueError(f"shape {spec!r}: '{kind}' is {wanted}D, the packing is {dim}D; use "
                             f"{'spheroid' if dim == 3 else 'ellipse'}:ALPHA")
        try:
            alpha = float(rest)
        except ValueError:
            raise ValueError(f"shape {spec!r}: ALPHA in {kind}:ALPHA must be a number, e.g. {kind}:1.5") from None
        if not (math.isfinite(alpha) and alpha > 0):
            raise ValueError(f"shape {spec!r}: ALPHA must be a finite number > 0")
        if alpha == 1.0:
            return SPHERE
        shape = Ellipsoid(alpha, contact)
        shape.check(dim)
        return shape
    if kind in ("nmer", "dimer", "trimer"):
        from jamflow.model.shapes.nmers import parse_body

        return parse_body(spec, kind, rest.split(":") if rest else [], dim)
    raise ValueError(f"unknown shape {spec!r}; use {SHAPE_USAGE}")
