"""LAMMPS data files of packings (``read_data``): what the LAMMPS engine starts from, and what
``jamflow export --format lammps-data`` and the decks write. Lengths in small diameters; each
particle (rigid body) has mass 1."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from jamflow import __version__
from jamflow.model.packing import Packing, warn_float64_only
from jamflow.support.files import atomic_path


def write_lammps_data(path, packing: Packing) -> Path:
    """LAMMPS data file of ``packing``; types number the distinct sizes; mass 1 per particle.

    - disks/spheres: ``atom_style sphere`` (id type diameter density x y z);
    - ellipses/spheroids: ``atom_style ellipsoid`` (id type 1 density x y z) and an
      ``Ellipsoids`` section (id a b b qw qx qy qz: full lengths, body x along the director);
    - rigid bodies: ``atom_style hybrid sphere molecular``, one atom per site
      (id type x y z diameter density molecule ix iy iz), atom id k S + s + 1 for site s of body
      k, molecule = body, types number the distinct site diameters; site s carries the fraction
      ``RigidBody.site_masses[s]`` of the body's mass 1, so the mass-weighted site centre (LAMMPS's
      rigid-body centre) is the union's centre of mass; image flags keep each body whole.
    Densities use LAMMPS's 3D volumes (also in 2D), so the masses come out as stated."""
    warn_float64_only(packing, "a LAMMPS data file")
    values, n_atoms, counts, atoms = ATOM_STYLES[packing.shape.kind](packing)
    box = packing.box.to_lammps()
    lines = [f"jamflow {__version__} packing, phi = {packing.phi:.17g}, shape {packing.shape.spec(packing.dim)}", "",
             f"{n_atoms} atoms", f"{len(values)} atom types", *counts]
    lines += ["", f"{box['xlo']:.17g} {box['xhi']:.17g} xlo xhi", f"{box['ylo']:.17g} {box['yhi']:.17g} ylo yhi",
              f"{box['zlo']:.17g} {box['zhi']:.17g} zlo zhi"]
    if packing.box.is_triclinic:
        lines.append(f"{box['xy']:.17g} {box['xz']:.17g} {box['yz']:.17g} xy xz yz")
    lines += atoms
    with atomic_path(path) as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    return Path(path)


def _sphere_atoms(packing: Packing):
    """(type sizes, atom count, extra count lines, the Atoms section) of disks/spheres."""
    values, types = packing.species()
    n, pos = packing.n, _xyz(packing.box.wrap(packing.positions))
    vol = np.pi * packing.diameters**3 / 6.0  # LAMMPS sphere mass = density * 4/3 pi r^3, also in 2D
    lines = ["", "Atoms # sphere", ""]
    lines += [f"{k + 1} {types[k] + 1} {packing.diameters[k]:.17g} {1.0 / vol[k]:.17g} "
              f"{_row(pos[k])}" for k in range(n)]
    return values, n, [], lines


def _ellipsoid_atoms(packing: Packing):
    """Ellipses/spheroids: the Atoms and Ellipsoids sections."""
    values, types = packing.species()
    n, pos = packing.n, _xyz(packing.box.wrap(packing.positions))
    a, b = packing.shape.axes(packing.diameters).T
    quat = lammps_quaternions(packing)
    lines = ["", "Atoms # ellipsoid", ""]
    lines += [f"{k + 1} {types[k] + 1} 1 {6.0 / (np.pi * a[k] * b[k] * b[k]):.17g} {_row(pos[k])}" for k in range(n)]
    lines += ["", "Ellipsoids", ""]
    lines += [f"{k + 1} {a[k]:.17g} {b[k]:.17g} {b[k]:.17g} {_row(quat[k])}" for k in range(n)]
    return values, n, [f"{n} ellipsoids"], lines


def _body_atoms(packing: Packing):
    """Rigid bodies: one atom per site, types by site diameter, molecule = body, image flags."""
    n, shape, cell = packing.n, packing.shape, packing.box.reduced()  # image flags count cells of the box LAMMPS holds
    site_d = packing.diameters[:, None] * shape.site_diameters[None, :]
    values, types = np.unique(site_d, return_inverse=True)
    types = types.reshape(site_d.shape)
    atoms = n * shape.n_sites
    sites = shape.world_sites(packing.box.wrap(packing.positions), packing.orientations, packing.diameters)
    inside, image = cell.images(sites.reshape(-1, packing.dim))
    inside = _xyz(inside)
    image = image if packing.dim == 3 else np.column_stack([image, np.zeros(len(image), int)])
    mass = np.tile(shape.site_masses, n)
    density = mass / (np.pi * site_d.ravel() ** 3 / 6.0)
    lines = ["", "Atoms # hybrid", ""]
    lines += [f"{a + 1} {types.flat[a] + 1} {_row(inside[a])} {site_d.flat[a]:.17g} {density[a]:.17g} "
              f"{a // shape.n_sites + 1} {image[a, 0]} {image[a, 1]} {image[a, 2]}" for a in range(atoms)]
    return values, atoms, [], lines


# shape kind -> its atom style: packing -> (type sizes, atom count, extra count lines, sections)
ATOM_STYLES = {"sphere": _sphere_atoms, "ellipsoid": _ellipsoid_atoms, "rigid": _body_atoms}


def lammps_quaternions(packing: Packing) -> np.ndarray:
    """(N, 4) quaternions (w, x, y, z) of the particles as LAMMPS stores them (2D: about z)."""
    o = packing.orientations
    if packing.dim == 3:
        return o
    return np.column_stack([np.cos(o / 2), np.zeros(len(o)), np.zeros(len(o)), np.sin(o / 2)])


def _xyz(pos: np.ndarray) -> np.ndarray:
    return pos if pos.shape[1] == 3 else np.column_stack([pos, np.zeros(len(pos))])


def _row(values) -> str:
    return " ".join(f"{float(v):.17g}" for v in values)
