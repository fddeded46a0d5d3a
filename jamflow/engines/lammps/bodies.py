"""Rigid bodies in the LAMMPS engine: one atom per site, one molecule per body.

LAMMPS has no minimiser for rigid bodies (``minimize`` ignores ``fix rigid``; docs: the wheel
notes), so ``LammpsEngine`` relaxes them by damped rigid-body dynamics at zero temperature,
``fix rigid molecule langevin 0 0 DAMP SEED`` (drag -m v / DAMP on each centre and
-I omega / DAMP on each rotation, no noise at T = 0), with DAMP = 1 / ``damping``: the body mass is
1, so the translational drag coefficient is the ``MinimizerSettings.damping`` of damped MD.
Not ``fix rigid/small``: its ``setup()`` allocates the Langevin force array and adds it to the body
forces before ``post_force`` first fills it, so the first half-step of a run integrates
uninitialised memory (found by valgrind; it made the dimer deck blow up or give NaN pressures
depending on the environment's size: docs/notes/nmers.md). ``fix rigid`` zeroes that array in setup.
Intra-body site pairs are excluded (``neigh_modify exclude molecule/intra all``).

LAMMPS computes site forces; this module does the rigid-body bookkeeping from the sites:
- centres: the mass-weighted site centres. The site masses (``RigidBody.site_masses``) make that
  the union's centre of mass, jamflow's body centre, which is also LAMMPS's rigid-body centre
  (measured: ``compute rigid/local`` centres equal jamflow's to 2e-15);
- orientations: the rotation carrying the body-frame sites onto the world sites
  (``shapes.rotations.fit_orientations``);
- body forces: sums of site forces; torques: sums of lever x site force (world frame);
- the molecular virial sum over site pairs of (R_I - R_J) f_st (chapter eq. 2.34 with centre
  separations, as the reference and the compiled engine): LAMMPS's pair virial of the sites,
  sum (r_s - r_t) f_st, minus sum over sites of lever_s f_s.
Box changes move the centres affinely (x -> h' h^-1 x) and put each body's sites back rigidly
around its centre: ``change_box ... remap`` would scale the sites and distort the bodies.
Units: eps, diameter, unit body mass.
"""

from __future__ import annotations

import numpy as np

from jamflow.model.packing import Packing
from jamflow.model.shapes.rotations import fit_orientations, generalized_torques

RIGID_FIX = "jf_rigid"
RIGID_CHECK = 500  # steps between force/torque checks of damped rigid-body dynamics
LANGEVIN_SEED = 4928  # no noise at T = 0; LAMMPS wants a seed all the same


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b over the last axis: the z-component in 2D, the vector in 3D."""
    if a.shape[-1] == 2:
        return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return np.cross(a, b)


class BodySites:
    """The map between a packing of rigid bodies and its LAMMPS atoms (site s of body k is atom
    k S + s + 1)."""

    def __init__(self, packing: Packing):
        shape = packing.shape
        self.n, self.dim, self.n_sites = packing.n, packing.dim, shape.n_sites
        self.masses = shape.site_masses  # ValueError here, before LAMMPS starts, if no masses fit
        self.local = packing.diameters[:, None, None] * shape.sites[None]  # (N, S, d) body frame
        self.lengths = packing.rotational_lengths
        self.mask = shape.rotation_mask(packing.dim)
        self.template = packing

    def world(self, positions: np.ndarray, orientations: np.ndarray) -> np.ndarray:
        """(N S, d) site positions of bodies at ``positions`` turned by ``orientations``."""
        p = self.template
        return p.shape.world_sites(positions, orientations, p.diameters).reshape(-1, self.dim)

    def bodies(self, sites: np.ndarray, box) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(centres (N, d) wrapped into the box, orientations, levers (N, S, d)) from site
        positions (N S, d) in atom order, wrapped or not."""
        x = sites.reshape(self.n, self.n_sites, self.dim)
        rel = box.minimum_image(x - x[:, :1])  # a body is smaller than half the box
        offset = np.einsum("s,nsa->na", self.masses, rel)
        levers = rel - offset[:, None, :]
        return box.wrap(x[:, 0] + offset), fit_orientations(self.local, levers, self.masses), levers

    def forces_torques(self, levers: np.ndarray, site_forces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Body forces (N, d) and world torques ((N,) 2D, (N, 3) 3D) from site forces (N S, d)."""
        f = site_forces.reshape(self.n, self.n_sites, self.dim)
        return f.sum(axis=1), cross(levers, f).sum(axis=1)

    def virial_correction(self, levers: np.ndarray, site_forces: np.ndarray) -> np.ndarray:
        """sum over sites of lever_s,a f_s,b: site virial minus this is the molecular virial."""
        return np.einsum("nsa,nsb->ab", levers, site_forces.reshape(levers.shape))

    def generalized(self, orientations: np.ndarray, torques: np.ndarray) -> np.ndarray:
        """Generalized torques tau_a / d_k (N, r), body frame, the rotations that are DOF."""
        return generalized_torques(orientations, torques, self.dim, self.lengths, self.mask)

    def damped_dynamics_commands(self, settings, fix_2d: str | None) -> list[str]:
        """The zero-temperature damped rigid-body dynamics of a minimisation session (fix
        enforce2d must follow fix rigid, so it is defined again)."""
        lines = ["velocity all set 0.0 0.0 0.0",
                 f"fix {RIGID_FIX} all rigid molecule langevin 0.0 0.0 {1.0 / settings.damping:.17g} "
                 f"{LANGEVIN_SEED}"]
        if fix_2d:
            lines += [f"unfix {fix_2d}", f"fix {fix_2d} all enforce2d"]
        return lines
