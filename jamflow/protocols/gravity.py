"""Packings settled under gravity on a floor (chapter section 2.3, "gravity [36]").

From a random start in a box with walls on the last axis (the floor x_(d-1) = 0 and a
ceiling at the top, periodic sides), minimise the total energy -- pairs, walls and g x_(d-1)
per mobile particle -- until every particle is force balanced including its weight (the
minimiser's force rule, ``jamflow.minimize.rules``). No compression: the load sets the overlaps.
The result's ``phi_j`` is the packing fraction of the pile, mobile particle volume over the
floor area times the height of the highest particle top; the ceiling must carry no load
(otherwise the start was too dense for the box: lower phi0). The pressure profile with
height is ``jamflow.analysis.profile``. Units: g in eps/diameter per particle (unit mass).
"""

from __future__ import annotations

import time
import warnings

import numpy as np

from jamflow.engines.choose import open_engine
from jamflow.minimize.settings import MinimizerSettings
from jamflow.model.packing import Packing
from jamflow.model.walls import wall_loads
from jamflow.protocols.outcome import HISTORY_COLUMNS, JamResult, JammingFailed, record_minimization
from jamflow.protocols.settings import CompressionSettings
from jamflow.minimize.rules import minimize

MAX_RESUMES = 3  # a settling cut off by the iteration cap or the no-progress rule is resumed (at most 3 times)


def pile_fraction(packing: Packing) -> float:
    """Mobile particle volume over (floor area x height of the highest particle top)."""
    mobile = packing.mobile
    top = float(np.max(packing.positions[mobile, -1] + 0.5 * packing.diameters[mobile]))
    area = packing.box.volume / packing.box.lengths[-1]
    return float(packing.volumes[mobile].sum() / (area * top))


def settle(start: Packing, minimizer: MinimizerSettings | None = None, *, observers=(), engine: str = "auto",
           engine_options=None) -> JamResult:
    """Minimise ``start`` (with gravity and a floor) to force balance including the weights."""
    from jamflow.engines.lammps.library import lammps_version

    if start.gravity <= 0:
        raise ValueError("settle needs gravity > 0 (Packing.gravity); compress packings without gravity")
    minimizer = minimizer or MinimizerSettings()
    t0 = time.perf_counter()
    rows = {c: [] for c in HISTORY_COLUMNS}
    with open_engine(start, minimizer.method, engine, **(engine_options or {})) as sim:
        for step in range(MAX_RESUMES + 1):
            result = minimize(sim, minimizer)
            if result.reason == "blown-up":
                raise JammingFailed(f"settling diverged (max force {result.max_force:.3g}): lower the timestep")
            packing, state = sim.packing(), sim.state()
            record_minimization(rows, pile_fraction(packing), result, state.pressure, 0.0)
            for observe in observers:
                observe({"step": step, "phi": rows["phi"][-1], "dphi": 0.0, "result": result})
            if result.converged:
                break
        name, kernels = sim.name, sim.kernels
    if not result.converged:
        warnings.warn(f"settling stopped by '{result.reason}' with max force {result.max_force:.2e}: force balance "
                      "is only as good as that", stacklevel=2)
    loads = wall_loads(packing)
    ceiling = loads[packing.dim - 1, 1, packing.dim - 1]
    if ceiling != 0.0:
        raise JammingFailed(f"the settled pile presses on the ceiling (force {ceiling:.3g}): the start is too dense "
                            f"for the box; use a lower phi0 (phi0 = {start.phi:.3f} here)")
    history = {k: np.array(v) for k, v in rows.items()}
    history["reason"] = history["reason"].astype("S")
    return JamResult(packing=packing, phi_j=pile_fraction(packing), energy_per_particle=result.energy_per_particle,
                     pressure_tensor=state.pressure_tensor, max_force=result.max_force, history=history,
                     settings=CompressionSettings(phi0=start.phi, minimizer=minimizer), seconds=time.perf_counter() - t0,
                     lammps_version=lammps_version(), engine=name, kernels=kernels,
                     max_torque=result.max_torque, wall_forces=loads)
