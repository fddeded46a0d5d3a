"""Which engine runs a scene: the compiled FIRE (``NumbaEngine``) where it is exact for the
scene (spring potential, orthogonal box, FIRE, one process), LAMMPS everywhere else.

``engine="auto"`` (default) picks by that rule; ``"lammps"`` or ``"numba"`` force one
(forcing numba on a scene it cannot run is an error raised before any work).
"""

from __future__ import annotations

from ..packing import Packing

ENGINES = ("auto", "lammps", "numba")


def check_engine(engine: str) -> None:
    if engine not in ENGINES:
        raise ValueError(f"unknown engine {engine!r}; use one of {', '.join(ENGINES)}")


def engine_name(packing: Packing, method: str, engine: str = "auto", comm=None) -> str:
    """'numba' or 'lammps' for this scene; ValueError if 'numba' is forced where it cannot run."""
    from .native import unsupported_reason

    check_engine(engine)
    reason = unsupported_reason(packing, method, comm)
    if engine == "numba" and reason:
        raise ValueError(f"engine numba cannot run {reason}; use engine lammps (or auto)")
    if engine == "numba" or (engine == "auto" and reason is None):
        return "numba"
    return "lammps"


def open_engine(packing: Packing, method: str = "fire", engine: str = "auto", **options):
    """A new engine holding ``packing``; ``options`` go to LammpsEngine (skin, comm, args)
    or NumbaEngine (skin)."""
    if engine_name(packing, method, engine, options.get("comm")) == "numba":
        from .native import NumbaEngine

        return NumbaEngine(packing, **{k: v for k, v in options.items() if k == "skin"})
    from .lammps import LammpsEngine

    return LammpsEngine(packing, **options)
