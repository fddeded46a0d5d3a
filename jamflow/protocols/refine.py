"""Double-double refinement of a jammed packing of disks or spheres (docs/guide/precision.md).

float64 resolves a contact force only down to its round-off floor (``pressure.pressure_floor``:
P >= 8.3e-12 for 2D bidisperse disks at N <= 300); near p ~ 1e-14 the overlaps (~1e-14
diameters) fall below one ulp of a coordinate in a box of side ~10. Here the positions and the
box sides are double-double numbers hi + lo (``jamflow.model.ddouble``; ``Packing.extended``) and
the residual forces, overlaps, energy and virial are evaluated in double-double by a compiled
kernel (``jamflow.engines.compiled.ddkernel``; the linear spring, chapter eq. 2.1 at alpha = 2).

Force balance at a fixed box: Newton steps on the contact network. A contact is a pair with
double-double overlap sigma - r > 0. Floaters (fewer than d + 1 contacts, or not spanning,
removed iteratively: ``mechanics.contacts.find_floaters``) are left out of the linear system; an
overlap they still have is relieved by moving them along their net force by F / k (k the sum of
their contacts' stiffnesses, eps / sigma^2), which closes one contact exactly, else by the
shortest move that opens their contacts (``_escape``; floaters touching or nearly touching each
other move together, ``_cluster_move``); a cluster that no move frees, its cage closed on it,
carries load and joins the network (``balance``). The rest, the backbone, is solved with its
Hessian (``mechanics.hessian.sphere_contact_hessian``, built on the contacts found in
double-double) in float64 with one particle pinned (the d translations), the right-hand side
being the double-double residual rounded to float64; each Newton step is one round of iterative
refinement, and the step is accepted when it lowers the residual or the energy (else halved;
refused after ``STEP_HALVINGS`` halvings). Newton runs on a fixed network (its pairs as
bilateral springs, so that an affine dilation that pulls a pair apart does not cut the network);
after each solve the contacts are found again, and while they differ from the network Newton
runs again on the new one. The opened and closed contacts relative to the start are reported.
A network that comes back in that loop is a rearrangement: one float64 FIRE minimisation at the same
box finds the new network (where float64 resolves the pressure), and Newton resumes from it.
Converged: the largest net force on a backbone particle below ``force_tol`` times the mean
contact force, with no floater in contact.

Pressure walk: the box and all positions are scaled by 1 + mu (in double-double) and the state
balanced again; mu is chosen by the secant on p(L) (linear in L for the spring near onset),
one decade of pressure at a time from the start pressure down (or up) to the target. A step that
would make the box narrower than twice the largest contact distance (no unique minimum image) is
halved; a target above what the particles carry in that densest box (``pressure.pressure_ceiling``)
is refused before any work.

Resolution (``dd_pressure_floor``): float64 refuses targets below ``pressure.pressure_floor``,
FLOOR_MARGIN = 1000 times the force round-off floor f_64 (the minimiser's base force tolerance,
1e-14 max(1, L/20) eps/diameter for disks) over a^(d-1): there force balance is resolved to
1/FLOOR_MARGIN = 1e-3 of a contact force. In double-double the round-off of a position, hence of
an overlap and a force, is eps_dd / eps_64 = 2^-104 / 2^-52 = 2^-52 times smaller, f_dd = 2^-52 f_64,
and the refinement asks for a balance of ``force_tol`` (1e-12) of the mean contact force, so the
margin is 1 / force_tol: P >= f_dd / (force_tol a^(d-1)), 1.9e-18 for 2D bidisperse disks up to
N ~ 300 at the default tolerance (measured: ``jamflow refine`` of an N = 64 onset converges at
1e-18 with max|F|/<f> = 1.3e-13 and fails at 1e-20). A target below it is refused before any work.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse.linalg as spla
from scipy.optimize import nnls

from jamflow.engines.choose import open_engine
from jamflow.engines.compiled.ddkernel import spring_dd
from jamflow.mechanics.checks import PackingChecks
from jamflow.mechanics.contacts import find_floaters
from jamflow.mechanics.elastic import ContactModuli, contact_moduli
from jamflow.mechanics.hessian import sphere_contact_hessian
from jamflow.minimize.rules import minimize
from jamflow.minimize.settings import MinimizerSettings
from jamflow.model import ddouble as dd
from jamflow.model.box import Box
from jamflow.model.packing import Packing, fits_cell
from jamflow.model.pairs import candidate_pairs
from jamflow.protocols.outcome import JammingFailed
from jamflow.protocols.pressure import _check_pressure, check_pressure_ceiling, pressure_floor, pressure_sequence
from jamflow.support import hooks
from jamflow.support.settings_errors import SettingError

PAIR_SKIN = 0.05  # candidate pairs within the largest diameter + this (diameters)
STEP_HALVINGS = 12
WEDGE_SWEEPS = 20  # F / k relief sweeps before a wedged floater escapes along its contact normals
WEDGE_GAP = 1e-8  # neighbours this near (diameters) bound the escape of a wedged floater
ENERGY_EXPONENT = 2.0  # V ~ p^(alpha / (alpha - 1)) at a fixed network: alpha = 2, the linear spring
VTOL_SPREAD = 2.0  # V / ((d / 2) eps delta^2), bounded from above (measured 1.3-1.5: dd_vtol_floor)
MAX_JOINT_FLOATERS = 64  # larger floater clusters are not moved together (a least-distance problem of d x
# their number unknowns; every particle of N = 1024 past its onset: 20 s) but handed to the float64 FIRE
RELAX_V_MIN = 1e-300  # the float64 FIRE relaxes to force balance: the chapter's V < V_min stop (1e-16 per
# particle) would end it at once below p ~ 1e-8, where V ~ p^2 is smaller, and return the state unrelaxed
MAX_VTOL_REFINES = 6  # refinements (secant steps in log p, log V) to land V in (V_tol, 2 V_tol)


@dataclass(frozen=True)
class RefineSettings:
    """Target pressure (eps / diameter^d) and the tolerances of the refinement."""

    pressure: float  #: target pressure, eps / diameter^d
    force_tol: float = 1e-12  #: largest net force on a non-floater over the mean contact force, at balance
    pressure_tol: float = 1e-4  #: relative pressure error |p / target - 1| accepted at the target
    max_newton: int = 60  #: Newton steps per balanced state
    max_secant: int = 30  #: box rescalings per decade of pressure
    max_network_updates: int = 10  #: Newton solves with a new contact network per balanced state
    #: V_tol of the energy window V_tol < V < 2 V_tol (per particle, eps) this pressure was chosen for; None: none
    v_tol: float | None = None

    def __post_init__(self):
        _check_pressure(self.pressure)
        for name in ("force_tol", "pressure_tol"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and 0 < value < 1):
                raise SettingError(name, f"must be a number in (0, 1), got {value!r}")

    def as_dict(self) -> dict:
        """The settings as the packing file's protocol attributes."""
        window = {} if self.v_tol is None else {"v_tol": self.v_tol}
        return {"precision": "double-double", "target_pressure": self.pressure, "force_tol": self.force_tol,
                "pressure_tol": self.pressure_tol, **window}


def dd_force_floor(packing: Packing) -> float:
    """Round-off floor of a double-double force: the float64 floor (the minimiser's base force
    tolerance) times eps_dd / eps_64 = 2^-52, eps / diameter."""
    return MinimizerSettings().force_tol_for(packing) * dd.EPS_DD / dd.EPS_DOUBLE


def dd_pressure_floor(packing: Packing, force_tol: float = 1e-12) -> float:
    """Lowest target pressure double-double resolves for this packing to a force balance of
    ``force_tol`` of the mean contact force (module docstring)."""
    return dd_force_floor(packing) / (force_tol * float(np.mean(packing.diameters)) ** (packing.dim - 1))


def check_refine(packing: Packing, settings: RefineSettings) -> None:
    """Refuse, before any work, what the refinement cannot do."""
    _check_scene(packing)
    floor = dd_pressure_floor(packing, settings.force_tol)
    if settings.pressure < floor:
        raise ValueError(f"target pressure {settings.pressure:g} is below what double-double resolves at N = "
                         f"{packing.n} (box side {packing.box.lengths.max():.3g}): contact forces ~ P a^(d-1) must "
                         f"stay 1/force_tol = {1 / settings.force_tol:.0e} times above the double-double force "
                         f"round-off {dd_force_floor(packing):.1e}, so P >= {floor:.1e}; choose a larger target pressure")
    if settings.v_tol is None:
        check_pressure_ceiling(packing, settings.pressure)
    else:
        check_pressure_ceiling(packing, settings.pressure, "--vtol", f"the pressure for --vtol {settings.v_tol:g},")


def dd_vtol_floor(packing: Packing, force_tol: float = 1e-12) -> float:
    """Smallest V_tol (per particle) double-double resolves: the energy at ``dd_pressure_floor``. At
    a fixed network of linear springs a contact's overlap delta ~ P (area per particle) / eps, so
    V ~ VTOL_SPREAD (d / 2) eps delta^2 (z = 2d contacts, eps delta^2 / 2 each); measured on 2D
    float64 onsets, N = 64 and 256: V / ((d / 2) eps delta^2) = 1.3-1.5 with the area per particle of
    ``packing`` (a start below phi_J, whose larger area makes the floor conservative)."""
    eps = packing.potential.epsilon
    delta = dd_pressure_floor(packing, force_tol) * packing.box.volume / packing.n / eps
    return VTOL_SPREAD * 0.5 * packing.dim * eps * delta**packing.potential.alpha  # V ~ delta^alpha


def check_vtol(packing: Packing, v_tol: float, force_tol: float = 1e-12) -> None:
    """Refuse, before any work, a V_tol the refinement cannot reach (``dd_vtol_floor``)."""
    _check_scene(packing)
    if not (math.isfinite(v_tol) and v_tol > 0):
        raise ValueError(f"--vtol must be a finite positive number, got {v_tol}")
    floor = dd_vtol_floor(packing, force_tol)
    if v_tol < floor:
        raise ValueError(f"vtol {v_tol:g} is below what double-double resolves at N = {packing.n}: its pressure would "
                         f"be below the double-double floor P >= {dd_pressure_floor(packing, force_tol):.1e} "
                         f"(jamflow.protocols.refine.dd_pressure_floor); use --vtol >= {floor:.1e}")


def _check_scene(packing: Packing) -> None:
    """Refuse particles, potentials and boxes the refinement is not written for."""
    if not packing.shape.double_double:
        raise ValueError(f"double-double refinement is written for disks and spheres, not "
                         f"{packing.shape.name(packing.dim)} particles")
    pot = packing.potential
    if pot.name != "spring" or getattr(pot, "alpha", None) != 2.0:
        raise ValueError(f"double-double refinement is written for the linear spring (spring), not {pot.spec!r}")
    if packing.box.walls or packing.box.is_triclinic or packing.fixed is not None or packing.gravity > 0:
        raise ValueError("double-double refinement needs an orthogonal periodic box without walls, gravity or fixed "
                         "particles")


class _State:
    """Positions xh + xl (N, d) and box sides lh + ll (d,) in double-double."""

    def __init__(self, xh, xl, lh, ll):
        self.xh, self.xl, self.lh, self.ll = xh, xl, lh, ll

    @classmethod
    def of(cls, packing: Packing) -> _State:
        if packing.extended is None:
            return cls(packing.box.wrap(packing.positions), np.zeros_like(packing.positions), packing.box.lengths,
                       np.zeros(packing.dim))
        return cls(packing.positions.copy(), packing.positions_lo.copy(), packing.box.lengths, packing.lengths_lo.copy())

    def moved(self, dx) -> _State:
        return _State(*dd.dd_add(self.xh, self.xl, dx, 0.0 * dx), self.lh, self.ll)

    def scaled(self, mu: float) -> _State:
        """Box and positions times 1 + mu (affine), in double-double."""
        xs = dd.dd_add(self.xh, self.xl, *dd.dd_mul_d(self.xh, self.xl, mu))
        ls = dd.dd_add(self.lh, self.ll, *dd.dd_mul_d(self.lh, self.ll, mu))
        return _State(*xs, *ls)

    def volume(self):
        vh, vl = self.lh[0], self.ll[0]
        for a in range(1, len(self.lh)):
            vh, vl = dd.dd_mul(vh, vl, self.lh[a], self.ll[a])
        return vh, vl

    def wrapped(self) -> _State:
        """Every coordinate folded into [0, L) in double-double."""
        xh, xl = self.xh.copy(), self.xl.copy()
        for a in range(xh.shape[1]):
            k = np.floor(xh[:, a] / self.lh[a])
            sh, sl = dd.dd_mul_d(self.lh[a], self.ll[a], k)
            xh[:, a], xl[:, a] = dd.dd_sub(xh[:, a], xl[:, a], sh, sl)
        return _State(xh, xl, self.lh, self.ll)

    def float64(self, template: Packing) -> Packing:
        """The high parts as a float64 packing of ``template``'s particles and potential."""
        return Packing(self.xh, template.diameters, Box(np.diag(self.lh)), template.potential)

    def packing(self, template: Packing) -> Packing:
        box = Box(np.diag(self.lh), template.box.periodic)
        return replace(template, positions=self.xh, box=box, extended=None).with_low_parts(self.xl, self.ll)


@dataclass(frozen=True)
class Network:
    """The double-double evaluation of a state and its contact network."""

    i: np.ndarray  #: (C,) contacts (overlap > 0 in double-double)
    j: np.ndarray  #: (C,) their partners, i < j
    overlap: np.ndarray  #: (C,) sigma - r (float64 value of the double-double overlap)
    floater: np.ndarray  #: (N,) bool
    forces: np.ndarray  #: (N, d) net forces, hi + lo rounded to float64
    energy: tuple  #: (hi, lo)
    pressure: float  #: P, eps / diameter^d
    pressure_tensor: np.ndarray  #: (d, d)

    @property
    def backbone(self) -> np.ndarray:
        """(C,) bool: contacts between two non-floaters."""
        return ~self.floater[self.i] & ~self.floater[self.j]

    @property
    def n_contacts(self) -> int:
        """N_c, the backbone contacts."""
        return int(self.backbone.sum())

    def contact_forces(self, diameters, epsilon) -> np.ndarray:
        """|f| of the backbone contacts: eps (sigma - r) / sigma^2."""
        sigma = 0.5 * (diameters[self.i] + diameters[self.j])
        return (epsilon * self.overlap / sigma**2)[self.backbone]

    def residual(self, diameters, epsilon) -> float:
        """Largest net force on a backbone particle over the mean contact force (inf without contacts)."""
        fc = self.contact_forces(diameters, epsilon)
        if not len(fc):
            return math.inf
        live = ~self.floater
        return float(np.linalg.norm(self.forces[live], axis=1).max() / np.abs(fc).mean())  # bilateral: tensions too

    @property
    def floater_overlaps(self) -> bool:
        """True when a floater overlaps a particle (a contact outside the backbone)."""
        return bool(len(self.i) and (~self.backbone).any())


def evaluate(packing: Packing, st: _State, network: tuple | None = None) -> Network:
    """Overlaps, forces, energy and pressure of ``st`` in double-double; its contacts and floaters.
    ``network`` (i, j, floater): evaluate that fixed contact network as bilateral springs instead."""
    hi = st.float64(packing)
    if network is None:
        i, j = candidate_pairs(hi, float(packing.diameters.max()) + PAIR_SKIN)
    else:
        i, j, floater = network
    out = spring_dd(st.xh, st.xl, st.lh, st.ll, packing.diameters, i, j, packing.potential.epsilon,
                    bilateral=network is not None)
    oh, ol = out.overlap
    touch = (oh > 0) | ((oh == 0) & (ol > 0)) if network is None else np.ones(len(i), bool)
    ci, cj = i[touch], j[touch]
    if network is None:
        dr = hi.box.minimum_image(st.xh[ci] - st.xh[cj])
        floater = find_floaters(packing.n, ci, cj, dr / np.linalg.norm(dr, axis=1)[:, None], packing.dim + 1)
    vh, vl = st.volume()
    d = packing.dim
    tensor = np.array([[dd.dd_div(out.virial[0][a, b], out.virial[1][a, b], vh, vl)[0] for b in range(d)]
                       for a in range(d)])
    th, tl = 0.0, 0.0
    for a in range(d):
        th, tl = dd.dd_add(th, tl, out.virial[0][a, a], out.virial[1][a, a])
    p = dd.dd_div(th, tl, *dd.dd_mul_d(vh, vl, float(d)))[0]
    return Network(ci, cj, (oh + ol)[touch], floater, out.forces[0] + out.forces[1], out.energy, p, tensor)


def _relieve_floaters(packing: Packing, st: _State, net: Network, sweeps: int = 200):
    """Move floaters in contact along their net force by F / k until none touches. A floater wedged
    between nearly opposite contacts (its net force ~0 however deep the overlaps: a rattler left
    touching at the float64 round-off, e.g. overlaps ~1e-14 with two neighbours) does not get out
    that way, nor one moved off one side of the wedge into the other; after ``WEDGE_SWEEPS`` sweeps it
    moves instead along u, the sum of the normals of its contacts and near neighbours, far enough
    that every overlap closes to first order, or together with the floaters it touches or nearly
    touches (``_escape``; ``_Caged`` if no move frees them)."""
    eps = packing.potential.epsilon
    for sweep in range(sweeps):
        if not net.floater_overlaps:
            return st, net
        off = ~net.backbone
        i, j = net.i[off], net.j[off]
        k = np.zeros(packing.n)
        stiff = eps / (0.5 * (packing.diameters[i] + packing.diameters[j])) ** 2
        np.add.at(k, i, stiff)
        np.add.at(k, j, stiff)
        move = net.floater & (k > 0)
        dx = np.zeros_like(st.xh)
        if sweep < WEDGE_SWEEPS:
            dx[move] = net.forces[move] / k[move, None] * (1.0 + 1e-9)  # a hair beyond contact
        else:
            dx = _escape(packing, st, i, j, net.overlap[off], net.floater)
        st = st.moved(dx)
        net = evaluate(packing, st)
    raise RuntimeError(f"floaters still overlap after {sweeps} relief sweeps")


class _Caged(RuntimeError):
    """A floater cluster in contact that no move frees: its cage has closed on it, so it carries load."""


def _escape(packing: Packing, st: _State, i, j, overlap, floater) -> np.ndarray:
    """Per cluster of floaters in contact (floaters linked by contacts or near gaps, below
    ``WEDGE_GAP`` diameters), a move opening its contacts. A single floater moves by t u, u the
    normalised sum of the unit normals n_c (from each neighbour to the floater) of its contacts and
    of its near neighbours (the other side of the wedge, which a move off one contact alone runs
    into), t = max_c overlap_c / (u . n_c) (1 + 1e-6) over its contacts. Where some u . n_c <= 0 (a
    3D floater held by three contacts around it), the least-norm dx with n_c . dx = overlap_c
    (1 + 1e-6) on the contacts and >= 0 on the near gaps, if it exists. Else, and for a cluster of
    floaters touching or nearly touching each other (one caged by the others: 2D N = 1024 seed 1,
    floaters 176 and 458), the shortest joint move that opens every contact of the cluster and
    closes no near gap by more than half, else 99 % (``_least_distance``). Raises ``_Caged`` where no such move
    exists (the cage has closed on the cluster)."""
    box = Box(np.diag(st.lh))
    dx = np.zeros_like(st.xh)
    depth = {}
    for c in range(len(i)):
        depth[(int(i[c]), int(j[c]))] = depth[(int(j[c]), int(i[c]))] = float(overlap[c])
    seen = set()
    for a0 in np.unique(np.concatenate([i[floater[i]], j[floater[j]]])).tolist():
        if a0 in seen:
            continue
        cluster, stack, near = [], [a0], {}
        seen.add(a0)
        while stack:  # the floaters linked to a0 by contacts or near gaps
            a = stack.pop()
            cluster.append(a)
            near[a] = _near(packing, box, st.xh, a)
            for b in near[a][0].tolist():
                if floater[b] and b not in seen:
                    seen.add(b)
                    stack.append(b)
        move = _single_escape(near[a0], depth, a0) if len(cluster) == 1 else None
        if move is None:
            move = _cluster_move(packing, box, st.xh, cluster, depth)
        dx[cluster] = move
    return dx


def _near(packing: Packing, box: Box, x: np.ndarray, a: int, reach: float = WEDGE_GAP) -> tuple:
    """The neighbours of ``a`` with a gap below ``reach`` (float64, diameters): (indices, unit
    normals from each to ``a``, gaps)."""
    dr = box.minimum_image(x[a] - x)
    r = np.linalg.norm(dr, axis=1)
    r[a] = np.inf
    gap = r - 0.5 * (packing.diameters[a] + packing.diameters)
    near = np.flatnonzero(gap < reach)
    return near, dr[near] / r[near, None], gap[near]


def _single_escape(near: tuple, depth: dict, a: int) -> np.ndarray | None:
    """A lone floater's move along its summed normals, or the least-norm move opening its contacts
    (``_escape``); None if neither does."""
    others, normals, gap = near
    contact = np.array([(a, b) in depth for b in others.tolist()])
    u = normals.sum(axis=0)
    if np.linalg.norm(u) == 0.0:
        return None
    u /= np.linalg.norm(u)
    over = np.array([depth[(a, b)] for b in others[contact].tolist()])
    ends = normals[contact] @ u
    if (normals @ u).min() > 0 and ends.min() > 0:
        return u * float(np.max(over / ends)) * (1.0 + 1e-6)
    # no common direction (e.g. three contacts of a 3D floater around it): the least-norm move
    # that opens each contact and near gap to first order, n_c . dx = max(-gap_c, 0)
    target = np.maximum(-gap, 0.0)
    target[contact] = over
    move = np.linalg.lstsq(normals, target * (1.0 + 1e-6), rcond=None)[0]
    if np.all(normals @ move >= target - 1e-9 * target.max()):
        return move
    return None


def _cluster_move(packing: Packing, box: Box, x: np.ndarray, cluster: list, depth: dict) -> np.ndarray:
    """The shortest joint move (len(cluster), d) of a floater cluster, the rest fixed, that opens
    each contact by 1 + 1e-6 of its (dd) overlap and closes each other gap by at most half, else
    by at most 99 % (a tight cage); ``_Caged`` if neither exists (``_joint_move``), or if the cluster
    has more than ``MAX_JOINT_FLOATERS`` floaters."""
    if len(cluster) > MAX_JOINT_FLOATERS:
        raise _Caged(f"{len(cluster)} floaters in contact form one cluster, too many to move together (more than "
                     f"{MAX_JOINT_FLOATERS}): the state is far from balance or below its onset")
    for share in (0.5, 0.99):
        move = _joint_move(packing, box, x, cluster, depth, share)
        if move is not None:
            return move
    raise _Caged(f"floaters {sorted(cluster)} are caged: no move opens their contacts (the cage has closed on them)")


def _joint_move(packing: Packing, box: Box, x: np.ndarray, cluster: list, depth: dict, share: float):
    """``_cluster_move`` closing gaps below ``reach`` by at most ``share`` of themselves; a pair inside
    the cluster is one constraint on the difference of its two moves. ``reach`` starts at
    ``WEDGE_GAP`` and grows to twice the largest possible closing (2 max|move| per particle) until
    no gap beyond it can close. None if no move exists, or if ``reach`` would be a diameter or more
    (moves of 1/4 to 1/2 diameter)."""
    d = packing.dim
    where = {a: k for k, a in enumerate(cluster)}
    reach = WEDGE_GAP
    while reach < 1.0:
        rows, lower = [], []
        for a in cluster:
            for b, n, g in zip(*_near(packing, box, x, a, reach)):
                b = int(b)
                if b in where and b < a:
                    continue  # a pair inside the cluster, written once
                row = np.zeros(len(cluster) * d)
                row[where[a] * d:(where[a] + 1) * d] = n
                if b in where:
                    row[where[b] * d:(where[b] + 1) * d] = -n
                rows.append(row)
                lower.append(depth[(a, b)] * (1.0 + 1e-6) if (a, b) in depth else -share * max(g, 0.0))
        move = _least_distance(np.array(rows), np.array(lower))
        if move is None:
            return None
        move = move.reshape(len(cluster), d)
        largest = 2.0 * float(np.linalg.norm(move, axis=1).max())  # the most a gap can close
        if largest < reach:
            return move
        reach = 2.0 * largest
    return None


def _least_distance(g: np.ndarray, h: np.ndarray) -> np.ndarray | None:
    """The shortest x with g @ x >= h, None if there is none: least-distance programming by
    non-negative least squares (Lawson & Hanson, Solving Least Squares Problems (1974), ch. 23):
    u >= 0 minimising |E u - f|, E = [g^T; h^T], f = (0, ..., 0, 1); with r = E u - f, x = -r[:-1] /
    r[-1], and r = 0 means the constraints are incompatible. h is scaled to 1 for the solve."""
    scale = float(np.abs(h).max())
    if scale == 0.0:
        return np.zeros(g.shape[1])
    e = np.vstack([g.T, h[None, :] / scale])
    f = np.zeros(g.shape[1] + 1)
    f[-1] = 1.0
    u = nnls(e, f)[0]
    r = e @ u - f
    if abs(r[-1]) < 1e-12:
        return None
    x = -r[:-1] / r[-1] * scale
    return x if np.all(g @ x >= h - 1e-9 * scale) else None


def _newton_step(packing: Packing, st: _State, net: Network) -> np.ndarray:
    """Displacement solving H dx = F on the backbone (one particle pinned), with one refinement."""
    b = net.backbone
    i, j = net.i[b], net.j[b]
    box = Box(np.diag(st.lh))
    dr = box.minimum_image(st.xh[i] - st.xh[j])
    r = np.linalg.norm(dr, axis=1)
    sigma = 0.5 * (packing.diameters[i] + packing.diameters[j])
    s = 1.0 - net.overlap[b] / sigma
    h = sphere_contact_hessian(packing, i, j, dr, r, sigma, s).tocsc()
    d = packing.dim
    live = np.flatnonzero(~net.floater)
    rows = (live[1:, None] * d + np.arange(d)).ravel()  # live[0] pinned: the d translations
    rhs = net.forces.ravel()[rows]
    reduced = h[rows][:, rows].tocsc()
    try:
        lu = spla.splu(reduced)
    except RuntimeError as err:  # singular: the network lost its rigidity
        raise RuntimeError(f"the contact network ({len(i)} contacts) is not rigid: {err}") from None
    x = lu.solve(rhs)
    x += lu.solve(rhs - reduced @ x)
    dx = np.zeros(packing.n * d)
    dx[rows] = x
    return dx.reshape(packing.n, d)


class _Unbalanced(RuntimeError):
    """Newton on a fixed network does not reach force balance: the state is far from that network's
    equilibrium (e.g. a float64 start whose minimiser stopped at its iteration cap while the network
    rearranged), or the network's Hessian is too soft there (stress-softened modes of particles with
    d + 1 contacts in 3D)."""


def _newton(packing: Packing, st: _State, network: tuple, settings: RefineSettings):
    """Newton steps on a fixed contact network (bilateral springs) to ``settings.force_tol``;
    (state, steps)."""
    dia, eps = packing.diameters, packing.potential.epsilon
    if not len(network[0]):
        raise RuntimeError("no contacts between non-floaters: the state is below its onset (refine a jammed packing)")
    net = evaluate(packing, st, network)
    for step in range(settings.max_newton + 1):
        res = net.residual(dia, eps)
        if res <= settings.force_tol:
            return st, step
        if step == settings.max_newton or not math.isfinite(res):
            break
        dx = _newton_step(packing, st, net)
        for _ in range(STEP_HALVINGS):
            trial = st.moved(dx)
            new = evaluate(packing, trial, network)
            if new.residual(dia, eps) < res or dd.dd_sub(*new.energy, *net.energy)[0] < 0:
                break
            dx = 0.5 * dx
        else:  # no step lowers either: stuck (accepting the last, smallest one would go uphill)
            raise _Unbalanced(f"no Newton step of {STEP_HALVINGS} halvings lowers the largest net force ({res:.1e} of "
                               f"the mean contact force) or the energy")
        st, net = trial, new
    raise _Unbalanced(f"double-double force balance not reached in {settings.max_newton} Newton steps (largest "
                       f"net force {net.residual(dia, eps):.1e} of the mean contact force, {net.n_contacts} contacts)")


def _network(net: Network) -> tuple:
    b = net.backbone
    return net.i[b], net.j[b], net.floater


def balance(packing: Packing, st: _State, settings: RefineSettings, network: tuple | None = None):
    """Force balance at a fixed box: Newton on the contact network ``network`` (i, j, floater; by
    default the contacts of ``st``), then the contacts found again in double-double; while they
    differ (a contact opened or closed, a floater touches) Newton again on the new network. A
    network that comes back (a contact in tension without which another overlaps: a rearrangement
    that no network solve finds) or half of ``max_network_updates`` networks in a row (3D N = 512
    seed 15 at p = 3.2e-8 kept changing over 10), a floater cluster whose cage has closed on it (``_Caged``: it
    carries load, so it joins the network), or a Newton solve that does not balance (``_Unbalanced``:
    3D N = 128 seed 20 at p = 3.2e-5, from a float64 enthalpy minimum stopped at its iteration cap
    with max|F|/<f> = 1.5e-3) falls back once on FIRE in float64 at the same box
    (``_float64_relax``), where float64 resolves the state. (state, network evaluated
    unilaterally, Newton steps)."""
    relaxed = False

    def fall_back(st, pressure, why):
        """The one float64 FIRE of this balance, then the floaters relieved."""
        nonlocal relaxed
        relaxed = True
        st = _float64_relax(packing, st, pressure, why)
        return _relieve_floaters(packing, st, evaluate(packing, st))

    def relieve(st):
        net = evaluate(packing, st)
        try:
            return _relieve_floaters(packing, st, net)
        except _Caged as caged:
            if relaxed:
                raise
            return fall_back(st, net.pressure, str(caged))

    if network is None:
        st, net = relieve(st)
        network = _network(net)
    total, seen = 0, set()
    for update in range(settings.max_network_updates):
        try:
            st, steps = _newton(packing, st, network, settings)
        except _Unbalanced as stuck:
            if relaxed:
                raise
            st, net = fall_back(st, evaluate(packing, st).pressure, str(stuck))
            network = _network(net)
            continue
        total += steps
        st, net = relieve(st)
        key = frozenset(zip(network[0].tolist(), network[1].tolist()))
        if _pairs(net) == key and np.array_equal(net.floater, network[2]):
            return st, net, total
        wandering = update + 1 == settings.max_network_updates // 2 and net.pressure >= _float64_floor(packing, st)
        if (key in seen or wandering) and not relaxed:
            st, net = fall_back(st, net.pressure, "the contact network rearranges")
        seen.add(key)
        network = _network(net)
    raise RuntimeError(f"the contact network kept changing over {settings.max_network_updates} Newton solves")


def _float64_floor(packing: Packing, st: _State) -> float:
    """The lowest pressure float64 resolves at the box of ``st`` (``pressure.pressure_floor``)."""
    return pressure_floor(st.float64(packing), MinimizerSettings())


def relax_at_box(packing: Packing) -> Packing:
    """``packing`` relaxed by FIRE in float64 (the compiled engine) at its fixed box, to force
    balance: no V < V_min stop (``RELAX_V_MIN``)."""
    with open_engine(packing, "fire", "numba") as sim:
        minimize(sim, MinimizerSettings(v_min=RELAX_V_MIN))
        return sim.packing()


def _float64_relax(packing: Packing, st: _State, pressure: float, why: str) -> _State:
    """``relax_at_box`` of the high parts: the contact changes of a rearrangement or of a closed
    cage (``why``), found where float64 resolves the forces (``pressure_floor``)."""
    start = st.float64(packing)
    floor = pressure_floor(start, MinimizerSettings())
    if pressure < floor:
        raise RuntimeError(f"{why} at p = {pressure:.2e}, below what float64 resolves ({floor:.1e}), and there is no "
                           f"double-double minimiser for that yet")
    x = start.box.wrap(relax_at_box(start).positions)
    return _State(x, np.zeros_like(x), st.lh, st.ll)


def _length_change(st: _State, ref: _State) -> float:
    """u = (L - L_ref) / L_ref along x, from the double-double difference."""
    return dd.dd_sub(st.lh[0], st.ll[0], ref.lh[0], ref.ll[0])[0] / ref.lh[0]


def _affine_slope(packing: Packing, st: _State, net: Network) -> float:
    """dp/du of an affine dilation by 1 + u at fixed network (u > 0 lowers p): -sum r^2 k / (d V)."""
    b = net.backbone
    sigma = 0.5 * (packing.diameters[net.i[b]] + packing.diameters[net.j[b]])
    r = sigma - net.overlap[b]
    return -float(np.sum(packing.potential.epsilon * r**2 / sigma**2) / (packing.dim * st.volume()[0]))


@dataclass(frozen=True)
class RefineResult:
    """A packing balanced in double-double at the target pressure, and how it got there."""

    packing: Packing  #: the refined packing, with ``extended`` (positions_lo, box_lo): the double-double low parts
    network: Network  #: the double-double contact network: overlaps, forces, floaters, energy, pressure
    settings: RefineSettings  #: the target pressure and tolerances
    history: dict  #: per balanced state: target_pressure, pressure, phi + phi_lo, contacts, floaters, newton_steps
    start_contacts: set  #: backbone contacts (i, j) of the start, for ``contact_changes``
    seconds: float  #: wall-clock time of the refinement, s
    onset: object = None  #: the float64 ``JamResult`` refined (``jamflow jam --precision double-double``), if any
    refines: int = 1  #: refinements made (``refine_to_vtol``: secant steps to the energy window)

    def __repr__(self) -> str:
        """One line: N, dim, target and reached pressure, phi, contacts against the isostatic count,
        floaters, force balance, V, refinements, time; ``summary()`` is the CLI's lines."""
        p = self.packing
        return (f"RefineResult(N={p.n}, dim={p.dim}, P_target={self.settings.pressure:.3e}, P={self.pressure:.6e}, "
                f"phi={self.phi[0]:.12f}, N_c={self.n_contacts}, isostatic={self.isostatic_contacts}, "
                f"floaters={self.n_floaters}, force_balance={self.force_balance:.1e}, "
                f"V={self.energy_per_particle:.3e}, refines={self.refines}, seconds={self.seconds:.2f})")

    @property
    def pressure(self) -> float:
        """P = tr P_ab / d from the double-double forces, eps / diameter^d."""
        return self.network.pressure

    @property
    def pressure_tensor(self) -> np.ndarray:
        """(d, d) virial pressure tensor (chapter eq. 2.34) from the double-double forces, eps / diameter^d."""
        return self.network.pressure_tensor

    @property
    def n_contacts(self) -> int:
        """Contacts between non-floaters, counted with double-double overlaps > 0."""
        return self.network.n_contacts

    @property
    def phi(self) -> tuple[float, float]:
        """(hi, lo): the packing fraction from the double-double box, phi = hi + lo (``packing.phi``
        is the float64 value from the high parts of the box sides)."""
        return float(self.history["phi"][-1]), float(self.history["phi_lo"][-1])

    def moduli(self) -> ContactModuli:
        """G and B by the Hessian route (``mechanics.elastic.contact_moduli``) on the double-double
        contact network: the stiffness term from the contact geometry (float64 directions), the
        stress term from the double-double overlaps. Where the overlaps are below an ulp of a
        coordinate (p ~ 1e-14) float64 positions can lose or gain a contact, and
        ``HessianModuli`` of ``packing`` (which reads float64 positions) is then wrong."""
        net, p = self.network, self.packing
        b = net.backbone
        i, j = net.i[b], net.j[b]
        dr = p.box.minimum_image(p.positions[i] - p.positions[j])
        sigma = 0.5 * (p.diameters[i] + p.diameters[j])
        return contact_moduli(p, i, j, dr, sigma, net.overlap[b], ~net.floater)

    @property
    def n_floaters(self) -> int:
        """Particles removed as floaters."""
        return int(self.network.floater.sum())

    @property
    def isostatic_contacts(self) -> int:
        """N' d - d + 1: the contacts of an isostatic periodic packing of N' non-floaters."""
        d = self.packing.dim
        return (self.packing.n - self.n_floaters) * d - d + 1

    @property
    def force_balance(self) -> float:
        """Largest net force on a non-floater over the mean contact force (double-double forces)."""
        return self.network.residual(self.packing.diameters, self.packing.potential.epsilon)

    @property
    def energy_per_particle(self) -> float:
        """V = U / N from the double-double overlaps, eps."""
        return float(self.network.energy[0] / self.packing.n)

    @property
    def in_window(self) -> bool | None:
        """V_tol < V < 2 V_tol for the double-double energy per particle (None without ``settings.v_tol``)."""
        v_tol = self.settings.v_tol
        return None if v_tol is None else bool(v_tol < self.energy_per_particle < 2.0 * v_tol)

    def checks(self) -> PackingChecks:
        """The packing checks, from the double-double forces and contacts (the energy window of
        ``settings.v_tol`` if the pressure was chosen for one, else none). Force balance here is the refinement's own criterion,
        ``settings.force_tol``, far below the float64 checks' ``BALANCE_RTOL``."""
        net, p = self.network, self.packing
        fc = net.contact_forces(p.diameters, p.potential.epsilon)
        live = ~net.floater
        fmax = float(np.linalg.norm(net.forces[live], axis=1).max()) if live.any() else 0.0
        kept, ratio = int(live.sum()), self.force_balance
        return PackingChecks(
            energy_per_particle=self.energy_per_particle, v_tol=self.settings.v_tol, in_window=self.in_window,
            max_force=fmax,
            force_tol=self.settings.force_tol * float(fc.mean()) if len(fc) else None,
            mean_contact_force=float(fc.mean()) if len(fc) else math.nan, force_ratio=ratio,
            force_balanced=bool(ratio <= self.settings.force_tol), n_contacts=self.n_contacts,
            isostatic_count=self.isostatic_contacts, excess_contacts=self.n_contacts - self.isostatic_contacts,
            n_floaters=self.n_floaters, n_kept=kept, mean_z=2.0 * self.n_contacts / kept if kept else math.nan,
            jammed=bool(kept and self.n_contacts >= self.isostatic_contacts))

    def save(self, path, force: bool = False):
        """Write the refined packing (positions_lo, precision = "double-double") with its checks;
        a packing that fails them is not written (``jamflow.io.packing_file.save_refined``)."""
        return hooks.call("save_refined", self, path, force=force)

    def contact_changes(self) -> tuple[set, set]:
        """(opened, closed): backbone contacts (i, j) of the start no longer present, and new ones."""
        now = _pairs(self.network)
        return self.start_contacts - now, now - self.start_contacts

    def summary(self) -> str:
        """The lines ``jamflow jam --precision double-double`` prints: onset, pressure, phi, contacts, force balance,
        time."""
        opened, closed = self.contact_changes()
        target = self.settings.pressure
        onset = "" if self.onset is None else f"float64 onset {self.onset.summary()}\n"
        window = "" if self.settings.v_tol is None else (
            f"\ndouble-double: V = {self.energy_per_particle:.4e} = {self.energy_per_particle / self.settings.v_tol:.3f} "
            f"V_tol (V_tol = {self.settings.v_tol:g}), {self.refines} refinement(s)")
        return onset + (f"double-double: P_target = {target:.3e}  P = {self.pressure:.6e} (rel. {self.pressure / target - 1:+.1e})  "
                f"phi = {self.phi[0]:.15f}  N_c = {self.n_contacts} (isostatic {self.isostatic_contacts}, "
                f"{self.n_floaters} floaters; {len(opened)} opened, {len(closed)} closed)  max|F|/<f> = "
                f"{self.force_balance:.1e}  {len(self.history['pressure'])} states, "
                f"{int(np.sum(self.history['newton_steps']))} Newton steps (double-double), {self.seconds:.2f} s") + window


def _pairs(net: Network) -> set:
    b = net.backbone
    return set(zip(net.i[b].tolist(), net.j[b].tolist()))


def refine(packing: Packing, pressure: float, *, settings: RefineSettings | None = None, observers=(),
           onset=None) -> RefineResult:
    """Balance ``packing`` (disks/spheres, linear spring, periodic orthogonal box; its ``extended``
    low parts if it has them) in double-double and walk it to the target ``pressure``
    (eps / diameter^d) by affine dilation and Newton correction (module docstring).
    ``observers``: callables given {"target", "pressure", "contacts"} after each balanced state;
    ``onset``: the float64 result ``packing`` came from, kept for the record. Raises
    ``JammingFailed`` where the refinement does not converge.

    Parameters
    ----------
    packing : jamflow.Packing
        A jammed packing of disks or spheres with the linear spring, in an orthogonal periodic
        box without walls, gravity or fixed particles (lengths in diameters).
    pressure : float
        The target pressure, eps / diameter^d (> 0, above what double-double resolves at this N).
    settings : RefineSettings, optional
        Tolerances and step limits; default ``RefineSettings(pressure)``; its ``pressure`` is
        replaced by ``pressure``.
    observers : iterable of callable, optional
        Each called with {"target", "pressure", "contacts"} after each balanced state.
    onset : optional
        The float64 result ``packing`` came from, kept in the result for the record.

    Returns
    -------
    RefineResult
        The balanced double-double packing at the target pressure, its contact network, and
        the history of every balanced state (target and reached pressure, phi, contacts).

    Raises
    ------
    ValueError
        A scene the refinement is not written for, or a target below the double-double floor.
    jamflow.JammingFailed
        The refinement does not converge, or the packing carries no pressure.
    """
    settings = settings or RefineSettings(pressure)
    if settings.pressure != pressure:
        settings = replace(settings, pressure=pressure)
    check_refine(packing, settings)
    t0 = time.perf_counter()
    rows = {c: [] for c in ("target_pressure", "pressure", "phi", "phi_lo", "contacts", "floaters", "newton_steps")}
    solids = float(packing.volumes.sum())

    def record(target, st, net, steps):
        rows["target_pressure"].append(target)
        rows["pressure"].append(net.pressure)
        phi, phi_lo = dd.dd_div(solids, 0.0, *st.volume())  # the double-double box; solids is float64, so phi is good to ~1e-16 relative, its changes to ~1e-30
        rows["phi"].append(phi)
        rows["phi_lo"].append(phi_lo)
        rows["contacts"].append(net.n_contacts)
        rows["floaters"].append(int(net.floater.sum()))
        rows["newton_steps"].append(steps)
        for observe in observers:
            observe({"target": target, "pressure": net.pressure, "contacts": net.n_contacts})

    try:
        st, net, steps = balance(packing, _State.of(packing), settings)
        start_contacts = _pairs(net)
        record(math.nan, st, net, steps)
        if net.pressure <= 0 or not net.n_contacts:
            raise RuntimeError("the packing carries no pressure (no contacts between non-floaters): refine a jammed "
                               "packing")
        slope = 0.7 * _affine_slope(packing, st, net)  # non-affine relaxation softens the affine response (~0.7, 2D)
        for target in _targets(net.pressure, pressure):
            tol = settings.pressure_tol if target == pressure else 1e-2
            st, net, slope = _walk(packing, st, net, target, tol, settings, record, slope)
    except RuntimeError as err:
        raise JammingFailed(f"double-double refinement failed: {err}") from None
    return RefineResult(st.wrapped().packing(packing), net, settings, {k: np.array(v) for k, v in rows.items()},
                        start_contacts, time.perf_counter() - t0, onset)


def refine_to_vtol(packing: Packing, v_tol: float, *, force_tol: float = 1e-12, observers=(),
                   onset=None) -> RefineResult:
    """Refine ``packing`` (as ``refine``) to the pressure whose double-double energy per particle V
    lands in V_tol < V < 2 V_tol. The first target is p0 (1.5 V_tol / V0)^(1 / ENERGY_EXPONENT) from the
    packing's own double-double (p0, V0), V ~ p^2 at a fixed network of linear springs; while V is
    outside the window, a secant on (log p, log V) picks the next pressure, each refinement continuing
    from the last refined state (at most ``MAX_VTOL_REFINES``). ``JammingFailed`` if V never lands.

    Parameters
    ----------
    packing : jamflow.Packing
        A jammed packing ``refine`` accepts (disks or spheres, linear spring, periodic box).
    v_tol : float
        V_tol of the energy window, eps (> 0, above what double-double resolves at this N).
    force_tol : float, default 1e-12
        The force tolerance of each refinement (``RefineSettings.force_tol``).
    observers : iterable of callable, optional
        As in ``refine``.
    onset : optional
        As in ``refine``.

    Returns
    -------
    RefineResult
        The refined packing with V in the window; ``refines`` counts the refinements it took.

    Raises
    ------
    ValueError
        A bad ``v_tol`` or a scene ``refine`` is not written for.
    jamflow.JammingFailed
        The packing carries no pressure, a refinement fails, or V is still outside the window
        after ``MAX_VTOL_REFINES`` refinements.
    """
    check_vtol(packing, v_tol, force_tol)
    t0 = time.perf_counter()
    first = evaluate(packing, _State.of(packing))
    if first.pressure <= 0 or first.energy[0] <= 0:
        raise JammingFailed("double-double refinement failed: the packing carries no pressure: refine a jammed packing")
    points = [(math.log(first.pressure), math.log(first.energy[0] / packing.n))]
    goal, slope, state = math.log(1.5 * v_tol), ENERGY_EXPONENT, packing
    floor = dd_pressure_floor(packing, force_tol)
    for k in range(1, MAX_VTOL_REFINES + 1):
        slope = _log_secant(points, slope)
        pressure = max(math.exp(points[-1][0] + (goal - points[-1][1]) / slope), floor)  # an overshoot stops at the floor
        result = refine(state, pressure, settings=RefineSettings(pressure, force_tol=force_tol, v_tol=v_tol),
                        observers=observers, onset=onset)
        if result.in_window:
            return replace(result, refines=k, seconds=time.perf_counter() - t0)
        points.append((math.log(result.pressure), math.log(result.energy_per_particle)))
        state = result.packing
    raise JammingFailed(f"double-double refinement failed: V = {result.energy_per_particle:.3e} after "
                        f"{MAX_VTOL_REFINES} refinements (p = {result.pressure:.3e}) is outside the window "
                        f"({v_tol:g}, {2 * v_tol:g})")


def _log_secant(points: list, slope: float) -> float:
    """d log V / d log p from the last two points, or ``slope`` if they do not give a positive one."""
    if len(points) < 2:
        return slope
    (pa, va), (pb, vb) = points[-2], points[-1]
    secant = (vb - va) / (pb - pa) if pb != pa else math.nan
    return secant if math.isfinite(secant) and secant > 0 else slope


def _targets(start: float, target: float) -> tuple:
    """Decades from ``start`` to ``target`` (either direction), ending at ``target``."""
    if target <= start:
        return pressure_sequence(target, start / 10.0) if target < start / 10.0 else (target,)
    seq = []
    p = start * 10.0
    while p < target:
        seq.append(p)
        p *= 10.0
    return tuple(seq) + (target,)


def _fits(packing: Packing, st: _State, mu: float) -> bool:
    """Whether the box of ``st`` scaled by 1 + ``mu`` keeps a unique minimum image (``fits_cell``)."""
    reach = float(packing.shape.reach(packing.diameters).max())
    return 1.0 + mu > 0 and fits_cell(Box(np.diag(st.lh * (1.0 + mu))), reach)


def _walk(packing: Packing, st: _State, net: Network, target: float, tol: float, settings: RefineSettings, record,
          slope: float):
    """Secant in the box length until |p / target - 1| <= tol, from the guess ``slope`` = dp/du;
    (state, network, the last secant slope)."""
    ref = st
    points = [(0.0, net.pressure)]
    for _ in range(settings.max_secant):
        u0, p0 = points[-1]
        if len(points) > 1:
            (ua, pa), (ub, pb) = points[-2], points[-1]
            slope = (pb - pa) / (ub - ua) if ub != ua and pb != pa else slope
        u_next = u0 + (target - p0) / slope
        for _ in range(STEP_HALVINGS):  # from the last balanced state, keeping its non-affine relaxation
            if not _fits(packing, st, (u_next - u0) / (1.0 + u0)):  # a secant past the densest box: back off
                u_next = 0.5 * (u0 + u_next)
                continue
            try:
                trial, new, steps = balance(packing, st.scaled((u_next - u0) / (1.0 + u0)), settings,
                                            _network(net))
                if new.pressure > 0 and new.n_contacts:
                    break
            except RuntimeError:  # past the onset or too far for Newton: back off halfway
                pass
            u_next = 0.5 * (u0 + u_next)
        else:
            raise RuntimeError(f"no balanced state between p = {p0:.3e} and the target {target:.3e}")
        st, net = trial, new
        points.append((_length_change(st, ref), net.pressure))
        record(target, st, net, steps)
        if abs(net.pressure / target - 1.0) <= tol:
            return st, net, slope
    raise RuntimeError(f"pressure {target:g} not reached in {settings.max_secant} box rescalings (at "
                       f"{net.pressure:.3e})")
