"""Short reprs (stdlib only): settings show the fields that differ from their defaults, so that
``repr(CompressionSettings())`` is ``CompressionSettings()`` and any other value is one line that
rebuilds it (``eval`` with the classes in scope)."""

from __future__ import annotations

import dataclasses


def _default(f: dataclasses.Field):
    if f.default is not dataclasses.MISSING:
        return f.default
    if f.default_factory is not dataclasses.MISSING:
        return f.default_factory()
    return dataclasses.MISSING


def _same(a, b) -> bool:
    try:
        return bool(a == b)
    except (TypeError, ValueError):  # arrays and other values without one truth value
        return False


def changed_fields_repr(obj) -> str:
    """``Class(name=value, ...)`` of the ``repr=True`` fields of dataclass ``obj`` that differ from their defaults."""
    parts = [f"{f.name}={getattr(obj, f.name)!r}" for f in dataclasses.fields(obj)
             if f.repr and not _same(getattr(obj, f.name), _default(f))]
    return f"{type(obj).__name__}({', '.join(parts)})"
