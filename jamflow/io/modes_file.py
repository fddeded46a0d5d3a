"""Results files of ``jamflow modes`` (schema ``jamflow.modes`` v2): contacts, floaters, the spectrum, the stability class and the per-mode profiles of one packing."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from jamflow import __version__
from jamflow.io.packing_file import hdf5_output, open_hdf5
from jamflow.mechanics.contacts import pooled_contacts
from jamflow.support.files import write_csv

SCHEMA, SCHEMA_VERSION = "jamflow.modes", 2  # v2 adds the shape, mode character and per-mode profiles


def save_modes(out, source, spec, stab, vectors=False, checks=None) -> Path:
    """Write one packing's results atomically (schema jamflow.modes v2: v1 plus ``shape``,
    ``dof_per_particle``, ``n_translational``, ``n_quartic``, ``n_single_flat``, ``n_balanced``,
    ``missing_contacts``, the dataset ``translational_fraction`` and the group
    ``stability/profiles``); ``checks`` (a ``jamflow.mechanics.checks.PackingChecks``) go to group
    ``checks`` and root ``force_balanced``."""
    c = spec.dynamical.contacts
    packing = spec.dynamical.packing
    attrs = dict(schema=SCHEMA, schema_version=SCHEMA_VERSION, jamflow_version=__version__,
                 source=str(source), dim=spec.dim, n=spec.dynamical.n_total, n_kept=c.n_kept,
                 shape=packing.shape.spec(packing.dim), dof_per_particle=packing.dof_per_particle,
                 n_translational=spec.dynamical.n_translational, n_quartic=stab.n_quartic,
                 n_single_flat=stab.n_single_flat, n_balanced=c.n_balanced,
                 missing_contacts=max(-c.excess_contacts, 0),
                 n_floaters=c.n_floaters, n_contacts=c.n_contacts, n_overlapping=c.n_overlapping,
                 n_near_contact=c.n_near_contact, isostatic_count=c.isostatic_count,
                 excess_contacts=c.excess_contacts, mean_z=c.mean_z, e_min=spec.e_min, mass=spec.mass,
                 complete=spec.complete, n_zero=spec.n_zero, n_negative=spec.n_negative,
                 lowest_nonzero=spec.lowest_nonzero, classification=stab.label, behaviour=stab.behaviour,
                 power=stab.power, mode_eigenvalue=stab.mode_eigenvalue,
                 translation_residual=spec.translation_residual)
    if checks is not None:
        attrs["force_balanced"] = checks.force_balanced
    with hdf5_output(out) as f:
        f.attrs.update(attrs)
        if checks is not None:
            f.create_group("checks").attrs.update(checks.as_attrs())
        f["floater"], f["z"], f["particles"] = c.floater, c.z, spec.dynamical.particles
        f["contacts"] = np.column_stack([c.i, c.j])
        f["eigenvalues"], f["frequencies"] = spec.eigenvalues, spec.frequencies
        if vectors and spec.eigenvectors is not None:
            f["eigenvectors"] = spec.eigenvectors
        g = f.create_group("stability")
        g["deltas"], g["delta_v_plus"], g["delta_v_minus"], g["mode"] = (
            stab.deltas, stab.delta_v_plus, stab.delta_v_minus, stab.mode)
        if spec.eigenvectors is not None:
            f["translational_fraction"] = spec.translational_fraction
        _save_profiles(g.create_group("profiles"), stab.profiles, vectors)
    return Path(out)


def _save_profiles(g, profiles, vectors: bool) -> None:
    """One row per profiled mode (ascending eigenvalue)."""
    g["eigenvalues"] = np.array([p.eigenvalue for p in profiles])
    g["powers"] = np.array([p.power for p in profiles])
    g["behaviours"] = np.array([p.behaviour for p in profiles], dtype=h5py.string_dtype())
    g["regimes"] = np.array([p.regime for p in profiles], dtype=h5py.string_dtype())
    g["translational_fraction"] = np.array([p.translational_fraction for p in profiles])
    g["participation"] = np.array([p.participation for p in profiles])
    g["quartic_straight"] = np.array([p.quartic_straight for p in profiles])
    g["quartic_relaxed"] = np.array([p.quartic_relaxed for p in profiles])
    g["deltas"] = np.array([p.deltas for p in profiles])
    g["delta_v"] = np.array([p.delta_v for p in profiles])
    if vectors:
        g["modes"] = np.array([p.mode for p in profiles])


def _dataset(obj):
    return obj.asstr()[...] if h5py.check_string_dtype(obj.dtype) else obj[...]


def read_modes(path) -> dict:
    """Attributes and datasets of a results file as a flat dict (datasets as arrays)."""
    with open_hdf5(path, "jamflow modes results file") as f:
        if f.attrs.get("schema") != SCHEMA:
            raise ValueError(f"{path} is not a jamflow modes results file")
        out = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}
        f.visititems(lambda name, obj: out.__setitem__(name, _dataset(obj)) if isinstance(obj, h5py.Dataset) else None)
    return out


# --- data pooled over the packings of one `jamflow modes` run, beside its figure ----------------

DOS_COLUMNS = ("omega_low", "omega_high", "D", "D_per_packing", "D_translational_per_packing", "fraction_in_range")
PACKING_COLUMNS = ("file", "n", "n_kept", "n_floaters", "floater_fraction", "n_contacts", "isostatic_count",
                   "mean_z", "n_zero", "n_negative", "lowest_nonzero", "mass")


def save_pooled_dos(path, dos) -> Path:
    """D(omega) of a ``DensityOfStatesResult`` as CSV, one row per bin (columns ``DOS_COLUMNS``):
    omega = sqrt(e / M) in units of sqrt(eps / (m diameter^2)), M the spectra's ``mass`` (N m by
    default, the chapter's); ``D`` normalised over all nonzero modes, so that it integrates to
    ``fraction_in_range`` (1 unless ``omega_max`` leaves modes out; the same value in every row);
    ``D_per_packing`` modes per unit omega per packing (the chapter's D(omega), section 3); its
    translational part (empty without eigenvectors)."""
    translational = dos.translational if dos.translational is not None else [""] * len(dos.density)
    rows = [dict(zip(DOS_COLUMNS, values)) for values in
            zip(dos.edges[:-1], dos.edges[1:], dos.normalized, dos.density, translational,
                [dos.fraction_in_range] * len(dos.density))]
    return write_csv(path, rows, DOS_COLUMNS)


def save_packing_table(path, labels, spectra) -> Path:
    """One CSV row per packing (columns ``PACKING_COLUMNS``: contacts, floaters, <z>, zero modes)
    and a last row ``file = pooled``: sums of the counts, <z> and floater fraction pooled
    (``jamflow.mechanics.contacts.pooled_contacts``), lowest_nonzero the smallest."""
    rows = []
    for label, s in zip(labels, spectra):
        c = s.dynamical.contacts
        rows.append(dict(file=label, n=len(c.floater), n_kept=c.n_kept, n_floaters=c.n_floaters,
                         floater_fraction=c.n_floaters / len(c.floater), n_contacts=c.n_contacts,
                         isostatic_count=c.isostatic_count, mean_z=c.mean_z, n_zero=s.n_zero,
                         n_negative=s.n_negative, lowest_nonzero=s.lowest_nonzero, mass=s.mass))
    pooled_z = pooled_contacts(s.dynamical.contacts for s in spectra)
    pooled = {k: sum(r[k] for r in rows) for k in ("n", "n_kept", "n_floaters", "n_contacts", "isostatic_count",
                                                   "n_zero", "n_negative")}
    lowest = [r["lowest_nonzero"] for r in rows if np.isfinite(r["lowest_nonzero"])]
    rows.append(dict(file="pooled", **pooled, floater_fraction=pooled_z.floater_fraction, mean_z=pooled_z.mean_z,
                     lowest_nonzero=min(lowest, default=float("nan")), mass=""))
    return write_csv(path, rows, PACKING_COLUMNS)
