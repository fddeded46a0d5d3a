"""The engine contract: what every engine computes, what it can run, and how one is chosen.

An engine holds one packing and evaluates or minimises it at a fixed (or, for constant
stress, variable) box. Every engine implements ``Engine`` and returns the neutral ``State``;
it declares what it runs in ``CAPABILITIES`` (shapes, potentials, minimisers, boxes,
processes) and ``supports(packing, method, comm)`` turns that table into a reason or None.
``open_engine`` picks one: ``"auto"`` takes the compiled engine wherever it supports the
scene (it needs no LAMMPS), LAMMPS elsewhere; ``"lammps"`` / ``"numba"`` force one, and a
forced engine that cannot run the scene, or an option it does not take, is an error raised
before any work.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple, Protocol

import numpy as np



class Window(NamedTuple):
    """What one window of a minimiser returns (``Engine.minimizer_session``)."""

    iterations: int  #: minimiser iterations in the window
    objective: float  #: total energy, or the enthalpy U + P V at a target pressure (eps)
    max_force: float  #: largest force component (eps/diameter)
    max_torque: float  #: largest generalized torque tau_a / d_k or box force component; 0.0 if none
    fluctuation: float | None = None  #: damped MD of disks/spheres: relative rms fluctuation of V sampled in the window
    kinetic: float = 0.0  #: damped MD: total kinetic energy at the window's end (eps)


@dataclass(frozen=True)
class State:
    """Energy, forces, torques and pressure tensor at the current configuration.

    ``torques`` are world-frame torques: (N,) about z in 2D, (N, 3) in 3D; None for disks and
    spheres. ``pressure_tensor`` is the virial part of the stress (athermal packings),
    P_ab = V^-1 sum_pairs r_ij,a f_ij,b (chapter eq. 2.34; for rigid bodies r_ij joins the
    centres), positive under compression."""

    energy: float  #: total, eps
    forces: np.ndarray  #: (N, d), eps/diameter, packing order
    pressure_tensor: np.ndarray  #: (d, d), eps/diameter^d
    torques: np.ndarray | None = None  #: eps; None for disks and spheres

    @property
    def energy_per_particle(self) -> float:
        """V = energy / N, eps."""
        return self.energy / len(self.forces)

    @property
    def pressure(self) -> float:
        """P = trace / d of the pressure tensor, eps / diameter^d."""
        return float(np.trace(self.pressure_tensor) / len(self.pressure_tensor))

    @property
    def max_force(self) -> float:
        """Largest force component, eps / diameter (0 without particles)."""
        return float(np.max(np.abs(self.forces))) if self.forces.size else 0.0

    @property
    def max_torque(self) -> float:
        """Largest world-frame torque component, eps (0 without torques)."""
        return float(np.max(np.abs(self.torques))) if self.torques is not None and self.torques.size else 0.0


@dataclass(frozen=True)
class Capabilities:
    """What an engine runs; ``reason`` says why it cannot run a scene (None if it can)."""

    shapes: frozenset  #: shape kinds it runs ("sphere", "ellipsoid", "rigid")
    potentials: frozenset  #: pair laws it runs ("spring", "rlj")
    methods: frozenset  #: minimisers it runs
    tilted_boxes: bool = True  #: runs sheared (triclinic) boxes
    mpi: bool = False  #: runs on an MPI communicator
    options: frozenset = field(default_factory=frozenset)  #: keyword options its constructor takes
    boundaries: frozenset = field(default_factory=frozenset)  #: of "walls", "fixed", "gravity" (disks, spheres)
    box_methods: frozenset = field(default_factory=frozenset)  #: minimisers that relax the box at a target pressure
    shape_methods: tuple = ()  #: (shape kind, minimisers, why) where a shape runs fewer minimisers

    def reason(self, packing, method: str | None = "fire", comm=None, pressure: bool = False) -> str | None:
        """Why the engine cannot run the scene, or None; ``method`` None: any of its minimisers."""
        needs = scene_boundaries(packing)
        if needs and not packing.shape.bounded:
            return f"{' and '.join(sorted(needs))} with {packing.shape.name(packing.dim)} particles (written for disks and spheres)"
        if needs - self.boundaries:
            return f"{' and '.join(sorted(needs - self.boundaries))} (it runs {', '.join(sorted(self.boundaries)) or 'none'})"
        if pressure and method not in self.box_methods:
            return (f"a target pressure with minimizer {method} (it relaxes the box with "
                    f"{', '.join(sorted(self.box_methods)) or 'no minimizer'})")
        if packing.shape.kind not in self.shapes:
            return f"{packing.shape.name(packing.dim)} particles (it runs {', '.join(sorted(self.shapes))})"
        if packing.potential.name not in self.potentials:
            return f"potential {packing.potential.spec} (it runs {', '.join(sorted(self.potentials))})"
        if method is not None and method not in self.methods:
            return f"minimizer {method} (it runs {', '.join(sorted(self.methods))})"
        methods, why = {kind: (m, w) for kind, m, w in self.shape_methods}.get(packing.shape.kind, (None, ""))
        if method is not None and methods is not None and method not in methods:
            return (f"minimizer {method} on {packing.shape.name(packing.dim)} particles: {why} (it runs "
                    f"{', '.join(sorted(methods))} there)")
        if packing.box.is_triclinic and not self.tilted_boxes:
            return "a tilted (sheared) box"
        if comm is not None and not self.mpi:
            return "an MPI communicator (it is serial)"
        return None


def scene_boundaries(packing) -> set:
    """What a packing needs beyond pairs in a periodic box: walls, fixed particles, gravity."""
    needs = set()
    if packing.box.walls:
        needs.add("walls")
    if packing.fixed is not None:
        needs.add("fixed")
    if packing.gravity > 0:
        needs.add("gravity")
    return needs


class Engine(Protocol):
    """One packing held by an engine (a context manager; ``close`` frees it).

    Everything the minimisers, protocols and commands call on an engine is here; both
    ``CompiledEngine`` and ``LammpsEngine`` implement all of it."""

    name: str  #: "numba" or "lammps": recorded with every result (the files' ``engine``)
    kernels: str  #: the code that ran: "ahead-of-time" or "numba" (compiled engine), "lammps"; summary lines only
    template: object  #: the Packing it was built from (shape, sizes, potential)
    box: object  #: the current Box
    commands: list  #: LAMMPS commands sent (empty for engines that send none)

    def __enter__(self) -> "Engine":
        """The engine itself."""
        ...

    def __exit__(self, *exc) -> None:
        """``close``."""
        ...

    def close(self) -> None:
        """Free what the engine holds (pair lists, the LAMMPS instance)."""
        ...

    def set_box(self, box) -> None:
        """Deform the cell affinely to ``box`` (positions follow, x -> h' h^-1 x); forces are
        stale until ``evaluate``."""
        ...

    def positions(self) -> np.ndarray:
        """(N, d) current positions in packing order (rigid bodies: their centres)."""
        ...

    def orientations(self) -> np.ndarray | None:
        """Current orientations in the Packing's form (2D angles, 3D quaternions); None for
        disks and spheres."""
        ...

    def set_positions(self, positions, orientations=None) -> None:
        """Move (and, given ``orientations``, turn) the particles; forces are stale until
        ``evaluate``."""
        ...

    def evaluate(self) -> State:
        """Compute energy, forces, torques and pressure tensor at the current configuration."""
        ...

    def state(self) -> State:
        """The ``State`` as last computed."""
        ...

    def packing(self, **metadata):
        """The current configuration as a new Packing (``metadata`` added to it)."""
        ...

    def counters(self) -> dict:
        """Name -> count of what the shape's contact solver counted since the engine was opened
        (ellipsoids: contact-distance fallbacks, approximate contacts, invalid pairs); empty
        where the shape counts nothing."""
        ...

    def minimizer_session(self, settings, ftol: float):
        """Context manager yielding ``window(steps) -> Window``; each window is one restart of the
        minimiser ``settings.method`` stopping at max force ``ftol``."""
        ...
