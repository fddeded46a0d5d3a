"""Sampling geometric families (chapter section 2.2, Figures 2.6-2.7).

On a grid of strains gamma_s (spacing Delta gamma), jam many random starts at each gamma_s
(compression at fixed strain, ``jam(gamma=...)``) and follow each packing by quasistatic shear
at zero pressure (``protocols.shear``) in n steps of delta gamma = Delta gamma / n to the
neighbouring grid points gamma_{s+1} and gamma_{s-1}. Every static packing met on the way is a
``point``: its strain, phi_J, the stress ratio Sigma / P, the contact fabric anisotropy, a
contact-network signature that does not depend on particle labels, and the *segment* it belongs to -- the run of steps of one path
with an unchanged contact network (labels fixed along a path, so "unchanged" is exact).
``jamflow.analysis.families`` joins segments into families.

Seeds: start k at grid point s uses seed ``SEED_STRIDE * s + k + seed``, so every (s, k) is an
independent random start and adding starts keeps the earlier ones.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import asdict, dataclass

import numpy as np

from jamflow.model.box import Box
from jamflow.model.packing import BoxTooSmall, fits_cell, particle_volumes
from jamflow.model.shapes.shape import SPHERE
from jamflow.model.sizes import parse_sizes
from jamflow.protocols.compression import check_strain, jam
from jamflow.protocols.outcome import JammingFailed
from jamflow.protocols.shear import shear, shear_protocol
from jamflow.support.settings_errors import SettingError

SEED_STRIDE = 100_000
MAX_GRID = 100_000  # grid strains: each is jammed once per start
# The packing fraction at which a plan's cells must hold the particles: phi_J of bidisperse disks
# in the large-N limit, 0.84 (O'Hern, Silbert, Liu & Nagel, PRE 68, 011306 (2003)). A start that
# jams denser than its cell can hold at its strain is a failure of that start (``sample_start``).
FIT_PHI = 0.84
POINT_FIELDS = ("start", "grid", "direction", "step", "segment", "strain_index", "gamma", "phi_j", "mu",
                "fabric_a", "fabric_b", "pressure", "n_contacts", "n_floaters", "signature")


@dataclass(frozen=True)
class FamilySampling:
    """The sampling plan; strains dimensionless."""

    n: int = 10  #: particles per packing (2D disks)
    sizes: str = "bi:1.4:0.5"  #: the size spec (``parse_sizes``)
    gamma_min: float = 0.0  #: first grid strain
    gamma_max: float = 1.0  #: last grid strain (spacing divides [gamma_min, gamma_max] into whole intervals)
    spacing: float = 0.01  #: Delta gamma between grid points (the chapter's example)
    substeps: int = 10  #: n shear steps between grid points: delta gamma = spacing / substeps
    starts: int = 20  #: random starts per grid point
    seed: int = 0  #: offset of every start's seed (SEED_STRIDE * grid point + start + seed)
    engine: str = "auto"  #: "auto", "numba" or "lammps"

    def __post_init__(self):
        for name in ("gamma_min", "gamma_max", "spacing"):
            check_strain(getattr(self, name), f"{name} (--{name.replace('_', '-')})")
        if not self.spacing > 0:
            raise ValueError(f"the grid spacing must be positive, got {self.spacing}")
        if not self.gamma_max > self.gamma_min:
            raise ValueError(f"gamma_max = {self.gamma_max} must exceed gamma_min = {self.gamma_min}")
        count = (self.gamma_max - self.gamma_min) / self.spacing
        if abs(count - round(count)) > 1e-6:
            raise ValueError(f"the grid spacing {self.spacing} must divide [{self.gamma_min}, {self.gamma_max}] "
                             "into whole intervals")
        if round(count) + 1 > MAX_GRID:
            raise ValueError(f"the grid spacing (--spacing) {self.spacing:g} gives {round(count) + 1:.4g} grid strains in "
                             f"[{self.gamma_min:g}, {self.gamma_max:g}]: more than {MAX_GRID:,}; use a spacing of at "
                             f"least {(self.gamma_max - self.gamma_min) / (MAX_GRID - 1):.3g}")
        for name in ("n", "substeps", "starts"):
            value = getattr(self, name)
            if not isinstance(value, (int, np.integer)) or value < 1:
                raise SettingError(name, f"must be a positive integer, got {value!r}")
        if self.starts > SEED_STRIDE:
            raise ValueError(f"at most {SEED_STRIDE} starts per grid point")
        self._check_cell()

    def _check_cell(self) -> None:
        """Refuse, before any work, grid strains whose Lees-Edwards cell cannot hold the N disks at
        phi = FIT_PHI (box narrower than twice the largest contact distance: no unique minimum
        image, ``model.packing.fits_cell``); sizes drawn at random are checked start by start."""
        spec = parse_sizes(self.sizes)
        if not spec.discrete:
            return
        diameters = spec.draw(self.n, np.random.default_rng(0))
        side = math.sqrt(particle_volumes(diameters, 2).sum() / FIT_PHI)
        reach = float(SPHERE.reach(diameters).max())
        cell = Box.cube(side, 2)
        bad = [g for g in self.grid if not fits_cell(cell.with_shear_strain(float(g)), reach)]
        if not bad:
            return
        lo, hi = 0.0, 0.5  # the largest reduced strain |gamma - k| that fits, by bisection
        if not fits_cell(cell, reach):
            raise ValueError(f"N = {self.n} disks ({self.sizes}) do not fit the cell even unsheared at phi {FIT_PHI}: "
                             "the box is narrower than twice the largest contact distance; use more particles")
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if fits_cell(cell.with_shear_strain(mid), reach) else (lo, mid)
        edge = math.floor(lo * 100) / 100
        example = f" (e.g. --gamma-min {-edge:g} --gamma-max {edge:g})" if edge > 0 else ""
        raise ValueError(f"N = {self.n} disks ({self.sizes}) do not fit the cell at gamma = {bad[0]:.6g}: at phi "
                         f"{FIT_PHI} the box is narrower than twice the largest contact distance (unique minimum "
                         f"image) once |gamma - k| > {lo:.3f}, k the nearest integer; keep every strain within "
                         f"{lo:.3f} of an integer{example} or use more particles")

    @property
    def grid(self) -> np.ndarray:
        """The grid strains gamma_min, gamma_min + spacing, ..., gamma_max."""
        count = round((self.gamma_max - self.gamma_min) / self.spacing)
        return self.gamma_min + self.spacing * np.arange(count + 1)

    @property
    def step(self) -> float:
        """delta gamma of the shear paths."""
        return self.spacing / self.substeps

    def strain_index(self, gamma) -> np.ndarray:
        """Integer position of a strain on the lattice gamma_min + m delta gamma."""
        return np.round((np.asarray(gamma) - self.gamma_min) / self.step).astype(np.int64)

    def as_dict(self) -> dict:
        """The plan as a dict of its fields (the attributes of the families file)."""
        return asdict(self)


def signature(network, diameters) -> str:
    """Contact-network invariants that no relabelling changes: contacts, floaters, contacts
    per pair of species, and each species' sorted contact numbers (non-floaters)."""
    species = np.unique(diameters, return_inverse=True)[1]
    kinds = int(species.max()) + 1
    si, sj = species[network.i], species[network.j]
    lo, hi = np.minimum(si, sj), np.maximum(si, sj)
    pairs = [int(np.sum((lo == a) & (hi == b))) for a in range(kinds) for b in range(a, kinds)]
    z = np.bincount(network.i, minlength=len(species)) + np.bincount(network.j, minlength=len(species))
    per_species = ["".join(str(v) for v in sorted(z[(species == a) & (z > 0)])) for a in range(kinds)]
    return f"c{network.n_contacts}-f{network.n_floaters}-p{'.'.join(map(str, pairs))}-z{'.'.join(per_species)}"


def sample_start(plan: FamilySampling, s: int, k: int, first_segment: int) -> tuple[list[dict], list[str]]:
    """(points, failures) of start k at grid point s: the jammed packing and its paths to the
    neighbouring grid points (segments numbered from ``first_segment``). A jam or path that
    raises JammingFailed adds no points and one line to ``failures``."""
    grid = plan.grid
    seed = SEED_STRIDE * s + k + plan.seed
    try:
        jammed = jam(n=plan.n, sizes=plan.sizes, seed=seed, gamma=float(grid[s]), engine=plan.engine)
    except (JammingFailed, BoxTooSmall) as err:  # a start jamming denser than its cell holds (FIT_PHI)
        return [], [f"start {k} at gamma {grid[s]:.6g} (seed {seed}): {err}"]
    points, failures, segment = [], [], first_segment
    for direction, target in ((+1, s + 1), (-1, s - 1)):
        if not 0 <= target < len(grid):
            continue
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # a rearranging first step is part of what is sampled
                path = shear(jammed.packing, direction * plan.step, float(grid[target]), shear_protocol(),
                             engine=plan.engine)
        except (JammingFailed, BoxTooSmall) as err:
            failures.append(f"start {k} at gamma {grid[s]:.6g} (seed {seed}), shear to {grid[target]:.6g}: {err}")
            continue
        seg = first_segment  # step 0 is the sampled packing itself: the same segment both ways
        for step, st in enumerate(path.steps):
            if step == 0 and any(p["step"] == 0 for p in points):
                continue  # already recorded by the forward path
            if st.changed:
                segment += 1
                seg = segment
            points.append(_point(plan, k, s, direction, step, seg, st))
        segment += 1
    return points, failures


def fabric(network) -> tuple[float, float]:
    """(<n_x^2 - n_y^2>, <2 n_x n_y>) over the contacts' unit vectors n: the anisotropy of the
    contact fabric, unchanged by relabelling, translation and inversion, changed by reflections
    (x -> -x flips the second; the diagonal reflection of a square cell flips the first)."""
    if network.n_contacts == 0:
        return 0.0, 0.0
    n = network.dr / np.linalg.norm(network.dr, axis=1)[:, None]
    return float(np.mean(n[:, 0] ** 2 - n[:, 1] ** 2)), float(np.mean(2 * n[:, 0] * n[:, 1]))


def _point(plan, k, s, direction, step, segment, st) -> dict:
    fab_a, fab_b = fabric(st.network)
    return dict(start=k, grid=s, direction=direction, step=step, segment=segment,
                strain_index=int(plan.strain_index(st.gamma)), gamma=st.gamma, phi_j=st.phi_j,
                mu=st.shear_stress / st.jam.pressure, fabric_a=fab_a, fabric_b=fab_b, pressure=st.jam.pressure,
                n_contacts=st.network.n_contacts, n_floaters=st.network.n_floaters,
                signature=signature(st.network, st.packing.diameters))


def sample(plan: FamilySampling, *, done: dict | None = None, failures=(), observers=(), checkpoint=None):
    """(columns, failures): all points of the plan (POINT_FIELDS -> array) and the failed jams
    and paths. Starts run round by round (start k at every grid point, then k + 1), so an
    interrupted run holds complete rounds; ``done`` (columns of an earlier run of the same plan)
    and its ``failures`` are kept and its rounds skipped. ``checkpoint(columns, failures)`` is
    called after every round, ``observers(k, s)`` after every start."""
    rows, failed = ([] if done is None else _rows(done)), list(failures)
    finished = {int(k) for k in (done or {}).get("start", [])}
    segment = 1 + max((int(r["segment"]) for r in rows), default=-1)
    for k in range(plan.starts):
        if k in finished:
            continue
        for s in range(len(plan.grid)):
            new, why = sample_start(plan, s, k, segment)
            segment = 1 + max((p["segment"] for p in new), default=segment)
            rows += new
            failed += why
            for observe in observers:
                observe(k, s)
        if checkpoint is not None:
            checkpoint(columns(rows), failed)
    return columns(rows), failed


def columns(rows: list[dict]) -> dict:
    """Sampled points (one dict each) as columns, one array per ``POINT_FIELDS`` name (the signature as bytes)."""
    out = {f: np.array([r[f] for r in rows]) for f in POINT_FIELDS}
    out["signature"] = out["signature"].astype("S") if len(rows) else np.array([], dtype="S1")
    return out


def _rows(cols: dict) -> list[dict]:
    sig = [s.decode() if isinstance(s, bytes) else str(s) for s in cols["signature"]]
    return [{**{f: cols[f][m].item() for f in POINT_FIELDS if f != "signature"}, "signature": sig[m]}
            for m in range(len(sig))]


def expected_points(plan: FamilySampling) -> int:
    """Points per round: one sampled packing per grid point plus the steps of its paths."""
    s = len(plan.grid)
    return s + 2 * (s - 1) * plan.substeps


