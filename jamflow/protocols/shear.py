"""Quasistatic shear at fixed zero pressure (chapter section 2.2, eq. 2.4, Figures 2.5-2.6).

From a static packing at strain gamma_0, each step applies x_i -> x_i + dgamma y_i with the
shear-periodic cell (the cell's xy tilt grows by dgamma l_y: ``Engine.set_box`` is affine, so
centres move and orientations do not), minimises at the new fixed strain and compresses or
decompresses back into the energy window V_tol < V < 2 V_tol (section 2.1 at fixed strain,
``compression.bisect``, from the current state with a small increment). Every step records
gamma, phi_J, V, the pressure tensor and the contact network among non-floaters, compared
with the previous step's: the same contacts (one continuous geometric family, Figure 2.6(a))
or contacts removed and added (a rearrangement, Figure 2.5(d)). A contact is a pair (i, j),
i < j, with r_ij < sigma_ij; the same pair touching through another periodic image (its
separation jumps by more than half a contact distance) counts as removed and added.

Strains are the accumulated Lees-Edwards strain of ``Box`` (any value; the engines hold the
reduced cell and flip it at |xy| = l_x / 2, docs/notes/shear-cell.md).
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from jamflow.mechanics.contacts import Contacts
from jamflow.engines.choose import open_engine
from jamflow.model.packing import Packing
from jamflow.model.pairs import separations
from jamflow.protocols.settings import CompressionSettings, fast_protocol
from jamflow.protocols.outcome import JamResult, engine_label
from jamflow.protocols.compression import bisect, check_resolution, check_strain, check_window_reachable

MAX_STEPS = 1_000_000
REARRANGED_FRACTION = 0.5  # a first step that removes more than this fraction of the contacts is warned about


def shear_protocol(**overrides) -> CompressionSettings:
    """The bisection used after each shear step: the fast protocol from a small increment
    (dphi0 = 1e-6, grown to at most 1e-4), without its coarse V_min (a sheared packing starts
    next to the window, where a coarse stop would misread a jammed state as unjammed)."""
    return fast_protocol(**{"dphi0": 1e-6, "dphi_max": 1e-4, "coarse_v_min": None, **overrides})


@dataclass(frozen=True)
class Network:
    """Contacts among non-floaters: pairs i < j (sorted) and their separations r_i - r_j."""

    i: np.ndarray  #: (C,) first particle of each contact
    j: np.ndarray  #: (C,) second particle, i < j
    dr: np.ndarray  #: (C, d) minimum-image separations r_i - r_j, diameters
    n_floaters: int  #: floaters removed before the contacts were listed

    def __repr__(self) -> str:
        """One line: contacts and floaters (the arrays are the fields)."""
        return f"Network(contacts={len(self.i)}, floaters={self.n_floaters})"

    @classmethod
    def of(cls, packing: Packing) -> "Network":
        """The network of ``packing`` (``Contacts`` with its defaults), pairs sorted."""
        c = Contacts().compute(packing)
        order = np.lexsort((c.j, c.i))
        i, j = c.i[order], c.j[order]
        return cls(i, j, separations(packing, i, j), c.n_floaters)

    @property
    def n_contacts(self) -> int:
        """N_c."""
        return len(self.i)

    def pairs(self) -> set:
        """The contacts as a set of (i, j)."""
        return set(zip(self.i.tolist(), self.j.tolist()))

    def changes(self, before: "Network", sigma) -> tuple[list, list]:
        """(removed, added): sorted lists of pairs (i, j) in ``before`` but not here and the
        reverse; a pair whose separation moved by more than sigma_ij / 2 (another image) is both."""
        mine = {p: k for k, p in enumerate(zip(self.i.tolist(), self.j.tolist()))}
        theirs = {p: k for k, p in enumerate(zip(before.i.tolist(), before.j.tolist()))}
        jumped = {p for p in mine.keys() & theirs.keys()
                  if np.linalg.norm(self.dr[mine[p]] - before.dr[theirs[p]]) > 0.5 * sigma(*p)}
        removed = sorted((theirs.keys() - mine.keys()) | jumped)
        added = sorted((mine.keys() - theirs.keys()) | jumped)
        return removed, added


@dataclass(frozen=True)
class ShearStep:
    """One static packing on the path, at accumulated strain ``gamma``."""

    gamma: float  #: accumulated shear strain (Lees-Edwards tilt / height)
    jam: JamResult  #: the bisection at this strain (packing, phi_J, V, pressure tensor, history)
    network: Network  #: the contacts among non-floaters at this step
    removed: list = field(default_factory=list)  #: contacts of the previous step that are gone
    added: list = field(default_factory=list)  #: contacts that were not there

    def __repr__(self) -> str:
        """One line: gamma, N, phi_J, Sigma, P, contacts and their changes; ``steps[k].jam`` holds the rest."""
        return (f"ShearStep(gamma={self.gamma:.6g}, N={self.packing.n}, phi_j={self.phi_j:.10f}, "
                f"shear_stress={self.shear_stress:.3e}, P={self.jam.pressure:.3e}, contacts={len(self.network.i)}, "
                f"removed={len(self.removed)}, added={len(self.added)})")

    @property
    def packing(self) -> Packing:
        """The jammed packing at this strain."""
        return self.jam.packing

    @property
    def phi_j(self) -> float:
        """phi_J at this strain."""
        return self.jam.phi_j

    @property
    def changed(self) -> bool:
        """True when the contact network differs from the previous step's."""
        return bool(self.removed or self.added)

    @property
    def shear_stress(self) -> float:
        """Sigma = -P_xy (eps / diameter^d)."""
        return float(-self.jam.pressure_tensor[0, 1])


@dataclass(frozen=True)
class ShearPath:
    """The static packings along a quasistatic shear path; step 0 is the start at gamma_0."""

    steps: list  #: the ``ShearStep`` of each strain, step 0 the start
    dgamma: float  #: the strain step (negative: shear backwards)
    settings: CompressionSettings  #: the bisection that jams each step
    engine: str  #: "numba" or "lammps"
    seconds: float  #: wall time of the run
    kernels: str = ""  #: the engine's ``kernels`` (summary line only)

    def __repr__(self) -> str:
        """One line: N, dim, shape, steps, the gamma range, phi_J range, contact changes, engine."""
        p, g, phi = self.steps[0].packing, self.gamma, self.phi_j
        return (f"ShearPath(N={p.n}, dim={p.dim}, shape={p.shape.spec(p.dim)!r}, steps={len(g) - 1}, "
                f"gamma=[{g[0]:.6g}, {g[-1]:.6g}], dgamma={self.dgamma:.3g}, phi_j=[{phi.min():.8f}, {phi.max():.8f}], "
                f"changes={self.n_changes}, engine={self.engine!r})")

    def column(self, name: str) -> np.ndarray:
        """gamma, phi_j, shear_stress or changed at every step, as an array."""
        return np.array([getattr(s, name) for s in self.steps])

    @property
    def gamma(self) -> np.ndarray:
        """The strain of every step."""
        return self.column("gamma")

    @property
    def phi_j(self) -> np.ndarray:
        """phi_J at every step."""
        return self.column("phi_j")

    @property
    def changed(self) -> np.ndarray:
        """(steps + 1,) bool: the contact network changed at that step."""
        return self.column("changed")

    @property
    def n_changes(self) -> int:
        """Steps at which the contact network changed."""
        return int(self.changed.sum())

    def summary(self) -> str:
        """The line ``jamflow shear`` prints: strain range, steps, the phi_J range, contact changes, engine."""
        g, phi = self.gamma, self.phi_j
        return (f"gamma {g[0]:.6g} -> {g[-1]:.6g} in {len(g) - 1} steps of {self.dgamma:.3g}: phi_J "
                f"{phi.min():.8f}..{phi.max():.8f}, contact network changed at {self.n_changes} steps "
                f"({engine_label(self.engine, self.kernels)}, {self.seconds:.1f} s)")


def shear_strains(gamma0: float, dgamma, to) -> np.ndarray:
    """The strains of a path, gamma0 + k dgamma, ending exactly at ``to``; ValueError for
    bad input (non-finite, dgamma 0 or pointing away from ``to``, too many steps)."""
    dgamma, to = check_strain(dgamma, "the strain step dgamma (--dgamma)"), check_strain(to, "the final strain to (--to)")
    if dgamma == 0.0:
        raise ValueError("dgamma must not be zero; the chapter's quasistatic steps are ~1e-3 (Delta gamma / n)")
    if to == gamma0:
        raise ValueError(f"--to {to:g} is the start's own strain: nothing to shear")
    if (to - gamma0) * dgamma < 0:
        raise ValueError(f"dgamma = {dgamma:g} moves away from --to {to:g} (the start is at gamma = {gamma0:.6g}); "
                         f"use dgamma {'> 0' if to > gamma0 else '< 0'}")
    ratio = (to - gamma0) / dgamma
    steps = max(1, round(ratio) if abs(ratio - round(ratio)) < 1e-6 else math.ceil(ratio))
    if steps > MAX_STEPS:
        raise ValueError(f"{steps} steps of dgamma = {dgamma:g} to reach {to:g}: more than {MAX_STEPS}; "
                         "use a larger dgamma")
    strains = gamma0 + dgamma * np.arange(steps + 1, dtype=float)
    strains[-1] = to
    return strains


def shear(packing: Packing, dgamma: float, to: float, settings: CompressionSettings | None = None, *,
          engine: str = "auto", engine_options: dict | None = None, observers=()) -> ShearPath:
    """Shear ``packing`` quasistatically at zero pressure from its strain to ``to`` in steps of
    ``dgamma`` (either sign). ``settings``: the bisection after each step (default
    ``shear_protocol()``); ``observers``: callables ``f(step: ShearStep, k: int, total: int)``
    called after every step (progress bars). The start is first brought into the window at its
    own strain (one minimisation if it already is: a packing from ``jamflow jam``).

    Parameters
    ----------
    packing : jamflow.Packing
        The start, in a periodic box (Lees-Edwards tilt = its strain gamma_0).
    dgamma : float
        The strain step (dimensionless, either sign, towards ``to``; ~1e-3 in the chapter).
    to : float
        The final strain, reached exactly (the last step may be shorter).
    settings : jamflow.CompressionSettings, optional
        The bisection to the energy window after each step (default ``shear_protocol()``).
    engine : {"auto", "numba", "lammps"}, default "auto"
        The engine.
    engine_options : dict, optional
        Options for the engine's constructor.
    observers : iterable of callable, optional
        ``f(step, k, total)`` after every step.

    Returns
    -------
    ShearPath
        One ``ShearStep`` per strain (phi_J, pressure tensor, contacts, contacts removed/added).

    Raises
    ------
    ValueError
        A bad ``dgamma`` or ``to`` (zero, away from ``to``, too many steps), a box with walls,
        or a window the settings cannot resolve.
    """
    strains = shear_strains(packing.box.shear_strain, dgamma, to)
    packing.box.with_shear_strain(strains[1])  # a box that cannot be sheared (walls) is refused here, before work
    settings = settings or shear_protocol()
    check_resolution(packing, settings)
    check_window_reachable(packing, settings, engine, denser=None)
    sigma = _contact_distance(packing)
    start = time.perf_counter()
    with open_engine(packing, settings.minimizer.method, engine, **(engine_options or {})) as sim:
        steps = [_static(sim, settings, strains[0], None, sigma)]
        for k, gamma in enumerate(strains[1:], 1):
            sim.set_box(sim.box.with_shear_strain(gamma))  # x_i -> x_i + (gamma - gamma_prev) y_i, eq. 2.4
            steps.append(_static(sim, settings, gamma, steps[-1].network, sigma))
            if k == 1:
                _warn_if_rearranged(steps, dgamma)
            for observe in observers:
                observe(steps[-1], k, len(strains) - 1)
        name, kernels = sim.name, sim.kernels
    return ShearPath(steps, float(dgamma), settings, name, time.perf_counter() - start, kernels)


def _static(sim, settings, gamma, before: Network | None, sigma) -> ShearStep:
    """Bring the engine's packing into the window at its fixed strain and read its network."""
    jammed = bisect(sim, settings)
    network = Network.of(jammed.packing)
    removed, added = ([], []) if before is None else network.changes(before, sigma)
    return ShearStep(float(gamma), jammed, network, removed, added)


def _contact_distance(packing: Packing):
    """sigma_ij of a pair, for the image-jump test (disks/spheres: the mean diameter; other
    shapes: the largest contact distance of the two particles)."""
    reach = np.asarray(packing.shape.reach(packing.diameters), float)
    return lambda i, j: reach[i] + reach[j]


def _warn_if_rearranged(steps, dgamma) -> None:
    first = steps[1]
    total = steps[0].network.n_contacts
    if len(first.removed) > REARRANGED_FRACTION * max(total, 1):
        warnings.warn(f"the first step (dgamma = {dgamma:g}) rearranged the packing: {len(first.removed)} of "
                      f"{total} contacts removed and {len(first.added)} added, so the path does not follow the "
                      f"start continuously; use a smaller dgamma (e.g. {dgamma / 10:g})", stacklevel=3)
