"""``NumbaEngine``: FIRE 2.0 and the spring potential compiled in-process, for the one scene
where LAMMPS's generic machinery dominates the cost: disks or spheres with the spring
potential in an orthogonal periodic box, minimised with FIRE on one core.

Same interface as ``LammpsEngine`` for what the compression protocol uses (``box``,
``template``, ``set_box``, ``minimize``, ``state``, ``evaluate``, ``packing``), same
algorithm (LAMMPS's FIRE 2.0 with its defaults, ``jamflow.engine.fire_numba``) and the
same stopping rules (``jamflow.minimize``). Measured against LAMMPS in
tests/test_native_engine.py and benchmarks/engines.py. Everything else (other potentials,
tilted boxes, CG, damped MD, MPI) runs in LAMMPS.
"""

from __future__ import annotations

from contextlib import contextmanager
from typing import NamedTuple

import numpy as np

from ..box import Box
from ..packing import Packing
from ..pairs import candidate_pairs
from ..potentials import Spring
from . import fire_numba as kernels
from .lammps import State


def unsupported_reason(packing: Packing, method: str = "fire", comm=None) -> str | None:
    """Why NumbaEngine cannot run this scene, or None if it can."""
    if not isinstance(packing.potential, Spring):
        return f"potential {packing.potential.spec} (only the spring potential is compiled)"
    if packing.box.is_triclinic:
        return "a tilted (sheared) box"
    if method != "fire":
        return f"minimizer {method} (only FIRE is compiled)"
    if comm is not None:
        return "an MPI communicator (the compiled engine is serial)"
    return None


class PairList(NamedTuple):
    """Pairs i < j within sigma_ij + skin, with the positions they were built at."""

    i: np.ndarray
    j: np.ndarray
    sigma: np.ndarray
    built_at: np.ndarray  # (N, d) positions at the build: a move > skin/2 asks for a rebuild
    shift: np.ndarray  # (P, d) periodic image offset of each pair


class NumbaEngine:
    """Serial spring-potential engine; ``skin`` is the pair-list skin in diameters."""

    name = "numba"

    def __init__(self, packing: Packing, *, skin: float = 0.3):
        reason = unsupported_reason(packing)
        if reason:
            raise ValueError(f"NumbaEngine cannot run {reason}; use LammpsEngine")
        self.template = packing
        self.box = packing.box
        self.skin = float(skin)
        self.commands: list[str] = []  # no LAMMPS commands: nothing to replay as a deck
        self._x = np.array(packing.positions, dtype=float)
        self._f = np.zeros_like(self._x)
        self._energy = None
        self._pairs = None

    # lifecycle (parity with LammpsEngine) ---------------------------------------------------
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self):
        self._pairs = None

    # pair list --------------------------------------------------------------------------------
    def _build_pairs(self):
        """Pairs within sigma_ij + skin (i < j) and their periodic image offsets."""
        self._x = self.box.wrap(self._x)
        diameters = self.template.diameters
        i, j = candidate_pairs(self.packing(), float(diameters.max()) + self.skin)
        sigma = 0.5 * (diameters[i] + diameters[j])
        dr = self.box.minimum_image(self._x[i] - self._x[j])
        keep = np.einsum("ij,ij->i", dr, dr) < (sigma + self.skin) ** 2
        i, j, sigma, dr = i[keep], j[keep], sigma[keep], dr[keep]
        shift = dr - (self._x[i] - self._x[j])  # image offset of each pair
        self._pairs = PairList(i.astype(np.int64), j.astype(np.int64), sigma, self._x.copy(),
                               np.ascontiguousarray(shift))

    def _kernel_args(self):
        if self._pairs is None:
            self._build_pairs()
        p, pot = self._pairs, self.template.potential
        return p.shift, p.i, p.j, p.sigma, float(pot.alpha), float(pot.epsilon)

    # state ---------------------------------------------------------------------------------------
    def positions(self) -> np.ndarray:
        """Current positions (packing order), wrapped into the cell."""
        return self.box.wrap(self._x)

    def set_positions(self, positions: np.ndarray) -> None:
        """Move the particles (packing order); forces are stale until ``evaluate``."""
        self._x = np.array(positions, dtype=float)
        self._pairs, self._energy = None, None

    def evaluate(self) -> State:
        """Energy, forces and virial pressure tensor at the current positions."""
        shift, i, j, sigma, alpha, eps = self._kernel_args()
        self._energy = kernels.spring_forces(self._x, shift, i, j, sigma, alpha, eps, self._f)
        return self.state()

    def state(self) -> State:
        if self._energy is None:
            return self.evaluate()
        return State(float(self._energy), self._f.copy(), self._pressure_tensor())

    def _pressure_tensor(self) -> np.ndarray:
        """Virial P_ab = sum_pairs r_a f_b / volume over overlapping pairs (eps/diameter^d)."""
        i, j, sigma = self._pairs.i, self._pairs.j, self._pairs.sigma
        dr = self._x[i] - self._x[j] + self._pairs.shift
        r = np.linalg.norm(dr, axis=1)
        inside = r < sigma
        dr, r, sigma = dr[inside], r[inside], sigma[inside]
        fr = -self.template.potential.dv_dr(r, sigma) / r
        return np.einsum("k,ka,kb->ab", fr, dr, dr) / self.box.volume

    def packing(self, **metadata) -> Packing:
        return self.template.with_positions(self.box.wrap(self._x), box=self.box, **metadata)

    # box changes ----------------------------------------------------------------------------------
    def set_box(self, box: Box) -> None:
        """Deform the cell affinely (positions scaled with it), like LAMMPS ``change_box remap``."""
        if box.dim != self.box.dim:
            raise ValueError("cannot change the dimension of a running system")
        if box.is_triclinic:
            raise ValueError("NumbaEngine runs orthogonal boxes only; use LammpsEngine for shear")
        self._x = self._x * (box.lengths / self.box.lengths)
        self.box = box
        self._pairs, self._energy = None, None

    # minimisation -----------------------------------------------------------------------------------
    def minimize(self, settings=None):
        """Minimise at fixed box with the seed's stopping rules; returns MinimizeResult."""
        from ..minimize import MinimizerSettings, minimize

        return minimize(self, settings or MinimizerSettings())

    @contextmanager
    def minimizer_session(self, settings, ftol: float):
        """Yield ``window(steps) -> (iterations, total energy, max force component)``; each
        window restarts FIRE (v = 0, dt = timestep) like one LAMMPS ``minimize`` command."""
        if settings.method != "fire":
            raise ValueError(f"NumbaEngine runs FIRE only, not {settings.method}; use LammpsEngine")
        n = self.template.n
        halt = settings.v_min * n

        def window(steps: int):
            state = kernels.fire_state(settings.timestep)
            v = np.zeros_like(self._x)
            done = 0
            while True:
                shift, i, j, sigma, alpha, eps = self._kernel_args()
                ran, reason, energy = kernels.fire(self._x, v, self._f, state, shift, i, j, sigma, alpha, eps,
                                                   self._pairs.built_at, (self.skin / 2) ** 2, steps - done, ftol,
                                                   halt)
                done += ran
                self._energy = energy
                if reason != kernels.REBUILD or done >= steps:
                    break
                self._build_pairs()
            if reason == kernels.REBUILD:  # the cap fell on a rebuild step: forces with a fresh list
                self._build_pairs()
                self.evaluate()
            return done, float(self._energy), float(np.abs(self._f).max()) if n else 0.0

        yield window
