"""One summary row per packing file, with the checks every ensemble packing must pass
(``jamflow.mechanics.checks``: V in the window V_tol < V < 2 V_tol, force and torque balance against the
numpy reference, independent of the engine that made the packing, and the contact count). The
checks stored in the file by the writer are used; files without them are checked here."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from jamflow.mechanics.checks import check_packing
from jamflow.io.packing_file import load_packing, read_attrs, read_checks, read_history, read_phi_j, read_protocol


def packing_row(path, task, fixed: dict) -> dict:
    """Summary row of one packing file; ValueError if the file does not belong to ``task``.
    ``phi_j`` is the onset ``jamflow jam`` reports (``read_phi_j``: a pile's own fraction, phi_J(P->0)
    at constant pressure, NaN with one pressure); ``phi`` the packing fraction of the box."""
    path = Path(path)
    attrs, protocol = read_attrs(path), read_protocol(path)
    expected = task.options(fixed)
    if int(attrs["n"]) != int(expected["n"]) or int(attrs["seed"]) != task.seed:
        raise ValueError(f"{path} holds n = {attrs['n']}, seed = {attrs['seed']}, not its name's task")
    history = read_history(path)
    v = float(attrs["energy_per_particle"])
    checks = read_checks(path) or check_packing(load_packing(path), v, None, float(protocol["v_tol"]))
    st = os.stat(path)
    return {**expected, "status": "ok", "phi_j": repr(read_phi_j(path)), "phi": repr(float(attrs["phi"])), "V": v,
            "P": float(attrs["pressure"]),
            "mean_z": checks.mean_z, "floaters": checks.n_floaters, "n_contacts": checks.n_contacts,
            "iterations": int(np.sum(history["iterations"])), "minimizations": len(history["iterations"]),
            "seconds": protocol.get("seconds", ""), "engine": protocol.get("engine", ""),
            "jamflow_version": attrs["jamflow_version"], "max_force": checks.max_force,
            "in_window": bool(checks.in_window), "balanced": checks.force_balanced,
            "file": path.name, "reason": "", "file_size": st.st_size, "file_mtime_ns": st.st_mtime_ns}
