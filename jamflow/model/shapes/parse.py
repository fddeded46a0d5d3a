"""Shape specs (--shape): the text form of every particle shape, parsed into shape objects."""

from __future__ import annotations

import math

from jamflow.model.shapes.shape import SPHERE, Ellipsoid

SHAPE_USAGE = ("disk | sphere | ellipse:ALPHA (2D) | spheroid:ALPHA (3D) | nmer:N:ALPHA | dimer:ALPHA:S | "
               "trimer:ALPHA:C")


def parse_shape(spec, dim: int, contact: str = "exact"):
    """A ``--shape`` spec -> a shape object for dimension ``dim``. ALPHA = 1 gives the disk/sphere
    (the cheapest exact model of that scene). Rigid n-mers (``nmer``, ``dimer``, ``trimer``):
    ``jamflow.model.shapes.nmers`` defines their parameters and ranges."""
    if not isinstance(spec, str):
        if hasattr(spec, "kind"):
            spec.check(dim)
            return spec
        raise ValueError(f"shape must be a spec string ({SHAPE_USAGE}) or a shape object, got {spec!r}")
    text = spec.strip().lower()
    word, _, rest = text.partition(":")
    if word not in SPECS:
        raise ValueError(f"unknown shape {spec!r}; use {SHAPE_USAGE}")
    return SPECS[word](spec, word, rest, dim, contact)


def _round(spec, word, rest, dim, contact):
    if rest:
        raise ValueError(f"unknown shape {spec!r}; use {SHAPE_USAGE}")
    return SPHERE


def _elliptic(spec, word, rest, dim, contact):
    wanted = {"ellipse": 2, "spheroid": 3}[word]
    if dim != wanted:
        raise ValueError(f"shape {spec!r}: '{word}' is {wanted}D, the packing is {dim}D; use "
                         f"{'spheroid' if dim == 3 else 'ellipse'}:ALPHA")
    try:
        alpha = float(rest)
    except ValueError:
        raise ValueError(f"shape {spec!r}: ALPHA in {word}:ALPHA must be a number, e.g. {word}:1.5") from None
    if not (math.isfinite(alpha) and alpha > 0):
        raise ValueError(f"shape {spec!r}: ALPHA must be a finite number > 0")
    if alpha == 1.0:
        return SPHERE
    shape = Ellipsoid(alpha, contact)
    shape.check(dim)
    return shape


def _body(spec, word, rest, dim, contact):
    from jamflow.model.shapes.nmers import parse_body

    return parse_body(spec, word, rest.split(":") if rest else [], dim)


# the first word of a --shape spec -> its parser (spec, word, the rest after ':', dim, contact)
SPECS = {"disk": _round, "sphere": _round, "ellipse": _elliptic, "spheroid": _elliptic,
         "nmer": _body, "dimer": _body, "trimer": _body}
