"""Results files of ``jamflow moduli`` (schema ``jamflow.moduli`` v1): B and G by strain sweeps and by the Hessian, with the sweeps as datasets."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from jamflow import __version__
from jamflow.io.packing_file import hdf5_output
from jamflow.mechanics.strains import STRAINS

SCHEMA, SCHEMA_VERSION = "jamflow.moduli", 1


def save_moduli(out, source, packing, result, dphi_above, moduli) -> Path:
    """Write one packing's moduli atomically (schema jamflow.moduli v1)."""
    h = result.hessian
    attrs = dict(schema=SCHEMA, schema_version=SCHEMA_VERSION, jamflow_version=__version__, source=str(source),
                 n=packing.n, dim=packing.dim, potential=packing.potential.spec, shape_spec=packing.shape.spec(packing.dim),
                 phi=result.phi, dphi_above=dphi_above, energy_per_particle=result.energy_per_particle,
                 pressure=result.pressure, shear_stress=result.shear_stress, n_contacts=result.n_contacts,
                 n_floaters=result.n_floaters, engine=moduli.engine, linear_tol=moduli.sweeps.linear_tol,
                 jump_tol=moduli.sweeps.jump_tol,
                 G=result.G, B=result.B, G_hessian=result.G_hessian, B_hessian=result.B_hessian,
                 yield_strain=result.yield_strain, yield_reason=result.shear.yield_reason,
                 bulk_yield_strain=result.bulk.yield_strain, bulk_yield_reason=result.bulk.yield_reason,
                 G_affine=h.G_affine, B_affine=h.B_affine, n_extra_zero=h.n_extra_zero, n_negative=h.n_negative,
                 lowest_eigenvalue=h.lowest_eigenvalue)
    for strain in STRAINS:
        sweep, m = result.sweep(strain), strain.modulus
        attrs.update({f"{m}_error": sweep.error, f"{m}_curvature": sweep.curvature, f"{m}_linear_max": sweep.linear_max,
                      f"{m}_roundoff_strain": result.roundoff[m]})
    with hdf5_output(out) as f:
        f.attrs.update(attrs)
        for strain in STRAINS:
            sweep = result.sweep(strain)
            g = f.create_group(strain.kind)
            g.attrs.update(strain=strain.strain_name, response=strain.response_name, modulus=strain.modulus)
            g["strain"], g["response"], g["energy_per_particle"] = sweep.strains, sweep.responses, sweep.energies
            g["iterations"], g["max_force"], g["reason"] = sweep.iterations, sweep.max_forces, sweep.reasons.astype("S")
            g["contacts_added"], g["contacts_removed"] = sweep.added, sweep.removed
            g["rattler_contacts_changed"] = sweep.rattler_changes
            g["amplitudes"], g["central_slope"], g["linear"] = sweep.amplitudes, sweep.central_slopes, sweep.linear
            if strain.kind == "bulk":
                g["phi"] = result.phi * np.exp(sweep.strains)
    return Path(out)


def read_moduli(path) -> dict:
    """Attributes and datasets of a moduli results file as a flat dict ("shear/strain", ...)."""
    with h5py.File(path, "r") as f:
        if f.attrs.get("schema") != SCHEMA:
            raise ValueError(f"{path} is not a jamflow moduli results file")
        out = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}
        f.visititems(lambda name, obj: out.__setitem__(name, obj[...]) if isinstance(obj, h5py.Dataset) else None)
    return out
