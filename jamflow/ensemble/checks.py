"""One summary row per packing file, with the checks every ensemble packing must pass:
V in the window V_tol < V < 2 V_tol (seed section 2.1), and force balance: the largest force
on any particle from the numpy all-pairs reference (jamflow.engine.reference, independent of
the engine that made the packing) within FORCE_CHECK_FACTOR x the minimiser's force tolerance."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..analysis.contacts import Contacts
from ..engine.reference import energy_forces_pressure
from ..io import load_packing, read_attrs, read_history, read_protocol
from ..minimize import MinimizerSettings

FORCE_CHECK_FACTOR = 10.0  # engines sum forces in another order: round-off differs by a few x


def force_tolerance(packing, protocol: dict) -> float:
    """The force tolerance the final minimisation used (MinimizerSettings.resolved_force_tol)."""
    tol = protocol.get("minimizer_force_tol", "None")
    settings = MinimizerSettings(force_tol=None if tol in ("None", None) else float(tol))
    return settings.resolved_force_tol(packing.box, packing.potential.contact_stiffness)


def packing_row(path, task, fixed: dict) -> dict:
    """Summary row of one packing file; ValueError if the file does not belong to ``task``."""
    path = Path(path)
    attrs, protocol = read_attrs(path), read_protocol(path)
    packing = load_packing(path)
    expected = task.options(fixed)
    if int(attrs["n"]) != int(expected["n"]) or int(attrs["seed"]) != task.seed:
        raise ValueError(f"{path} holds n = {attrs['n']}, seed = {attrs['seed']}, not its name's task")
    history = read_history(path)
    contacts = Contacts().compute(packing)
    max_force = float(np.abs(energy_forces_pressure(packing).forces).max())
    v, vtol = float(attrs["energy_per_particle"]), float(protocol["v_tol"])
    st = os.stat(path)
    return {**expected, "status": "ok", "phi_j": repr(float(attrs["phi"])), "V": v, "P": float(attrs["pressure"]),
            "mean_z": contacts.mean_z, "floaters": contacts.n_floaters, "n_contacts": contacts.n_contacts,
            "iterations": int(np.sum(history["iterations"])), "minimizations": len(history["iterations"]),
            "seconds": protocol.get("seconds", ""), "engine": protocol.get("engine", ""),
            "jamflow_version": attrs["jamflow_version"], "max_force": max_force,
            "in_window": vtol < v < 2 * vtol,
            "balanced": max_force <= FORCE_CHECK_FACTOR * force_tolerance(packing, protocol),
            "file": path.name, "reason": "", "file_size": st.st_size, "file_mtime_ns": st.st_mtime_ns}
