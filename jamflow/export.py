"""Packings for viewers: a LAMMPS text dump and extended XYZ, both read by OVITO with radii.

``export_packing(packing, path, fmt)`` with fmt one of ``FORMATS``:

- LAMMPS dump (``lammps-dump``): ``ITEM: ATOMS id type radius x y z`` in a
  (triclinic) ``BOX BOUNDS`` block; OVITO maps ``radius`` to its Radius property.
- Extended XYZ (``xyz``): ``Lattice`` = the three cell vectors,
  ``Properties=species:S:1:pos:R:3:radius:R:1``, ``pbc``.

2D packings get z = 0 and a third cell vector (0, 0, 1) that is not periodic in XYZ.
Types number the distinct diameters (at most ``MAX_TYPES``; continuous polydispersity is
one type, the radius column carries the sizes). Shapes and orientations for nonspherical
particles add columns in ``_columns`` (OVITO reads ``c_shape[1..3]`` / ``quatw quati quatj
quatk`` from dumps and ``aspherical_shape:R:3`` / ``orientation:R:4`` from XYZ).
Lengths in small diameters, full float64 precision (``repr``-exact, 17 digits).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .io import atomic_path
from .packing import Packing

FORMATS = ("lammps-dump", "xyz")
SUFFIXES = {"lammps-dump": ".dump", "xyz": ".xyz"}
MAX_TYPES = 8


def export_packing(packing: Packing, path, fmt: str) -> Path:
    """Write ``packing`` to ``path`` in format ``fmt`` (one of ``FORMATS``), atomically."""
    if fmt not in FORMATS:
        raise ValueError(f"unknown export format {fmt!r}; use one of {', '.join(FORMATS)}")
    text = (_lammps_dump if fmt == "lammps-dump" else _extended_xyz)(packing)
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return Path(path)


def _columns(packing: Packing) -> dict[str, np.ndarray]:
    """Per-particle columns after the position: name -> (N,) values."""
    return {"radius": 0.5 * packing.diameters}


def _types(packing: Packing) -> np.ndarray:
    values, index = packing.species()
    return index + 1 if len(values) <= MAX_TYPES else np.ones(packing.n, int)


def _cell(packing: Packing) -> tuple[np.ndarray, np.ndarray]:
    """3x3 cell (columns = cell vectors) and positions (N, 3), 2D padded with z = 0."""
    h = np.eye(3)
    h[: packing.dim, : packing.dim] = packing.box.h
    pos = np.zeros((packing.n, 3))
    pos[:, : packing.dim] = packing.box.wrap(packing.positions)
    return h, pos


def _lammps_dump(packing: Packing) -> str:
    h, pos = _cell(packing)
    lx, ly, lz = np.diag(h)
    xy, xz, yz = h[0, 1], h[0, 2], h[1, 2]
    zlo = -0.5 if packing.dim == 2 else 0.0
    bounds = [(min(0.0, xy, xz, xy + xz), lx + max(0.0, xy, xz, xy + xz), xy),
              (min(0.0, yz), ly + max(0.0, yz), xz), (zlo, zlo + lz, yz)]
    triclinic = packing.box.is_triclinic
    header = "ITEM: BOX BOUNDS xy xz yz pp pp pp" if triclinic else "ITEM: BOX BOUNDS pp pp pp"
    box = [" ".join(repr(float(v)) for v in (b if triclinic else b[:2])) for b in bounds]
    extra = _columns(packing)
    lines = ["ITEM: TIMESTEP", "0", "ITEM: NUMBER OF ATOMS", str(packing.n), header, *box,
             "ITEM: ATOMS id type x y z " + " ".join(extra)]
    types, columns = _types(packing), np.column_stack(list(extra.values()))
    lines += [f"{k + 1} {types[k]} " + " ".join(repr(float(v)) for v in (*pos[k], *columns[k])) for k in range(packing.n)]
    return "\n".join(lines) + "\n"


def _extended_xyz(packing: Packing) -> str:
    h, pos = _cell(packing)
    lattice = " ".join(repr(float(v)) for v in h.T.ravel())  # a, b, c in turn
    extra = _columns(packing)
    props = "species:S:1:pos:R:3:" + ":".join(f"{name}:R:1" for name in extra)
    pbc = "T T T" if packing.dim == 3 else "T T F"
    comment = (f'Lattice="{lattice}" Properties={props} pbc="{pbc}" phi={packing.phi!r} '
               f'potential={packing.potential.spec} dim={packing.dim}')
    types, columns = _types(packing), np.column_stack(list(extra.values()))
    rows = [f"T{types[k]} " + " ".join(repr(float(v)) for v in (*pos[k], *columns[k])) for k in range(packing.n)]
    return "\n".join([str(packing.n), comment, *rows]) + "\n"
