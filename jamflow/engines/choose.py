"""Which engine runs a scene: the names, the check, and opening one (the contract is engines.base)."""

from __future__ import annotations

ENGINES = ("auto", "lammps", "numba")


def check_engine(engine: str) -> None:
    """ValueError unless ``engine`` is one of ``ENGINES``."""
    if engine not in ENGINES:
        raise ValueError(f"unknown engine {engine!r}; use one of {', '.join(ENGINES)}")


def engine_class(name: str):
    """The class of engine ``name``: ``CompiledEngine`` for "numba", else ``LammpsEngine`` (imported on use)."""
    if name == "numba":
        from jamflow.engines.compiled.engine import CompiledEngine

        return CompiledEngine
    from jamflow.engines.lammps.engine import LammpsEngine

    return LammpsEngine


def engine_name(packing, method: str = "fire", engine: str = "auto", comm=None, pressure: bool = False) -> str:
    """'numba' or 'lammps' for this scene (``pressure``: with the box relaxed at a target
    pressure); ValueError if a forced engine cannot run it."""
    check_engine(engine)
    if engine != "auto":
        reason = engine_class(engine).CAPABILITIES.reason(packing, method, comm, pressure)
        if reason:
            other = "lammps" if engine == "numba" else "numba"
            raise ValueError(f"engine {engine} cannot run {reason}; use engine {other} (or auto)")
        return engine
    for name in ("numba", "lammps"):
        if engine_class(name).CAPABILITIES.reason(packing, method, comm, pressure) is None:
            return name
    raise ValueError(f"no engine runs this scene: compiled: "
                     f"{engine_class('numba').CAPABILITIES.reason(packing, method, comm, pressure)}; lammps: "
                     f"{engine_class('lammps').CAPABILITIES.reason(packing, method, comm, pressure)}")


def open_engine(packing, method: str = "fire", engine: str = "auto", pressure: bool = False, **options):
    """A new engine holding ``packing``. ``options`` go to the engine's constructor
    (LAMMPS: skin, comm, args; compiled: skin, threads); an option the chosen engine does not take is
    an error, not silently dropped. ``pressure``: the engine must relax the box with ``method``."""
    name = engine_name(packing, method, engine, options.get("comm"), pressure)
    cls = engine_class(name)
    unknown = set(options) - cls.CAPABILITIES.options
    if unknown:
        raise ValueError(f"engine {name} takes no option {', '.join(sorted(unknown))} (it takes "
                         f"{', '.join(sorted(cls.CAPABILITIES.options))})")
    return cls(packing, **options)
