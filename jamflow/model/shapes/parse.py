"""Shape specs (--shape): the text form of every particle shape, parsed into shape objects."""

from __future__ import annotations

from jamflow.model.shapes.nmers import BODIES, parse_body
from jamflow.model.shapes.shape import SHAPES

SHAPE_USAGE = " | ".join(cls.spec_usage for cls in SHAPES.values())


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
