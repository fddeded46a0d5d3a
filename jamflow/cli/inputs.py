"""Packing inputs that several commands read (``analyze``, ``modes``, ``draw``): jamflow HDF5
packing files, LAMMPS data / dump files (``jamflow.io.readers``, through MDAnalysis) and GSD files
(``jamflow.io.gsd_file``, as ``jamflow export --format gsd`` writes them), with the options that
describe the LAMMPS ones (--format, --diameters, --dim) declared once."""

from __future__ import annotations

import math
from pathlib import Path

import h5py

from jamflow.io.gsd_file import GSD_SUFFIXES, packings_from_gsd
from jamflow.io.packing_file import load_packing
from jamflow.io.readers import packings_from_lammps

FORMATS = ("auto", "jamflow", "data", "dump", "gsd")
HDF5_SUFFIXES = (".h5", ".hdf5")


def add_input_arguments(p, dump: str = "every frame is one packing") -> None:
    """--format, --diameters, --dim; ``dump`` says what the command makes of a dump's frames."""
    p.add_argument("--format", choices=FORMATS, default="auto",
                   help=f"input format (auto: HDF5, or by suffix: .gsd GSD, else LAMMPS); LAMMPS dump and GSD: {dump}")
    p.add_argument("--diameters", default=None,
                   help="LAMMPS input without a diameter column: TYPE:DIAMETER,... e.g. 1:1.0,2:1.4")
    p.add_argument("--dim", type=int, choices=(2, 3), default=None, help="LAMMPS input: dimension (default: infer)")


def parse_diameters(text: str | None) -> dict | None:
    """'1:1.0,2:1.4' -> {'1': 1.0, '2': 1.4}."""
    if text is None:
        return None
    try:
        pairs = [item.split(":") for item in text.split(",") if item.strip()]
        mapping = {t.strip(): float(d) for t, d in pairs}
    except ValueError:
        raise ValueError(f"--diameters {text!r}: write TYPE:DIAMETER pairs separated by commas, e.g. 1:1.0,2:1.4") from None
    if not mapping or not all(math.isfinite(v) and v > 0 for v in mapping.values()):
        raise ValueError(f"--diameters {text!r}: every diameter must be a positive number")
    return mapping


def is_jamflow_file(name, fmt: str = "auto") -> bool:
    """Whether ``name`` is read as a jamflow HDF5 packing: --format jamflow, or auto and HDF5 (or an
    HDF5 suffix, so that a damaged .h5 gets load_packing's message, not a LAMMPS parser's)."""
    return fmt == "jamflow" or (fmt == "auto" and (h5py.is_hdf5(name) or Path(name).suffix.lower() in HDF5_SUFFIXES))


def is_gsd_file(name, fmt: str = "auto") -> bool:
    """Whether ``name`` is read as a GSD file: --format gsd, or auto and a .gsd suffix."""
    return fmt == "gsd" or (fmt == "auto" and Path(name).suffix.lower() in GSD_SUFFIXES)


def _frames(name, fmt, diameters, dim) -> list:
    """Every configuration of a GSD or LAMMPS file."""
    if is_gsd_file(name, fmt):
        return packings_from_gsd(name)
    return packings_from_lammps(name, None if fmt == "auto" else fmt, diameters=diameters, dim=dim)


def _check_found(files) -> None:
    missing = [str(f) for f in files if not Path(f).is_file()]
    if missing:
        raise FileNotFoundError(f"input file(s) not found: {', '.join(missing)}")


def load_inputs(files, fmt: str = "auto", diameters=None, dim=None) -> tuple[list, list[str]]:
    """All packings of all files (every frame of a dump), with a label (file name, and #frame for
    dumps) for each."""
    _check_found(files)
    packings, labels = [], []
    for name in files:
        if is_jamflow_file(name, fmt):
            packings.append(load_packing(name))
            labels.append(Path(name).name)
            continue
        frames = _frames(name, fmt, diameters, dim)
        packings += frames
        labels += [Path(name).name if len(frames) == 1 else f"{Path(name).name}#{k}" for k in range(len(frames))]
    return packings, labels


def load_input(name, fmt: str = "auto", diameters=None, dim=None):
    """One packing from one file: a jamflow packing, a LAMMPS data file, or the last frame of a
    dump or GSD file."""
    _check_found([name])
    if is_jamflow_file(name, fmt):
        return load_packing(name)
    return _frames(name, fmt, diameters, dim)[-1]
