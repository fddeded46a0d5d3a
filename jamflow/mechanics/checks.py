"""Is a packing what it claims to be? The checks run before a packing is written
(``jamflow jam``) and before one is analysed (``jamflow modes``, ``analyze``).

- window: V_tol < V < 2 V_tol (chapter section 2.1, step 4), V the energy per particle;
- force balance: the largest net force component on any particle, and for particles that
  turn the largest generalized torque tau_a / d_k (body frame, the minimiser's coordinates),
  is at most ``BALANCE_RTOL`` of the mean contact force (a packing at an energy minimum has
  net forces at round-off, ~1e-6 of the contact forces for springs at V ~ 1e-16), or at
  most the float64 round-off floor of forces (the minimiser's default tolerance, ~L 1e-16
  times the contact stiffness) when the contacts themselves are that weak; wall and gravity
  forces count (fixed particles are held);
- contact count among the non-floaters (chapter section 4.1, ``jamflow.mechanics.contacts``):
  disks and spheres need N_c >= N_c,iso = N' d - d_trivial + 1; particles that turn are
  generally hypostatic (N_c < N' d_f - d + 1, chapter section 4.1), so for them the check asks for
  the translational count N' d - d_trivial + 1 that any jammed packing exceeds or meets.

Forces, torques and energies are recomputed here in float64 from the packing itself with the
numpy reference over the pairs of the cell search (``engine.reference``, ``pairs="near"``),
independently of the engine that made it. Units: energies in eps per particle, forces in
eps/diameter.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields

import numpy as np

from jamflow.mechanics.contacts import Contacts
from jamflow.mechanics.force_floor import packing_force_floor
from jamflow.model.packing import Packing
from jamflow.model.shapes.rotations import generalized_torques as body_torques

BALANCE_RTOL = 1e-3  # max net force / mean contact force above this: not at an energy minimum


@dataclass(frozen=True)
class PackingChecks:
    """Outcome of ``check_packing``; None where a check could not be made (no V_tol known)."""

    energy_per_particle: float  #: V, eps
    v_tol: float | None  #: V_tol of the window, eps (None: unknown, the window is not checked)
    in_window: bool | None  #: V_tol < V < 2 V_tol (None: not checked)
    max_force: float  #: largest net force component, eps/diameter (refine: largest norm |F|)
    force_tol: float | None  #: the minimiser's tolerance, for the record
    mean_contact_force: float  #: mean |dV/dr| over overlapping pairs (nan without any)
    force_ratio: float  #: max_force / mean_contact_force
    force_balanced: bool  #: force_ratio <= BALANCE_RTOL, or max_force below the packing's force floor
    n_contacts: int  #: N_c among non-floaters
    isostatic_count: int  #: N_c,iso
    excess_contacts: int  #: N_c - N_c,iso
    n_floaters: int  #: N_f, the floaters
    n_kept: int  #: N' = N - N_f
    mean_z: float  #: <z> among non-floaters
    jammed: bool  #: N_c >= N_c,iso with at least one non-floater

    @property
    def passed(self) -> bool:
        """In the window (or not checked), force balanced and jammed: the packing may be written as jammed."""
        return self.in_window is not False and self.force_balanced and self.jammed

    def __repr__(self) -> str:
        """One line: passed, V (in the window?), force ratio, contacts against isostatic, floaters."""
        return (f"PackingChecks(passed={self.passed}, V={self.energy_per_particle:.3e}, in_window={self.in_window}, "
                f"force_ratio={self.force_ratio:.2e}, N_c={self.n_contacts}, isostatic={self.isostatic_count}, "
                f"floaters={self.n_floaters}, mean_z={self.mean_z:.4f})")

    def problems(self) -> list[str]:
        """One sentence per failed check, saying what is wrong."""
        out = []
        if self.in_window is False:
            out.append(f"V = {self.energy_per_particle:.3e} is outside the window ({self.v_tol:g}, {2 * self.v_tol:g})")
        if not self.force_balanced:
            out.append(f"not at an energy minimum: the largest net force {self.max_force:.2e} is "
                       f"{self.force_ratio:.2g} of the mean contact force {self.mean_contact_force:.2e} "
                       f"(force balance needs <= {BALANCE_RTOL:g})")
        if not self.jammed and self.n_kept == 0:
            out.append("not jammed: every particle is a floater (no contact network)")
        elif not self.jammed:
            out.append(f"not jammed: {self.n_contacts} contacts among {self.n_kept} non-floaters, fewer than "
                       f"the isostatic {self.isostatic_count}")
        return out

    def as_attrs(self) -> dict:
        """HDF5-friendly attributes (None -> nan or the string 'None'), plus ``passed``."""
        out = {k: (math.nan if v is None and k != "in_window" else v) for k, v in asdict(self).items()}
        out["in_window"] = "None" if self.in_window is None else bool(self.in_window)
        return {**out, "passed": self.passed, "balance_rtol": BALANCE_RTOL}

    @classmethod
    def from_attrs(cls, attrs) -> "PackingChecks":
        """Inverse of ``as_attrs`` (reads a file's ``checks`` group)."""
        values = {f.name: attrs[f.name] for f in fields(cls)}
        window = values["in_window"]
        values["in_window"] = None if isinstance(window, (str, bytes)) else bool(window)
        for name in ("v_tol", "force_tol"):
            values[name] = None if math.isnan(values[name]) else float(values[name])
        return cls(**values)


def check_packing(packing: Packing, energy_per_particle: float | None = None, max_force: float | None = None,
                  v_tol: float | None = None, ftol: float | None = None) -> PackingChecks:
    """Window, force (and torque) balance and contact count of ``packing``, any shape.

    ``energy_per_particle`` and ``max_force`` (the engine's values) are recomputed from the
    packing when None; ``v_tol`` None skips the window check; ``ftol`` is recorded only.

    Parameters
    ----------
    packing : jamflow.Packing
        The packing to check (lengths in diameters).
    energy_per_particle : float, optional
        V in eps, as the engine reported it; None: recomputed from the packing.
    max_force : float, optional
        The largest force (and generalised torque) component, eps / diameter; None: recomputed.
    v_tol : float, optional
        The energy window's V_tol (eps): ``in_window`` is V_tol < V < 2 V_tol; None: not checked.
    ftol : float, optional
        The minimiser's force tolerance (eps / diameter), recorded in the result only.

    Returns
    -------
    PackingChecks
        The window, force balance (max force / mean contact force, or below the packing's force
        floor), contact count against the isostatic count, floaters and mean contact number;
        ``passed`` and ``problems()`` summarise them.
    """
    from jamflow.mechanics.reference import energy_forces_pressure

    ref = energy_forces_pressure(packing, pairs="near")
    v = ref.energy / packing.n if energy_per_particle is None else float(energy_per_particle)
    worst = float(np.abs(ref.forces).max()) if ref.forces.size else 0.0
    if ref.torques is not None and packing.n:
        worst = max(worst, float(np.abs(generalized_torques(packing, ref.torques)).max()))
    fmax = worst if max_force is None else float(max_force)
    magnitudes = ref.contact_forces
    mean_f = float(magnitudes.mean()) if len(magnitudes) else math.nan
    ratio = fmax / mean_f if len(magnitudes) else (0.0 if fmax == 0 else math.inf)
    floor = packing_force_floor(packing)
    c = Contacts(count="sites").compute(packing)  # rigid bodies: one constraint per site pair (the matrix's count)
    needed = c.isostatic_count - c.n_kept * (packing.dof_per_particle - packing.dim)  # N' d - d_trivial (+ 1)
    in_window = None if v_tol is None else bool(v_tol < v < 2 * v_tol)
    return PackingChecks(
        energy_per_particle=v, v_tol=None if v_tol is None else float(v_tol), in_window=in_window,
        max_force=fmax, force_tol=None if ftol is None else float(ftol), mean_contact_force=mean_f,
        force_ratio=float(ratio), force_balanced=bool(ratio <= BALANCE_RTOL or fmax <= floor), n_contacts=c.n_contacts,
        isostatic_count=c.isostatic_count, excess_contacts=c.excess_contacts, n_floaters=c.n_floaters,
        n_kept=c.n_kept, mean_z=float(c.mean_z), jammed=bool(c.n_kept > 0 and c.n_contacts >= needed))


def generalized_torques(packing: Packing, torques: np.ndarray) -> np.ndarray:
    """(N, r) tau_a / d_k about each rotational body axis that is a degree of freedom (zero
    about the others): the forces of the minimiser's rotational coordinates (eps/diameter)."""
    return body_torques(packing.orientations, torques, packing.dim, packing.rotational_lengths,
                        packing.shape.rotation_mask(packing.dim))


def generalized_forces(packing: Packing, state, rows=None) -> np.ndarray:
    """-dV/dxi in the coordinates of ``analysis.hessian.Coordinates`` (eps/diameter): the forces,
    then tau_a / d_k about each rotational axis that is a degree of freedom; of ``rows`` only
    (particle indices) if given. ``state`` holds the forces and torques of the whole packing."""
    rows = slice(None) if rows is None else rows
    forces = np.asarray(state.forces, float)[rows].ravel()
    axes = np.flatnonzero(packing.shape.rotation_mask(packing.dim))
    if not len(axes):
        return forces
    return np.concatenate([forces, generalized_torques(packing, state.torques)[rows][:, axes].ravel()])


# The refusal thresholds (benchmarks/vtol_resolution.py, docs/notes/vtol-resolution.csv, 96 runs at
# N = 64 and 256, springs and Hertz): net force / contact force ~ 1.1 / (window force / ftol),
# and at window force / ftol <= 1.8e3 at least half of the N = 256 packings failed their
# checks (lost contacts first); of the 32 runs at >= 1e4, 31 passed. The overlap ratio never
# bound first there (it does for soft exponents alpha < 2): overlaps must be resolved to 0.1%.
MIN_FORCE_RATIO = 2.0 / BALANCE_RTOL
MIN_OVERLAP_RATIO = 1e3


@dataclass(frozen=True)
class Resolution:
    """What float64 positions and the force tolerance resolve in the energy window.

    ``window_overlap``: the overlap delta = 1 - r/sigma (sigma the smallest diameter) of a
    contact when every particle carries d contacts and V = V_tol; ``overlap_roundoff``: the
    spacing of float64 numbers at the longest box side over sigma (positions, hence overlaps,
    are known no better); ``window_force``: |dV/dr| of such a contact, against ``force_tol``.
    ``smallest_v_tol``: the V_tol at which both ratios reach their minimum.
    """

    v_tol: float  #: the V_tol examined, eps
    window_overlap: float  #: 1 - r/sigma of a contact in the window (dimensionless)
    overlap_roundoff: float  #: float64 spacing at the longest box side, over sigma
    window_force: float  #: |dV/dr| of such a contact, eps / diameter
    force_tol: float  #: the minimiser's force tolerance, eps / diameter
    smallest_v_tol: float  #: the smallest V_tol both ratios allow, eps

    @property
    def overlap_ratio(self) -> float:
        """window_overlap / overlap_roundoff (contacts need >= MIN_OVERLAP_RATIO)."""
        return self.window_overlap / self.overlap_roundoff

    @property
    def force_ratio(self) -> float:
        """window_force / force_tol (force balance needs >= MIN_FORCE_RATIO)."""
        return self.window_force / self.force_tol

    def problem(self) -> str | None:
        """Why V_tol cannot be resolved and what to use instead, or None."""
        why, fixes = [], [f"vtol (--vtol) >= {self.smallest_v_tol:.1e}"]
        if self.overlap_ratio < MIN_OVERLAP_RATIO:
            why.append(f"a contact in the window overlaps by ~{self.window_overlap:.1e} diameters, only "
                       f"{self.overlap_ratio:.2g}x the float64 round-off of positions {self.overlap_roundoff:.1e} "
                       f"(contacts need >= {MIN_OVERLAP_RATIO:g}x)")
        if self.force_ratio < MIN_FORCE_RATIO:
            why.append(f"its contact force ~{self.window_force:.1e} is only {self.force_ratio:.2g}x the force "
                       f"tolerance {self.force_tol:.1e} (force balance needs >= {MIN_FORCE_RATIO:g}x)")
            if self.overlap_ratio >= MIN_OVERLAP_RATIO:
                fixes.append(f"a force tolerance (--ftol) <= {self.window_force / MIN_FORCE_RATIO:.1e}")
        if not why:
            return None
        return f"vtol {self.v_tol:g} is not resolvable: {'; '.join(why)}; use {', or '.join(fixes)}"


def resolution(packing: Packing, v_tol: float, force_tol: float) -> Resolution:
    """``Resolution`` of the window (V_tol, 2 V_tol) for this packing's N, box and potential."""
    energy, force = _contact_law(packing)
    delta = _solve(energy, v_tol / packing.dim)
    roundoff = float(np.spacing(packing.box.lengths.max())) / float(packing.shape.smallest_contact(packing.diameters))
    needed = max(MIN_OVERLAP_RATIO * roundoff, _solve(force, MIN_FORCE_RATIO * force_tol))
    return Resolution(float(v_tol), delta, roundoff, force(delta), float(force_tol), packing.dim * energy(needed))


def _contact_law(packing: Packing):
    """V(delta) and |dV/dr|(delta) of one contact of the smallest contact distance."""
    pot, sigma = packing.potential, float(packing.shape.smallest_contact(packing.diameters))

    def energy(delta):
        return float(pot.energy(np.array([sigma * (1 - delta)]), sigma)[0])

    def force(delta):
        return float(abs(pot.dv_dr(np.array([sigma * (1 - delta)]), sigma)[0]))

    return energy, force


def _solve(increasing, target: float) -> float:
    """The overlap delta in (0, 0.5] where ``increasing(delta)`` reaches ``target``
    (bisection in log delta; 0.5 if it never does)."""
    lo, hi = 1e-300, 0.5
    if increasing(hi) <= target:
        return hi
    for _ in range(200):
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if increasing(mid) < target else (lo, mid)
    return hi
