"""Functions a lower layer calls but a higher one provides: the dependency turned round by
registration, not import (docs/architecture.md). A name is registered once, by the package that
may import the provider (``jamflow/__init__.py``, outside the layers, registers ``save_result``:
``JamResult.save`` in ``protocols`` writes through the packing file of ``io``, above it)."""

from __future__ import annotations

_HOOKS: dict = {}


def register(name: str, function) -> None:
    """Provide ``function`` under ``name`` (a second registration replaces the first)."""
    _HOOKS[name] = function


def call(name: str, *args, **kwargs):
    """Call the function registered under ``name``; a RuntimeError if none is."""
    try:
        function = _HOOKS[name]
    except KeyError:
        raise RuntimeError(f"nothing provides {name!r}: it is registered by `import jamflow` "
                           f"(jamflow/__init__.py)") from None
    return function(*args, **kwargs)
