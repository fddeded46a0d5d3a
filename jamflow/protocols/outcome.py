"""What a jamming protocol returns: the packing at onset, its history, and the failure."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from jamflow.minimize.settings import MinimizeResult
from jamflow.model.box import AXES
from jamflow.model.packing import Packing
from jamflow.protocols.settings import CompressionSettings
from jamflow.support import hooks

HISTORY_COLUMNS = ("phi", "energy_per_particle", "pressure", "dphi", "iterations", "max_force", "converged")


@dataclass(frozen=True)
class JamResult:
    """A packing at jamming onset and how it was found."""

    packing: Packing  #: the packing at the onset (or above it, with ``above``)
    phi_j: float  #: packing fraction phi_J of ``packing``
    energy_per_particle: float  #: V = U / N at the last minimum, eps
    pressure_tensor: np.ndarray  #: (d, d) virial pressure tensor P_ab (chapter eq. 2.34), eps / diameter^d
    max_force: float  #: largest force component on a mobile particle, eps / diameter
    history: dict  #: column name -> np.ndarray, one entry per minimisation (phi, V, iterations, ...)
    settings: CompressionSettings  #: the compression protocol and minimiser that ran
    seconds: float  #: wall-clock time of the run, s
    lammps_version: int  #: LAMMPS version number (e.g. 20240829); 0 when LAMMPS did not run
    engine: str = "lammps"  #: which engine minimised: ``lammps`` or ``numba`` (the files' engine attribute)
    max_torque: float = 0.0  #: largest generalized torque component tau / d_k, eps / diameter (0 for disks, spheres)
    #: (d, 2, d) force of the particles on each face, eps / diameter (walled boxes); None without walls
    wall_forces: np.ndarray | None = None
    #: what the engine's kernel counted (ellipsoids: contact-distance fallbacks, ...)
    counters: dict = field(default_factory=dict)
    kernels: str = ""  #: the engine's kernels: ``ahead-of-time`` or ``numba`` (compiled), or ``lammps``

    def __repr__(self) -> str:
        """One line: N, dim, shape, phi_J, V, P, max|F|, minimisations, engine; ``summary()`` is the
        CLI's line, the fields hold the packing and its history."""
        p = self.packing
        return (f"JamResult(N={p.n}, dim={p.dim}, shape={p.shape.spec(p.dim)!r}, phi_j={self.phi_j:.10f}, "
                f"V={self.energy_per_particle:.3e}, P={self.pressure:.3e}, max_force={self.max_force:.1e}, "
                f"minimizations={self.minimizations}, engine={self.engine!r})")

    def save(self, path, checks=None, force: bool = False):
        """Write this result to the packing file ``path`` exactly as ``jamflow jam --out`` does
        (``jamflow.save_result``: checks group, protocol and engine record); ``checks`` None: checked
        first, as the command does. A result that fails its checks raises ``JammingFailed`` and
        nothing is written. Returns the path. (The writer lives in the io layer, above this one: it
        is reached through ``jamflow.support.hooks``, registered by ``jamflow/__init__.py``.)"""
        return hooks.call("save_result", self, path, checks, force=force)

    @property
    def pressure(self) -> float:
        """P = tr P_ab / d, eps / diameter^d."""
        return float(np.trace(self.pressure_tensor) / self.packing.dim)

    @property
    def minimizations(self) -> int:
        """Number of minimisations the protocol ran."""
        return len(self.history["phi"])

    @property
    def iterations(self) -> int:
        """Minimiser iterations over all minimisations."""
        return int(np.sum(self.history["iterations"]))

    @property
    def wall_pressures(self) -> np.ndarray:
        """(k, 2) pressure on the lower and upper face of each walled axis (``jamflow.model.walls``)."""
        from jamflow.model.walls import face_pressures

        return face_pressures(self.packing.box, self.wall_forces) if self.wall_forces is not None else np.empty((0, 2))

    def summary(self) -> str:
        """The one line ``jamflow jam`` prints: phi_J, V, P, max force, minimisations, kernels, time."""
        torque = f"  max|tau/d| = {self.max_torque:.1e}" if self.packing.shape.oriented else ""
        walls = "".join(f"  P_wall {AXES[a]} = {lo:.3e} {hi:.3e}"
                        for a, (lo, hi) in zip(self.packing.box.walls, self.wall_pressures))
        return (f"phi_J = {self.phi_j:.10f}  V = {self.energy_per_particle:.3e}  "
                f"P = {self.pressure:.3e}{walls}  max|F| = {self.max_force:.1e}{torque}  "
                f"{self.minimizations} minimisations, {self.iterations} iterations ({engine_label(self.engine, self.kernels)}), {self.seconds:.2f} s")


def engine_label(engine: str, kernels: str = "") -> str:
    """The engine as a summary line names it: "compiled, ahead-of-time" or "compiled, numba" for the
    compiled engine (which kernels ran; files keep ``engine`` = "numba"), "lammps" for LAMMPS."""
    if engine == "numba":
        return f"compiled, {kernels or 'numba'}"
    return engine


class JammingFailed(RuntimeError):
    """The protocol could not reach the energy window; the message says why and what to do."""


def record_minimization(rows, phi, result: MinimizeResult, pressure, dphi):
    """Append one minimisation to the history ``rows`` (HISTORY_COLUMNS and its stop reason)."""
    values = (phi, result.energy_per_particle, pressure, dphi, result.iterations, result.max_force, result.converged)
    for column, value in zip(HISTORY_COLUMNS, values):
        rows[column].append(value)
    rows.setdefault("reason", []).append(result.reason)
