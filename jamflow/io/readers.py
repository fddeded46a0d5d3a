"""Packings from LAMMPS data and dump files, read through MDAnalysis.

Diameters come from a per-atom column -- ``diameter`` (or ``radius``) in a dump, the
diameter column of an ``atom_style sphere`` data file -- or from a ``{type: diameter}``
mapping you pass, which takes precedence. Without either, a ValueError says what to pass.

Precision: MDAnalysis stores coordinates (and the data-file diameter column, read through
its charge slot) as float32, so packings read this way carry ~1e-7 relative round-off.
That is harmless for g(r), S(k) and order parameters; for contact-level quantities of
near-jamming packings (overlaps ~1e-8) use jamflow's own HDF5 files (jamflow.io.packing_file).
The dimension is taken from ``dim`` or, if None, inferred: 2 when every z coordinate is equal.
The potential is unknown to a LAMMPS file: packings get jamflow's default (linear spring),
which structure analysis does not use.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np

from jamflow.model.box import Box
from jamflow.model.packing import Packing

DATA_SUFFIXES = (".data", ".dat", ".lmp", ".lammps")
DUMP_SUFFIXES = (".dump", ".lammpstrj", ".lammpsdump", ".trj")
# the sphere style's columns, with the diameter column passed through MDAnalysis's charge slot
SPHERE_STYLE = "id type charge density x y z"


def lammps_format(path) -> str:
    """'data' or 'dump', from the suffix or else the first line (dumps start with ITEM:)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in DATA_SUFFIXES:
        return "data"
    if suffix in DUMP_SUFFIXES:
        return "dump"
    with open(path, "r", errors="replace") as fh:
        return "dump" if fh.readline().startswith("ITEM:") else "data"


def packings_from_lammps(path, format: str | None = None, *, diameters: dict | None = None,
                         dim: int | None = None) -> list[Packing]:
    """Every frame of a LAMMPS dump (or the one configuration of a data file) as Packings."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no LAMMPS file {path}")
    fmt = format or lammps_format(path)
    if fmt not in ("data", "dump"):
        raise ValueError(f"format must be 'data' or 'dump', got {format!r}")
    if dim not in (None, 2, 3):
        raise ValueError(f"dim must be 2, 3 or None (infer), got {dim!r}")
    mapping = _check_mapping(diameters)
    sphere = fmt == "data" and mapping is None and _is_sphere_data(path)
    out = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # MDAnalysis warns about guessed masses, elements and dt
        universe = _universe(path, fmt, sphere)
        for ts in universe.trajectory:
            column = np.asarray(universe.atoms.charges, float) if sphere else _dump_diameters(ts)
            d = _diameters(universe.atoms.types, column, mapping, path)
            out.append(_packing(ts.positions.astype(float), ts.triclinic_dimensions.astype(float), d, dim, path,
                                int(ts.frame)))
    return out


def packing_from_lammps(path, format: str | None = None, *, diameters: dict | None = None,
                        dim: int | None = None, frame: int = -1) -> Packing:
    """One configuration (default: the last frame) of a LAMMPS data or dump file."""
    frames = packings_from_lammps(path, format, diameters=diameters, dim=dim)
    try:
        return frames[frame]
    except IndexError:
        raise ValueError(f"{path} has {len(frames)} frame(s); frame {frame} does not exist") from None


def _check_mapping(diameters):
    if diameters is None:
        return None
    try:
        mapping = {str(k).strip(): float(v) for k, v in dict(diameters).items()}
    except (TypeError, ValueError):
        raise ValueError("diameters must map atom types to numbers, e.g. {1: 1.0, 2: 1.4}") from None
    if not all(math.isfinite(v) and v > 0 for v in mapping.values()):
        raise ValueError("every diameter in the type mapping must be a positive number")
    return mapping


def _universe(path: Path, fmt: str, sphere: bool):
    import MDAnalysis as mda

    if fmt == "dump":
        columns = _dump_columns(path)
        extra = [c for c in ("diameter", "radius") if c in columns]
        return mda.Universe(str(path), format="LAMMPSDUMP", topology_format="LAMMPSDUMP",
                            additional_columns=extra or None)
    kwargs = {"atom_style": SPHERE_STYLE} if sphere else {}
    try:
        return mda.Universe(str(path), format="DATA", topology_format="DATA", **kwargs)
    except Exception as err:  # MDAnalysis raises several types for unknown atom styles
        raise ValueError(f"MDAnalysis could not read {path} as a LAMMPS data file ({err}); for atom styles "
                         "other than atomic/full/sphere convert it with LAMMPS write_dump") from None


def _dump_columns(path: Path) -> list[str]:
    with open(path, "r", errors="replace") as fh:
        for line in fh:
            if line.startswith("ITEM: ATOMS"):
                return line.split()[2:]
    raise ValueError(f"{path} has no 'ITEM: ATOMS' line; is it a LAMMPS dump?")


def _is_sphere_data(path: Path) -> bool:
    with open(path, "r", errors="replace") as fh:
        for line in fh:
            if line.strip().startswith("Atoms"):
                return "sphere" in line
    return False


def _dump_diameters(ts):
    data = getattr(ts, "data", {})
    if "diameter" in data:
        return np.asarray(data["diameter"], float)
    if "radius" in data:
        return 2.0 * np.asarray(data["radius"], float)
    return None


def _diameters(types, column, mapping, path) -> np.ndarray:
    if mapping is not None:
        missing = sorted(set(map(str, types)) - set(mapping))
        if missing:
            raise ValueError(f"{path}: no diameter given for atom type(s) {', '.join(missing)}; "
                             "pass every type in the mapping, e.g. --diameters 1:1.0,2:1.4")
        return np.array([mapping[str(t)] for t in types])
    if column is None:
        raise ValueError(f"{path} has no per-atom diameter (dump column 'diameter'/'radius' or an atom_style "
                         "sphere data file); pass a type -> diameter mapping, e.g. --diameters 1:1.0,2:1.4")
    return column


def _packing(positions, triclinic, diameters, dim, path, frame) -> Packing:
    if dim is None:
        dim = 2 if np.ptp(positions[:, 2]) == 0 else 3
    h = np.array(triclinic, float).T  # MDAnalysis rows are cell vectors; jamflow columns are
    h[np.abs(h) < 1e-6 * np.abs(np.diag(h)).max()] = 0.0  # float32 dust in the zero tilts
    if np.any(np.tril(h, -1) != 0):
        raise ValueError(f"{path}: the cell is not a LAMMPS (upper-triangular) cell")
    box = Box(h[:dim, :dim])
    meta = {"source": str(path), "frame": frame, "coordinate_precision": "float32 (MDAnalysis)"}
    return Packing(box.wrap(positions[:, :dim]), diameters, box, metadata=meta)
