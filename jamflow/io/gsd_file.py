"""A packing as one frame of a HOOMD-blue GSD file (the ``gsd`` package, extra ``jamflow[gsd]``),
read by HOOMD, OVITO, freud and ``gsd.hoomd``.

HOOMD's conventions (gsd 5 ``gsd.hoomd.Frame``): ``configuration.box = [Lx, Ly, Lz, xy, xz, yz]``
with dimensionless tilt factors xy = h_xy / Ly, xz = h_xz / Lz, yz = h_yz / Lz (jamflow's h holds
LAMMPS tilt lengths; the shear strain gamma = xy, not folded), Lz = 0 in 2D; the cell is
centred on the origin, so a position is h (s - 1/2) for fractional coordinates s in [0, 1).
``particles.diameter`` the diameters (float32 in GSD, as every GSD particle field; the box is
float32 too), ``orientation`` unit quaternions (w, x, y, z) as jamflow's (2D angles turn about z),
``typeid`` the distinct sizes in increasing order (types ``A``, ``B``, ...; one type ``A`` beyond
``MAX_TYPES`` sizes), ``type_shapes`` ``Ellipsoid`` semi-axes for ellipses/spheroids. Rigid bodies
follow HOOMD's layout: the N body centres (``body`` = own index, diameter 0) and then their sites
(type ``site``, ``body`` = the centre's index). Every position lies in the box, ``particles.image``
counting the box vectors it was moved by: a site about its wrapped centre that sticks out of the
box is written wrapped, and position + image @ h.T puts the body back together. Lengths in
small diameters.

``packings_from_gsd`` reads such files back (disks, spheres, ellipses, spheroids; every frame),
as ``jamflow analyze``, ``modes`` and ``draw`` do: with GSD's float32 coordinates, so like LAMMPS
files read through MDAnalysis (``jamflow.io.readers``) they carry ~1e-7 relative round-off, harmless
for structure and pictures but not for contact-level quantities of near-jamming packings (use
jamflow's HDF5 file there). The potential is unknown to a GSD file: the linear spring.
"""

from __future__ import annotations

import string
from pathlib import Path

import numpy as np

from jamflow.model.box import Box
from jamflow.model.packing import Packing
from jamflow.model.shapes.parse import parse_shape
from jamflow.support.files import atomic_path

MAX_TYPES = 8


def gsd_module():
    """``gsd.hoomd``, or a ValueError naming the extra to install."""
    try:
        import gsd.hoomd
    except ImportError:
        raise ValueError("--format gsd needs the gsd package: pip install 'jamflow[gsd]' (or pip install gsd)") from None
    return gsd.hoomd


def hoomd_box(packing: Packing) -> list[float]:
    """[Lx, Ly, Lz, xy, xz, yz], HOOMD's tilt factors; Lz = 0 in 2D."""
    h = np.zeros((3, 3))
    h[: packing.dim, : packing.dim] = packing.box.h
    lx, ly, lz = np.diag(h)
    return [lx, ly, lz, h[0, 1] / ly, h[0, 2] / lz if lz else 0.0, h[1, 2] / lz if lz else 0.0]


def hoomd_positions(packing: Packing, positions=None) -> tuple[np.ndarray, np.ndarray]:
    """(M, 3) positions in HOOMD's origin-centred cell and their (M, 3) image flags
    (``Box.images``; walled axes stay as they are); ``positions``: default the particles'."""
    box = packing.box
    inside, image = box.images(packing.positions if positions is None else positions)
    out, flags = np.zeros((len(inside), 3)), np.zeros((len(inside), 3), np.int32)
    out[:, : packing.dim] = inside - box.to_cartesian(np.full(packing.dim, 0.5))
    flags[:, : packing.dim] = image
    return out, flags


def quaternions(packing: Packing) -> np.ndarray:
    """(N, 4) unit quaternions (w, x, y, z); a 2D angle theta is the turn about z; ones for round particles."""
    if packing.orientations is None:
        return np.tile([1.0, 0.0, 0.0, 0.0], (packing.n, 1))
    if packing.dim == 3:
        return np.asarray(packing.orientations, float)
    half = 0.5 * np.asarray(packing.orientations, float)
    return np.column_stack([np.cos(half), np.zeros_like(half), np.zeros_like(half), np.sin(half)])


def _types(packing: Packing) -> tuple[list[str], np.ndarray]:
    values, index = packing.species()
    if len(values) > MAX_TYPES:
        return ["A"], np.zeros(packing.n, int)
    return list(string.ascii_uppercase[: len(values)]), index


def gsd_frame(packing: Packing):
    """One ``gsd.hoomd.Frame`` of ``packing``."""
    frame = gsd_module().Frame()
    frame.configuration.dimensions = packing.dim
    frame.configuration.box = hoomd_box(packing)
    types, typeid = _types(packing)
    (position, image), orientation = hoomd_positions(packing), quaternions(packing)
    diameter, body = packing.diameters.astype(float), np.full(packing.n, -1)
    rows = _ROWS[packing.shape.kind](packing, dict(types=types, typeid=typeid, position=position, image=image,
                                                   orientation=orientation, diameter=diameter, body=body))
    types, typeid, position, image = rows["types"], rows["typeid"], rows["position"], rows["image"]
    orientation, diameter, body, shapes = rows["orientation"], rows["diameter"], rows["body"], rows.get("shapes")
    p = frame.particles
    p.N, p.types, p.typeid = len(position), types, typeid
    p.position, p.image, p.orientation, p.diameter, p.body = position, image, orientation, diameter, body
    if shapes is not None:
        p.type_shapes = shapes
    return frame


def _particle_rows(packing: Packing, rows: dict) -> dict:
    """Disks/spheres: one particle each, as they are."""
    return rows


def _ellipsoid_rows(packing: Packing, rows: dict) -> dict:
    """Ellipses/spheroids: an ``Ellipsoid`` type shape (semi-axes) per type."""
    a, b = packing.shape.axes(packing.diameters).T
    first = [int(np.flatnonzero(rows["typeid"] == t)[0]) for t in range(len(rows["types"]))]
    shapes = [{"type": "Ellipsoid", "a": 0.5 * a[k], "b": 0.5 * b[k], "c": 0.5 * b[k]} for k in first]
    return {**rows, "shapes": shapes}


def _body_rows(packing: Packing, rows: dict) -> dict:
    """Rigid bodies: the centres (diameter 0) then one ``site`` particle per site, ``body`` = its body."""
    centres = packing.box.images(packing.positions)[0]
    sites = packing.shape.world_sites(centres, packing.orientations, packing.diameters)  # about the wrapped centre
    site_position, site_image = hoomd_positions(packing, sites.reshape(-1, packing.dim))
    site_d = (packing.diameters[:, None] * packing.shape.site_diameters[None, :]).reshape(-1)
    types = rows["types"]
    return dict(position=np.concatenate([rows["position"], site_position]),
                image=np.concatenate([rows["image"], site_image]),
                orientation=np.concatenate([rows["orientation"], np.tile([1.0, 0.0, 0.0, 0.0], (len(site_d), 1))]),
                typeid=np.concatenate([rows["typeid"], np.full(len(site_d), len(types))]),
                types=[*types, "site"],
                diameter=np.concatenate([np.zeros(packing.n), site_d]),
                body=np.concatenate([np.arange(packing.n), np.repeat(np.arange(packing.n), sites.shape[1])]))


# shape kind -> (packing, the particle rows) -> the rows of its frame (``shapes``: HOOMD type shapes)
_ROWS = {"sphere": _particle_rows, "ellipsoid": _ellipsoid_rows, "rigid": _body_rows}


def write_gsd(path, packing: Packing) -> Path:
    """Write ``packing`` as a one-frame GSD file, atomically."""
    frame = gsd_frame(packing)
    with atomic_path(path) as tmp, gsd_module().open(name=str(tmp), mode="w") as f:
        f.append(frame)
    return Path(path)


GSD_SUFFIXES = (".gsd",)


def packings_from_gsd(path) -> list[Packing]:
    """Every frame of a GSD file as a Packing (module docstring): the box from HOOMD's
    [Lx, Ly, Lz, xy, xz, yz], positions wrapped into jamflow's cell, ``diameter`` as the
    diameters, ``Ellipsoid`` type shapes as ellipses (2D) or spheroids (3D) with their
    orientations. Rigid bodies (``body`` set) are refused: read them from the jamflow file."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no GSD file {path}")
    hoomd = gsd_module()
    try:
        with hoomd.open(name=str(path), mode="r") as f:
            frames = list(f)
    except Exception as err:  # gsd raises RuntimeError or OSError for files that are not GSD
        raise ValueError(f"{path} is not a GSD file gsd can read ({err})") from None
    if not frames:
        raise ValueError(f"{path} has no frame")
    return [_packing_of_frame(frame, path, k) for k, frame in enumerate(frames)]


def _packing_of_frame(frame, path: Path, k: int) -> Packing:
    dim = int(frame.configuration.dimensions)
    p = frame.particles
    if p.body is not None and np.any(np.asarray(p.body) >= 0):
        raise ValueError(f"{path}: rigid bodies in a GSD file are not read back; use the jamflow packing file "
                         "(jamflow export wrote the GSD file from it)")
    lx, ly, lz, xy, xz, yz = (float(v) for v in frame.configuration.box)
    h = np.array([[lx, xy * ly, xz * lz], [0.0, ly, yz * lz], [0.0, 0.0, lz]])[:dim, :dim]
    box = Box(h)
    position = np.asarray(p.position, float)[:, :dim]
    s = box.to_fractional(position) + 0.5  # HOOMD's cell is centred on the origin
    positions = box.wrap(box.to_cartesian(s))
    diameters = np.asarray(p.diameter, float)
    shape, orientations = parse_shape("disk", dim), None
    shapes = p.type_shapes or []
    if shapes and shapes[0].get("type") == "Ellipsoid":
        alpha = float(f"{float(shapes[0]['a']) / float(shapes[0]['b']):.7g}")  # float32 semi-axes
        shape = parse_shape(f"{'ellipse' if dim == 2 else 'spheroid'}:{alpha!r}", dim)
        q = np.asarray(p.orientation, float)
        orientations = 2.0 * np.arctan2(q[:, 3], q[:, 0]) if dim == 2 else q / np.linalg.norm(q, axis=1)[:, None]
    meta = {"source": str(path), "frame": k, "coordinate_precision": "float32 (GSD)"}
    return Packing(positions, diameters, box, metadata=meta, shape=shape, orientations=orientations)
