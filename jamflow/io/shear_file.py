"""Shear path files: one HDF5 file with a whole quasistatic shear path (``jamflow shear``).

Schema ``jamflow.shear`` version 1 (lengths in small diameters, energies in eps, pressures in
eps / diameter^d; S + 1 steps, step 0 the start)::

    /                   attrs: schema, schema_version, jamflow_version, lammps_version, source,
                               dim, n, potential, alpha, epsilon, seed, sizes, shape (JSON),
                               shape_spec, engine, gamma_start, gamma_end, dgamma, steps,
                               n_changes (steps whose contact network changed), seconds
    /diameters (N,)
    /path/gamma (S+1,)            accumulated Lees-Edwards strain of each step
    /path/phi_j, energy_per_particle, pressure, shear_stress (Sigma = -P_xy) (S+1,)
    /path/pressure_tensor (S+1, d, d)
    /path/n_contacts, n_floaters, n_removed, n_added, minimizations, iterations (S+1,) int
    /path/changed (S+1,) bool     contacts removed or added since the previous step
    /path/checks_passed (S+1,) bool   the packing checks of jamflow.mechanics.checks (jamflow shear writes it)
    /path/positions (S+1, N, d), /path/box (S+1, d, d)   the packing at every step
    /path/orientations (S+1, N) | (S+1, N, 4)             shapes that turn
    /contacts/pairs (M, 2), /contacts/offsets (S+2,)      step k: pairs[offsets[k]:offsets[k+1]]
    /changes/removed (R, 3), /changes/added (A, 3)        rows (step, i, j)
    /protocol               attrs: the bisection's parameters after each step

Written to a temporary sibling and renamed (``jamflow.support.files.atomic_path``).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from jamflow import __version__
from jamflow.io.packing_file import _attr, hdf5_output
from jamflow.model.box import Box
from jamflow.model.packing import Packing
from jamflow.model.potentials import potential_from_attrs
from jamflow.model.shapes.shape import shape_from_attrs

SCHEMA, SCHEMA_VERSION = "jamflow.shear", 1
COLUMNS = ("gamma", "phi_j", "energy_per_particle", "pressure", "shear_stress", "n_contacts", "n_floaters",
           "n_removed", "n_added", "minimizations", "iterations", "changed")


def path_columns(path) -> dict:
    """The per-step columns of a ``ShearPath`` as arrays (COLUMNS and pressure_tensor)."""
    steps = path.steps
    columns = {
        "gamma": [s.gamma for s in steps], "phi_j": [s.phi_j for s in steps],
        "energy_per_particle": [s.jam.energy_per_particle for s in steps],
        "pressure": [s.jam.pressure for s in steps], "shear_stress": [s.shear_stress for s in steps],
        "n_contacts": [s.network.n_contacts for s in steps], "n_floaters": [s.network.n_floaters for s in steps],
        "n_removed": [len(s.removed) for s in steps], "n_added": [len(s.added) for s in steps],
        "minimizations": [s.jam.minimizations for s in steps], "iterations": [s.jam.iterations for s in steps],
        "changed": [s.changed for s in steps],
    }
    out = {k: np.asarray(v) for k, v in columns.items()}
    out["pressure_tensor"] = np.array([s.jam.pressure_tensor for s in steps])
    return out


def save_shear_path(out, path, *, source: str = "", extra_columns: dict | None = None) -> Path:
    """Write a ``ShearPath`` atomically to the HDF5 file ``out``; ``extra_columns`` (name ->
    one value per step, e.g. ``checks_passed``) join /path."""
    first = path.steps[0].packing
    pot = first.potential
    columns = {**path_columns(path), **{k: np.asarray(v) for k, v in (extra_columns or {}).items()}}
    attrs = dict(
        schema=SCHEMA, schema_version=SCHEMA_VERSION, jamflow_version=__version__,
        lammps_version=str(path.steps[0].jam.lammps_version), source=str(source), dim=first.dim, n=first.n,
        potential=pot.spec, alpha=float(getattr(pot, "alpha", math.nan)), epsilon=float(pot.epsilon),
        seed=int(first.metadata.get("seed", -1)), sizes=str(first.metadata.get("sizes", "")),
        shape=json.dumps(first.shape.attrs()), shape_spec=first.shape.spec(first.dim), engine=path.engine,
        gamma_start=float(columns["gamma"][0]), gamma_end=float(columns["gamma"][-1]), dgamma=path.dgamma,
        steps=len(path.steps) - 1, n_changes=path.n_changes, seconds=path.seconds,
    )
    pairs = [np.column_stack([s.network.i, s.network.j]).reshape(-1, 2) for s in path.steps]
    with hdf5_output(out) as f:
        f.attrs.update(attrs)
        f["diameters"] = first.diameters
        g = f.create_group("path")
        for name, column in columns.items():
            g[name] = column
        g["positions"] = np.array([s.packing.box.wrap(s.packing.positions) for s in path.steps])
        g["box"] = np.array([s.packing.box.h for s in path.steps])
        if first.orientations is not None:
            g["orientations"] = np.array([s.packing.orientations for s in path.steps])
        c = f.create_group("contacts")
        c["pairs"] = np.concatenate(pairs).astype(np.int64)
        c["offsets"] = np.cumsum([0] + [len(p) for p in pairs]).astype(np.int64)
        ch = f.create_group("changes")
        for name in ("removed", "added"):
            rows = [(k, i, j) for k, s in enumerate(path.steps) for i, j in getattr(s, name)]
            ch[name] = np.array(rows, dtype=np.int64).reshape(-1, 3)
        f.create_group("protocol").attrs.update({k: _attr(v) for k, v in path.settings.as_dict().items()})
    return Path(out)


@dataclass(frozen=True)
class ContactChange:
    """The contact changes of one step of a shear path: ``removed`` and ``added`` are sorted
    lists of pairs (i, j); ``floaters`` is the number of floaters (before, after) the step."""

    step: int  #: the step's index on the path (step 0 is the start)
    gamma: float  #: its strain
    removed: list  #: pairs (i, j) of the previous step that are gone
    added: list  #: pairs (i, j) that were not there
    floaters: tuple  #: floaters (before, after) the step

    def line(self) -> str:
        """``step 7  gamma=0.014  removed 6-26  added 3-8 2-3`` (``-`` for none), with
        ``floaters 0 -> 1`` appended when the number of floaters changed."""
        pairs = {k: " ".join(f"{i}-{j}" for i, j in v) or "-" for k, v in (("r", self.removed), ("a", self.added))}
        text = f"step {self.step}  gamma={self.gamma:.6g}  removed {pairs['r']}  added {pairs['a']}"
        before, after = self.floaters
        return text + (f"  floaters {before} -> {after}" if before != after else "")


class ShearFile:
    """A shear path file (schema ``jamflow.shear``) read back.

    Attributes:
        attrs: the file's root attributes (dict: dim, n, potential, gamma_start, gamma_end,
            dgamma, steps, n_changes, engine, ...; the module docstring lists them).
        columns: per-step arrays by name (dict, each of length S + 1, step 0 the start): gamma,
            phi_j, energy_per_particle, pressure, shear_stress, pressure_tensor, n_contacts,
            n_floaters, n_removed, n_added, minimizations, iterations, changed, checks_passed,
            positions, box (and orientations for shapes that turn).
        removed: (R, 3) int array, rows (step, i, j): the contacts of step - 1 that are gone at
            step (i < j, particle indices from 0).
        added: (A, 3) int array, rows (step, i, j): the contacts of step that were not there at
            step - 1. A pair whose separation jumped to another periodic image is in both.
            Contacts are counted among non-floaters, so a particle that becomes a floater has all
            its contacts removed, and one that stops being a floater has all its contacts added.
        diameters: (N,) the particles' diameters.
        source: the file's path.

    ``changes()`` groups ``removed`` and ``added`` by step; ``contacts(k)`` and ``packing(k)``
    give the network and the packing at step k.
    """

    def __init__(self, path):
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"no shear path file {path}")
        with h5py.File(path, "r") as f:
            if f.attrs.get("schema") != SCHEMA:
                raise ValueError(f"{path} is not a jamflow shear path file (schema {f.attrs.get('schema')!r})")
            self.attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}
            self.columns = {k: v[...] for k, v in f["path"].items()}
            self.diameters = f["diameters"][...]
            self._pairs, self._offsets = f["contacts/pairs"][...], f["contacts/offsets"][...]
            self.removed, self.added = f["changes/removed"][...], f["changes/added"][...]
        self.source = path

    def __repr__(self) -> str:
        """One line: the file, dim, N, the strain range, steps and the steps whose contacts changed."""
        a, gamma = self.attrs, self.columns["gamma"]
        changed = len(np.union1d(self.removed[:, 0], self.added[:, 0]))
        return (f"ShearFile({str(self.source)!r}, dim={int(a['dim'])}, N={len(self.diameters)}, "
                f"gamma={float(gamma[0]):.6g} -> {float(gamma[-1]):.6g}, steps={len(self) - 1}, changes={changed})")

    def __len__(self) -> int:
        return len(self.columns["gamma"])

    def changes(self) -> list[ContactChange]:
        """One ``ContactChange`` per step whose contact network changed, in step order."""
        floaters = self.columns["n_floaters"]
        steps = np.union1d(self.removed[:, 0], self.added[:, 0]).astype(int)
        return [ContactChange(int(k), float(self.columns["gamma"][k]), _pairs_at(self.removed, k),
                              _pairs_at(self.added, k), (int(floaters[k - 1]), int(floaters[k]))) for k in steps]

    def contacts(self, k: int) -> np.ndarray:
        """(N_c, 2) contacts i < j among non-floaters at step k."""
        return self._pairs[self._offsets[k]:self._offsets[k + 1]]

    def packing(self, k: int) -> Packing:
        """The static packing at step k."""
        a, c = self.attrs, self.columns
        pot = potential_from_attrs(str(a["potential"]), float(a["alpha"]), float(a["epsilon"]))
        shape = shape_from_attrs(json.loads(a["shape"]))
        orient = c["orientations"][k] if "orientations" in c else None
        meta = {"seed": int(a["seed"]), "sizes": str(a["sizes"]), "source": str(self.source), "step": k}
        return Packing(c["positions"][k], self.diameters, Box(c["box"][k]), pot, meta, shape, orient)


def _pairs_at(rows: np.ndarray, step: int) -> list:
    """The pairs (i, j) of the (step, i, j) ``rows`` at ``step``, sorted."""
    return sorted((int(i), int(j)) for _, i, j in rows[rows[:, 0] == step])
