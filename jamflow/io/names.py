"""Names of the files jamflow derives from packings: ``NAME.KIND.h5`` (and ``NAME.KIND.png``,
``NAME.KIND-TABLE.csv``) beside the input ``NAME.h5`` (or ``NAME.data``, ``NAME.dump``), one
rule for every command (``modes``, ``moduli``, ``analyze``, ``shear``). A directory or several
inputs derive from their common directory DIR: ``DIR/DIRNAME.KIND.h5``. Commands that read a
directory of packings take its ``*.h5`` files that are not derived (``packing_files``)."""

from __future__ import annotations

import os
from pathlib import Path

DERIVED_KINDS = ("modes", "moduli", "structure", "shear")  # result files of modes, moduli, analyze, shear


def derived_path(sources, kind: str, suffix: str = ".h5") -> Path:
    """``NAME.KIND`` + ``suffix`` for the input path ``sources`` (beside it, NAME its stem), or for
    several inputs or a directory, in their common directory and named after it."""
    if kind not in DERIVED_KINDS:
        raise ValueError(f"unknown derived file kind {kind!r}; one of {', '.join(DERIVED_KINDS)}")
    paths = [Path(sources)] if isinstance(sources, (str, os.PathLike)) else [Path(s) for s in sources]
    if len(paths) == 1 and not paths[0].is_dir():
        return paths[0].with_name(f"{paths[0].stem}.{kind}{suffix}")
    parents = {p.parent for p in paths}
    if len(paths) == 1:
        folder = paths[0]
    elif len(parents) == 1:
        folder = parents.pop()
    else:
        folder = Path(os.path.commonpath([p.resolve().parent for p in paths]))
    return folder / f"{folder.resolve().name or 'root'}.{kind}{suffix}"


def is_derived(path) -> bool:
    """Whether ``path`` is named as a derived result file (``NAME.KIND.h5``, ``.hdf5`` too)."""
    name = Path(path)
    return name.suffix.lower() in (".h5", ".hdf5") and Path(name.stem).suffix[1:] in DERIVED_KINDS


def without_derived(paths) -> tuple[list, list]:
    """(inputs, skipped): the paths given, without those named as derived files (a shell glob
    ``runs/*.h5`` after ``jamflow modes`` also matches ``runs/p.modes.h5``)."""
    paths = list(paths)
    return [p for p in paths if not is_derived(p)], [p for p in paths if is_derived(p)]


def packing_files(directory) -> list[Path]:
    """The packing files of a directory: its ``*.h5`` files but the derived ones, sorted."""
    return sorted(p for p in Path(directory).glob("*.h5") if not is_derived(p))


def check_packing_name(path, option: str = "--out") -> None:
    """Refuse (ValueError, before any work) a packing output ``path`` named as a derived result
    file (``x.shear.h5``): every command that reads packings would refuse or skip it."""
    if is_derived(path):
        path = Path(path)
        kind = Path(path.stem).suffix[1:]
        other = path.with_name(f"{Path(path.stem).stem}-{kind}{path.suffix}")
        raise ValueError(f"{option} {path} is named like a derived {kind} file (NAME.{kind}.h5): the commands that "
                         f"read packings would refuse or skip it; choose another {option} such as {other}")

