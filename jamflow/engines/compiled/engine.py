"""``CompiledEngine`` (engine name "numba"): the FIRE of ``compiled.fire`` with the kernel of the
packing's shape, in process, no LAMMPS.

It runs every box (orthogonal or tilted: pairs carry their periodic image offsets, box changes
are affine, x -> h' h^-1 x) on one core (disks and spheres with a spring law in a periodic box on
several with the option ``threads``, ``compiled.threads``), minimises with FIRE only, and is measured against
LAMMPS and the numpy reference in tests/test_engines.py and benchmarks/engines.py. Walls,
gravity and fixed particles (disks and spheres) are the external field of ``compiled.field``;
at a target pressure (``MinimizerSettings.pressure``) the box joins FIRE's coordinates. Disks and
spheres with the spring law run the same kernels compiled ahead of time (``compiled.aot``: no
numba start-up). The interface is ``jamflow.engines.base.Engine``.
"""

from __future__ import annotations

import math
import warnings
from contextlib import contextmanager

import numpy as np

from jamflow.model.box import Box
from jamflow.model.packing import Packing
from jamflow.engines.base import Capabilities, State, Window
from jamflow.engines.compiled import announce_compile, fire
from jamflow.engines.compiled.aot import kernels_for
from jamflow.engines.compiled.field import make_field
from jamflow.engines.compiled.kernels import BUILDERS, COUNTERS, TURNING_MOVES_SITES
from jamflow.engines.compiled.threads import ThreadedKernels, check_threads, uncovered

# cold compile of a shape's kernels (FIRE and forces; jam --n 64 cold minus warm, CPU s on the
# development machine: ellipses 9.9, dimers 7.6, disks with rlj 6.2), said in the notice printed
# before numba compiles them
COMPILE_SECONDS = {"ellipsoid": 10, "rigid": 8, "sphere": 6}


def _orientation_array(packing: Packing) -> np.ndarray:
    """Orientations as the kernels hold them: (N, 0) spheres, (N, 1) 2D angles, (N, 4) quaternions."""
    if packing.orientations is None:
        return np.zeros((packing.n, 0))
    o = np.array(packing.orientations, dtype=float)
    return o.reshape(packing.n, -1).copy()


CELL_GROWTH_LIMIT = 1e6  # a cell that grew by more than this within a minimisation has diverged


class CompiledEngine:
    """In-process engine; ``skin`` is the pair-list skin in diameters; ``threads`` > 1 runs FIRE and the
    forces of disks and spheres with a spring law in a periodic box on that many threads
    (``compiled.threads``; any other scene runs serial, with one warning saying why); 1 (the default):
    the serial kernels."""

    name = "numba"
    CAPABILITIES = Capabilities(shapes=frozenset(BUILDERS), potentials=frozenset({"spring", "rlj"}),
                                methods=frozenset({"fire"}), tilted_boxes=True, mpi=False,
                                options=frozenset({"skin", "threads"}), boundaries=frozenset({"walls", "fixed", "gravity"}),
                                box_methods=frozenset({"fire"}))

    def __init__(self, packing: Packing, *, skin: float = 0.3, threads: int = 1):
        threads = check_threads(threads)
        reason = self.CAPABILITIES.reason(packing)
        if reason:
            raise ValueError(f"the compiled engine cannot run {reason}; use engine lammps")
        if not (np.isfinite(skin) and skin > 0):
            raise ValueError(f"skin must be a finite positive length (diameters), got {skin!r}")
        self.template = packing
        self.box = packing.box
        self.skin = float(skin)
        self.commands: list[str] = []  # no LAMMPS commands: nothing to replay as a deck
        n, d = packing.n, packing.dim
        self._x = np.array(packing.positions, dtype=float)
        self._o = _orientation_array(packing)
        self._f = np.zeros((n, d))
        self._dk = np.ascontiguousarray(packing.rotational_lengths)
        r = self._dk.shape[1]
        self._tau, self._g = np.zeros((n, r)), np.zeros((n, r))
        self._mask = np.array(packing.shape.rotation_mask(d), dtype=float)
        reach = np.asarray(packing.shape.reach(packing.diameters), float)
        self._reach = reach if TURNING_MOVES_SITES[packing.shape.kind] else np.zeros_like(reach)  # rebuild rule
        self._virial = np.zeros((d, d))
        self._time_unit = fire.time_unit(packing.shape)
        self._field = make_field(packing)
        self._gb = np.zeros(0)  # box-coordinate forces (constant stress only)
        self._energy = None
        self._pairs = None
        self._built_at = self._x.copy()
        self._turned = np.zeros(n)
        self._counts = np.zeros(len(COUNTERS[packing.shape.kind]), np.int64)  # kernel counters of dropped lists
        aot = kernels_for(packing)
        self._kernels = aot or fire  # fire.fire / fire.forces, ahead of time where they exist
        self.kernels = "ahead-of-time" if aot is not None else "numba"  # which ran (summary lines; name stays "numba")
        self._looked_up: set = set()  # (kernel, field type) whose compile notice was considered
        self.threads = 1  # threads FIRE runs on (> 1: ``compiled.threads``)
        self._serial = (self._kernels, self.kernels)
        self._threaded = None
        self._warned = False  # the one warning of a scene the threaded kernels do not run
        if threads > 1:
            why = uncovered(packing)
            if why:
                self._warn_serial(threads, why)
            else:
                kernels = ThreadedKernels(threads, f"threaded {packing.shape.name(packing.dim)}")
                if kernels.available < threads:
                    warnings.warn(f"jamflow: threads={threads}, but numba runs at most {kernels.available} here "
                                  "(NUMBA_NUM_THREADS, by default the number of cores, or numba.set_num_threads): "
                                  f"running {kernels.available}", RuntimeWarning, stacklevel=2)
                self.threads = min(threads, kernels.available)
                self._threaded = (kernels, f"numba, {self.threads} thread{'s' if self.threads > 1 else ''}")
                self._kernels, self.kernels = self._threaded

    def _warn_serial(self, threads: int, why: str) -> None:
        if self._warned:
            return
        self._warned = True
        warnings.warn(f"jamflow: threads={threads} covers disks and spheres with a spring law in a periodic box, not "
                      f"{why}: the serial kernels run this scene", RuntimeWarning, stacklevel=3)

    def _announce(self, kernel, args) -> None:
        """One line on stderr before numba compiles this shape's kernels (``compiled.announce_compile``);
        looked up once per kernel and field type (a target pressure makes another field) per engine."""
        key = (getattr(kernel, "__name__", ""), type(self._field))
        if self.kernels == "numba" and key not in self._looked_up:
            self._looked_up.add(key)
            shape, dim = self.template.shape, self.template.dim
            what = "rigid-body" if shape.made_of_sites else shape.name(dim)
            announce_compile(what, COMPILE_SECONDS.get(shape.kind, 10), kernel, args)

    # lifecycle ---------------------------------------------------------------------------------
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self):
        self._drop_pairs()

    # pair list -----------------------------------------------------------------------------------
    def _drop_pairs(self):
        if self._pairs is not None and self._counts.size:
            self._counts += self._pairs.counters
        self._pairs = None

    def counters(self) -> dict:
        """What the shape's kernel counted since the engine was opened (``COUNTERS`` of its
        module; ellipsoids: contact-distance fallbacks, approximate contacts, invalid pairs)."""
        live = self._pairs.counters if self._pairs is not None and self._counts.size else 0
        names = COUNTERS[self.template.shape.kind]
        return dict(zip(names, (int(c) for c in self._counts + live)))

    def _check_counters(self):
        invalid = self.counters().get("invalid", 0)
        if invalid:
            raise RuntimeError(f"the contact-distance solver returned a non-finite sigma for {invalid} pair "
                               "evaluation(s) (coincident centres or non-finite coordinates); start from a valid "
                               "configuration (jamflow.protocols.compression checks starts before work)")

    def _build_pairs(self):
        self._drop_pairs()
        self._x = self.box.wrap(self._x)
        self._pairs = BUILDERS[self.template.shape.kind](self.packing(), self._x, self.skin)
        self._built_at = self._x.copy()
        self._turned[:] = 0.0

    def _model(self):
        if self._pairs is None:
            self._build_pairs()
        return self._pairs

    # state -----------------------------------------------------------------------------------------
    def positions(self) -> np.ndarray:
        """Current positions (packing order), wrapped into the cell."""
        return self.box.wrap(self._x)

    def orientations(self) -> np.ndarray | None:
        """Current orientations in the Packing's form (None for disks and spheres)."""
        if self.template.orientations is None:
            return None
        return self._o[:, 0].copy() if self.template.dim == 2 else self._o.copy()

    def set_positions(self, positions: np.ndarray, orientations=None) -> None:
        """Move (and turn) the particles; forces are stale until ``evaluate``."""
        self._x = np.array(positions, dtype=float)
        if orientations is not None:
            self._o = _orientation_array(self.template.with_positions(self._x, orientations=orientations))
        self._drop_pairs()
        self._energy = None

    def evaluate(self) -> State:
        """Energy, forces, torques and virial pressure tensor at the current configuration."""
        args = (self._model(), self._field, self._x, self._f, self._o, self._tau, self._g, self._dk, self._mask,
                self._virial, self._gb)
        self._announce(self._kernels.forces, args)
        self._energy = self._kernels.forces(*args)
        self._check_counters()
        return self.state()

    def state(self) -> State:
        if self._energy is None:
            return self.evaluate()
        torques = None
        if self.template.orientations is not None:
            torques = self._tau[:, 0].copy() if self.template.dim == 2 else self._tau.copy()
        return State(float(self._energy), self._f.copy(), self._virial / self.box.volume, torques)

    def packing(self, **metadata) -> Packing:
        return self.template.with_positions(self.box.wrap(self._x), box=self.box,
                                            orientations=self.orientations(), **metadata)

    # box changes ------------------------------------------------------------------------------------
    def set_box(self, box: Box) -> None:
        """Deform the cell affinely (positions follow, x -> h' h^-1 x), like LAMMPS
        ``change_box ... remap``; orientations do not change."""
        if box.dim != self.box.dim:
            raise ValueError("cannot change the dimension of a running system")
        if box.is_triclinic or self.box.is_triclinic:
            self._x = box.to_cartesian(self.box.to_fractional(self._x))
        else:
            self._x = self._x * (box.lengths / self.box.lengths)
        self.box = box
        self._field.h[:] = box.h
        self._drop_pairs()
        self._energy = None

    # minimisation -------------------------------------------------------------------------------------
    @contextmanager
    def minimizer_session(self, settings, ftol: float):
        """Yield ``window(steps) -> (iterations, objective, max force component, max generalized
        torque or box force component)``; each window restarts FIRE (v = 0, dt = timestep in the
        shape's time unit, ``fire.time_unit``) like one LAMMPS ``minimize`` command. The objective is the total energy, or at a target
        pressure the enthalpy U + P V with the box as coordinates (``compiled.field``)."""
        if settings.method != "fire":
            raise ValueError(f"the compiled engine runs FIRE only, not {settings.method}; use engine lammps")
        n = self.template.n
        pressure = settings.pressure
        halt = -np.inf if pressure is not None else settings.v_min * self.template.n_mobile
        half_skin_sq = (self.skin / 2) ** 2
        self._session_volume = self.box.volume  # the cell's volume as the minimisation starts (``_cell_valid``)
        if pressure is not None:
            self._field = make_field(self.packing(), pressure, settings.stress)
            self._gb = np.zeros(len(self._field.basis))
            self._energy = None
            if self._threaded is not None:  # box coordinates: the serial kernels, for this minimisation
                self._warn_serial(self.threads, uncovered(self.template, pressure=True))
                self._kernels, self.kernels = self._serial

        def window(steps: int):
            if self._threaded is not None:  # which kernels ran (summary lines)
                self.kernels = self._threaded[1] if self._kernels is self._threaded[0] else self._serial[1]
            state = fire.fire_state(settings.timestep * self._time_unit)
            v, w, u = np.zeros_like(self._x), np.zeros_like(self._g), np.zeros_like(self._gb)
            done = 0
            while True:
                args = (self._model(), self._field, self._x, v, self._f, self._o, w, self._tau, self._g, self._dk,
                        self._mask, self._virial, u, self._gb, state, self._built_at, self._turned, self._reach,
                        half_skin_sq, steps - done, ftol, halt)
                self._announce(self._kernels.fire, args)
                ran, reason, energy = self._kernels.fire(*args)
                done += ran
                self._energy = energy
                if not self._cell_valid():  # the box coordinates diverged: what the rules call "blown-up"
                    return Window(done, math.inf, math.inf, math.inf)
                self._sync_box()
                if reason != fire.REBUILD or done >= steps:
                    break
                self._build_pairs()
            if reason == fire.REBUILD:  # the cap fell on a rebuild step: forces with a fresh list
                self._build_pairs()
                self.evaluate()
            self._check_counters()
            fmax = float(np.abs(self._f).max()) if n else 0.0
            gmax = max([0.0] + [float(np.abs(a).max()) for a in (self._g, self._gb) if a.size])
            objective = float(self._energy) + (pressure * self.box.volume if pressure is not None else 0.0)
            return Window(done, objective, fmax, gmax)

        try:
            yield window
        finally:
            if pressure is not None:  # back to a fixed box
                self._field = make_field(self.packing())
                self._gb = np.zeros(0)
                if self._threaded is not None:  # the label stays the serial one until a threaded window runs
                    self._kernels = self._threaded[0]

    def _cell_valid(self) -> bool:
        """The field's cell matrix is finite, with positive side lengths and a volume below
        ``CELL_GROWTH_LIMIT`` times the minimisation's start (a target pressure that FIRE's box steps
        overshoot inverts the cell or blows it up within a window)."""
        if not len(self._field.basis):
            return True
        h = self._field.h
        if not (np.all(np.isfinite(h)) and np.all(np.diag(h) > 0)):
            return False
        return float(np.prod(np.diag(h))) < CELL_GROWTH_LIMIT * self._session_volume

    def _sync_box(self) -> None:
        """After box steps: the Box follows the field's cell matrix."""
        if len(self._field.basis):
            self.box = self.box.with_h(self._field.h.copy())
