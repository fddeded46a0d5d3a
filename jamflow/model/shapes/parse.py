"""Shape specs (--shape): the text form of every particle shape, parsed into shape objects."""

from __future__ import annotations

from jamflow.model.shapes.nmers import BODIES, parse_body
from jamflow.model.shapes.shape import SHAPES

SHAPE_USAGE = " | ".join(cls.spec_usage for cls in SHAPES.values())


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
    word, _, rest = text.partition(":")
    shape = SPECS[word](spec, word, rest, dim, contact) if word in SPECS else None
    if shape is None:
        raise ValueError(f"unknown shape {spec!r}; use {SHAPE_USAGE}")
    return shape


def _body(spec, word, rest, dim, contact):
    return parse_body(spec, word, rest.split(":") if rest else [], dim)


# the first word of a --shape spec -> its parser (spec, word, the rest after ':', dim, contact), None if not its spec:
# each shape class's ``spec_words``, and the rigid bodies of ``shapes.nmers``
SPECS = {**{word: cls.from_spec for cls in SHAPES.values() for word in cls.spec_words},
         **{word: _body for word in BODIES}}
