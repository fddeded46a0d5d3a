"""Packing files: a versioned HDF5 schema, LAMMPS data files, MDAnalysis Universes.

HDF5 schema ``jamflow.packing`` version 1 (all lengths in small diameters, energies in
epsilon, pressures in epsilon / diameter^d)::

    /                       attrs: schema, schema_version, jamflow_version, lammps_version,
                                   dim, n, phi, energy_per_particle, pressure, potential,
                                   alpha, epsilon, seed, sizes, created (ISO time)
    /positions  (N, d)      float64, Cartesian, wrapped into the cell
    /diameters  (N,)        float64
    /box        (d, d)      float64, upper-triangular, columns = cell vectors (LAMMPS tilt)
    /pressure_tensor (d, d) float64, virial part (athermal), if known
    /protocol               attrs: every protocol and minimiser parameter
    /history/<column> (M,)  one dataset per recorded column (phi, energy, pressure, ...)

Every file is written to a temporary sibling and renamed onto its name, so an interrupted
run never leaves a half-written file.
"""

from __future__ import annotations

import contextlib
import datetime
import math
import os
import tempfile
from pathlib import Path

import h5py
import numpy as np

from . import __version__
from .box import Box
from .packing import Packing
from .potentials import RepulsiveLJ, Spring

SCHEMA = "jamflow.packing"
SCHEMA_VERSION = 1


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; rename it onto ``path`` only on success."""
    path = Path(path)
    check_writable(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; give the file the usual permissions
    try:
        yield Path(tmp)
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def check_writable(path) -> None:
    """Raise a clear error before any work starts if ``path`` cannot be written."""
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise ValueError(f"cannot write {path}: directory {parent} does not exist; create it first")
    if not os.access(parent, os.W_OK):
        raise ValueError(f"cannot write {path}: directory {parent} is not writable; choose another --out")
    if path.is_dir():
        raise ValueError(f"cannot write {path}: it is a directory; give a file name such as packing.h5")


def save_packing(path, packing: Packing, *, energy_per_particle=None, pressure_tensor=None,
                 protocol: dict | None = None, history: dict | None = None, lammps_version=None) -> Path:
    """Write ``packing`` (and optional results) atomically to the HDF5 file ``path``."""
    pot = packing.potential
    attrs = dict(
        schema=SCHEMA, schema_version=SCHEMA_VERSION, jamflow_version=__version__,
        lammps_version=str(lammps_version or ""), dim=packing.dim, n=packing.n, phi=packing.phi,
        energy_per_particle=_num(energy_per_particle), potential=pot.spec,
        alpha=float(getattr(pot, "alpha", math.nan)), epsilon=float(pot.epsilon),
        seed=int(packing.metadata.get("seed", -1)), sizes=str(packing.metadata.get("sizes", "")),
        created=datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
    )
    ptensor = None if pressure_tensor is None else np.asarray(pressure_tensor, float)
    attrs["pressure"] = math.nan if ptensor is None else float(np.trace(ptensor) / packing.dim)
    with atomic_path(path) as tmp, h5py.File(tmp, "w") as f:
        f.attrs.update(attrs)
        f["positions"] = packing.box.wrap(packing.positions)
        f["diameters"] = packing.diameters
        f["box"] = packing.box.h
        if ptensor is not None:
            f["pressure_tensor"] = ptensor
        f.create_group("protocol").attrs.update({k: _attr(v) for k, v in (protocol or {}).items()})
        hist = f.create_group("history")
        for name, column in (history or {}).items():
            hist[name] = np.asarray(column)
    return Path(path)


def load_packing(path) -> Packing:
    """Read a jamflow HDF5 packing file (any schema version up to the current one)."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no packing file {path}")
    with h5py.File(path, "r") as f:
        schema = f.attrs.get("schema")
        if schema != SCHEMA:
            raise ValueError(f"{path} is not a jamflow packing file (schema {schema!r})")
        if int(f.attrs["schema_version"]) > SCHEMA_VERSION:
            raise ValueError(f"{path} has schema version {f.attrs['schema_version']}, newer than this "
                             f"jamflow ({SCHEMA_VERSION}); upgrade jamflow")
        pot = _potential(str(f.attrs["potential"]), float(f.attrs["alpha"]), float(f.attrs["epsilon"]))
        meta = {"seed": int(f.attrs["seed"]), "sizes": str(f.attrs["sizes"]), "source": str(path)}
        return Packing(f["positions"][...], f["diameters"][...], Box(f["box"][...]), pot, meta)


def read_history(path) -> dict:
    """The protocol history columns of a packing file as numpy arrays."""
    with h5py.File(path, "r") as f:
        return {k: v[...] for k, v in f["history"].items()}


def read_protocol(path) -> dict:
    """The ``protocol`` group's attributes (protocol, minimiser and run parameters) of a packing file."""
    with h5py.File(path, "r") as f:
        return {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f["protocol"].attrs.items()}


def read_attrs(path) -> dict:
    """Root attributes (phi, energy_per_particle, pressure, versions, ...) of a packing file."""
    with h5py.File(path, "r") as f:
        return {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}


def write_lammps_data(path, packing: Packing) -> Path:
    """LAMMPS data file for ``atom_style sphere`` (id type diameter density x y z);
    types number the distinct diameters; mass 1 per particle (density = 1/volume)."""
    values, types = packing.species()
    box = packing.box.to_lammps()
    pos = packing.box.wrap(packing.positions)
    if packing.dim == 2:
        pos = np.column_stack([pos, np.zeros(packing.n)])
    vol = np.pi * packing.diameters**3 / 6.0  # LAMMPS sphere mass = density * 4/3 pi r^3, also in 2D
    lines = [f"jamflow {__version__} packing, phi = {packing.phi:.17g}", "",
             f"{packing.n} atoms", f"{len(values)} atom types", "",
             f"{box['xlo']:.17g} {box['xhi']:.17g} xlo xhi", f"{box['ylo']:.17g} {box['yhi']:.17g} ylo yhi",
             f"{box['zlo']:.17g} {box['zhi']:.17g} zlo zhi"]
    if packing.box.is_triclinic:
        lines.append(f"{box['xy']:.17g} {box['xz']:.17g} {box['yz']:.17g} xy xz yz")
    lines += ["", "Atoms # sphere", ""]
    lines += [f"{k + 1} {types[k] + 1} {packing.diameters[k]:.17g} {1.0 / vol[k]:.17g} "
              f"{pos[k, 0]:.17g} {pos[k, 1]:.17g} {pos[k, 2]:.17g}" for k in range(packing.n)]
    with atomic_path(path) as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    return Path(path)


def to_universe(packing: Packing):
    """An MDAnalysis Universe with positions, radii and the (triclinic) box."""
    import MDAnalysis as mda
    from MDAnalysis.lib.mdamath import triclinic_box

    u = mda.Universe.empty(packing.n, trajectory=True)
    _, types = packing.species()
    u.add_TopologyAttr("types", [str(t + 1) for t in types])
    u.add_TopologyAttr("radii", packing.diameters / 2.0)
    h = packing.box.h if packing.dim == 3 else np.diag([*np.diag(packing.box.h), 1.0])
    if packing.dim == 2:
        h[0, 1] = packing.box.h[0, 1]
    pos = packing.box.wrap(packing.positions)
    u.atoms.positions = pos if packing.dim == 3 else np.column_stack([pos, np.zeros(packing.n)])
    u.dimensions = triclinic_box(*h.T)
    return u


def _potential(spec, alpha, epsilon):
    return RepulsiveLJ(epsilon) if spec == "rlj" else Spring(alpha, epsilon)


def _num(x):
    return math.nan if x is None else float(x)


def _attr(value):
    if value is None:
        return "None"
    if isinstance(value, (bool, int, float, str, np.number)):
        return value
    return str(value)
