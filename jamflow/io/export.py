"""Packings for viewers: a LAMMPS text dump and extended XYZ, both read by OVITO with radii,
shapes and orientations; and the LAMMPS data file a simulation starts from.

``export_packing(packing, path, fmt)`` with fmt one of ``FORMATS``:

- LAMMPS dump (``lammps-dump``): ``ITEM: ATOMS id type x y z radius ...`` in a (triclinic)
  ``BOX BOUNDS`` block.
- Extended XYZ (``xyz``): ``Lattice`` = the three cell vectors, ``Properties=species:S:1:pos:R:3:
  radius:R:1...``, ``pbc``.
- LAMMPS data file (``lammps-data``): ``jamflow.engines.lammps.data_file.write_lammps_data``
  (atom_style sphere, ellipsoid, or hybrid sphere molecular for rigid bodies).
- HOOMD-blue GSD (``gsd``): ``jamflow.io.gsd_file.write_gsd`` (needs the ``gsd`` package).

Ellipses/spheroids add their axes and quaternions (``_rows``); rigid bodies are written one row
per site with the body as molecule id. Every position lies in the box the file describes (``h``'s
own cell, ``Box.images``), the last columns being its image flags (dump ``ix iy iz``, XYZ
``image:I:3``): a site of a body about its wrapped centre that sticks out of the box is written
wrapped, and position + image @ h.T puts the body back together. Measured with OVITO 3.17.2 (``ovito.io.import_file``):
dump ``shapex..z`` are read as full axes and halved into Aspherical Shape, XYZ
``aspherical_shape`` is taken as semi-axes; dump ``quatw quati quatj quatk`` and XYZ
``orientation`` (x, y, z, w) both give Orientation; ``mol`` / ``molecule`` give Molecule
Identifier. 2D packings get z = 0, a third cell vector (0, 0, 1) that is not periodic in XYZ, and
2D angles become turns about z. Types number the distinct sizes (at most ``MAX_TYPES``; continuous
polydispersity is one type, the radius column carries the sizes). Lengths in small diameters,
full float64 precision (``repr``-exact, 17 digits).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from jamflow.engines.lammps.data_file import write_lammps_data
from jamflow.io.gsd_file import write_gsd
from jamflow.model.packing import Packing
from jamflow.support.files import atomic_path

FORMATS = ("lammps-dump", "xyz", "lammps-data", "gsd")
SUFFIXES = {"lammps-dump": ".dump", "xyz": ".xyz", "lammps-data": ".data", "gsd": ".gsd"}
MAX_TYPES = 8


def export_packing(packing: Packing, path, fmt: str) -> Path:
    """Write ``packing`` to ``path`` in format ``fmt`` (one of ``FORMATS``), atomically."""
    if fmt not in FORMATS:
        raise ValueError(f"unknown export format {fmt!r}; use one of {', '.join(FORMATS)}")
    if fmt == "lammps-data":
        return write_lammps_data(path, packing)
    if fmt == "gsd":
        return write_gsd(path, packing)
    text = (_lammps_dump if fmt == "lammps-dump" else _extended_xyz)(packing)
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return Path(path)


@dataclass(frozen=True)
class _Column:
    """One per-row property: its LAMMPS dump column names, its extended-XYZ name and (M, k) values."""

    dump: tuple[str, ...]
    xyz: str
    values: np.ndarray
    kind: str = "R"


def _quaternions(packing: Packing) -> np.ndarray:
    """(N, 4) unit quaternions (w, x, y, z); a 2D angle theta is the turn about z."""
    if packing.dim == 3:
        return np.asarray(packing.orientations, float)
    half = 0.5 * np.asarray(packing.orientations, float)
    return np.column_stack([np.cos(half), np.zeros_like(half), np.zeros_like(half), np.sin(half)])


def _rows(packing: Packing) -> tuple[np.ndarray, np.ndarray, list[_Column]]:
    """Rows to write: positions (M, 3), types (M,) and the columns after the position.

    Spheres: one row per particle with its radius. Ellipses/spheroids: one row per particle with
    its full axes (dump ``shapex..z``, which OVITO halves) or semi-axes (XYZ ``aspherical_shape``)
    and its quaternion (dump ``quatw..k``, XYZ ``orientation`` in OVITO's x, y, z, w order); a 2D
    ellipse's third axis is its minor one. Rigid bodies: one row per site (radius, ``mol`` = body),
    sites placed about the wrapped body centre and wrapped into the box themselves, with image flags
    that put the body back together. Last, every row's image flags (``_in_box``).
    """
    return _ROWS[packing.shape.kind](packing, _types(packing))


def _particle_rows(packing: Packing, types: np.ndarray):
    """Disks/spheres: one row per particle with its radius."""
    pos, image = _in_box(packing, packing.positions)
    return pos, types, [_Column(("radius",), "radius", (0.5 * packing.diameters)[:, None]), _images(image)]


def _ellipsoid_rows(packing: Packing, types: np.ndarray):
    """Ellipses/spheroids: radius, full axes and quaternion."""
    pos, image = _in_box(packing, packing.positions)
    a, b = packing.shape.axes(packing.diameters).T
    columns = [_Column(("radius",), "radius", (0.5 * packing.diameters)[:, None]),
               _Column(("shapex", "shapey", "shapez"), "aspherical_shape", np.column_stack([a, b, b])),
               _Column(("quatw", "quati", "quatj", "quatk"), "orientation", _quaternions(packing))]
    return pos, types, [*columns, _images(image)]


def _site_rows(packing: Packing, types: np.ndarray):
    """Rigid bodies: one row per site (radius, ``mol`` = body) about the wrapped body centre."""
    centres = packing.box.images(packing.positions)[0]
    sites = packing.shape.world_sites(centres, packing.orientations, packing.diameters)
    pos, image = _in_box(packing, sites.reshape(-1, packing.dim))
    n_sites = sites.shape[1]
    radius = 0.5 * packing.diameters[:, None] * packing.shape.site_diameters[None, :]
    body = np.repeat(np.arange(1, packing.n + 1), n_sites)
    return pos, np.repeat(types, n_sites), [_Column(("radius",), "radius", radius.reshape(-1, 1)),
                                            _Column(("mol",), "molecule", body[:, None], "I"), _images(image)]


# shape kind -> (packing, types) -> (positions, types, columns) of the rows it exports
_ROWS = {"sphere": _particle_rows, "ellipsoid": _ellipsoid_rows, "rigid": _site_rows}


def _images(image: np.ndarray) -> _Column:
    """The image flags column: dump ``ix iy iz`` (LAMMPS's names, OVITO's Periodic Image), XYZ ``image``."""
    return _Column(("ix", "iy", "iz"), "image", image, "I")


def _xyz_values(column: _Column) -> np.ndarray:
    """The values as extended XYZ stores them for OVITO: semi-axes, quaternion (x, y, z, w)."""
    if column.xyz == "aspherical_shape":
        return 0.5 * column.values
    if column.xyz == "orientation":
        return column.values[:, [1, 2, 3, 0]]
    return column.values


def _table(pos: np.ndarray, columns: list[_Column], values: list[np.ndarray]) -> list[str]:
    """One text row per particle/site: position then every column, float64 repr-exact."""
    def cells(k):
        for c, v in zip(columns, values):
            yield from (str(int(x)) if c.kind == "I" else repr(float(x)) for x in v[k])
    return [" ".join([*(repr(float(x)) for x in pos[k]), *cells(k)]) for k in range(len(pos))]


def _types(packing: Packing) -> np.ndarray:
    values, index = packing.species()
    return index + 1 if len(values) <= MAX_TYPES else np.ones(packing.n, int)


def _cell(packing: Packing) -> np.ndarray:
    """3x3 cell (columns = cell vectors), 2D padded with (0, 0, 1)."""
    h = np.eye(3)
    h[: packing.dim, : packing.dim] = packing.box.h
    return h


def _in_box(packing: Packing, positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(M, 3) ``positions`` in the cell of ``_cell`` and their (M, 3) image flags (``Box.images``),
    2D padded with z = 0 and image 0."""
    inside, image = packing.box.images(positions)
    pos, flags = np.zeros((len(inside), 3)), np.zeros((len(inside), 3), np.int64)
    pos[:, : packing.dim], flags[:, : packing.dim] = inside, image
    return pos, flags


def _lammps_dump(packing: Packing) -> str:
    h = _cell(packing)
    lx, ly, lz = np.diag(h)
    xy, xz, yz = h[0, 1], h[0, 2], h[1, 2]
    zlo = -0.5 if packing.dim == 2 else 0.0
    bounds = [(min(0.0, xy, xz, xy + xz), lx + max(0.0, xy, xz, xy + xz), xy),
              (min(0.0, yz), ly + max(0.0, yz), xz), (zlo, zlo + lz, yz)]
    triclinic = packing.box.is_triclinic
    header = "ITEM: BOX BOUNDS xy xz yz pp pp pp" if triclinic else "ITEM: BOX BOUNDS pp pp pp"
    box = [" ".join(repr(float(v)) for v in (b if triclinic else b[:2])) for b in bounds]
    pos, types, columns = _rows(packing)
    names = " ".join(name for c in columns for name in c.dump)
    lines = ["ITEM: TIMESTEP", "0", "ITEM: NUMBER OF ATOMS", str(len(pos)), header, *box,
             "ITEM: ATOMS id type x y z " + names]
    rows = _table(pos, columns, [c.values for c in columns])
    lines += [f"{k + 1} {types[k]} {row}" for k, row in enumerate(rows)]
    return "\n".join(lines) + "\n"


def _extended_xyz(packing: Packing) -> str:
    h = _cell(packing)
    lattice = " ".join(repr(float(v)) for v in h.T.ravel())  # a, b, c in turn
    pos, types, columns = _rows(packing)
    props = "species:S:1:pos:R:3:" + ":".join(f"{c.xyz}:{c.kind}:{c.values.shape[1]}" for c in columns)
    pbc = "T T T" if packing.dim == 3 else "T T F"
    comment = (f'Lattice="{lattice}" Properties={props} pbc="{pbc}" phi={packing.phi!r} '
               f'potential={packing.potential.spec} dim={packing.dim} shape="{packing.shape.spec(packing.dim)}"')
    rows = _table(pos, columns, [_xyz_values(c) for c in columns])
    return "\n".join([str(len(pos)), comment, *(f"T{types[k]} {row}" for k, row in enumerate(rows))]) + "\n"
