"""Pair distribution function g(r) and static structure factor S(k) (chapter section 4.2).

Conventions (lengths in small diameters; results in reduced units):

- r is reported in units of the rms contact distance ``<sigma^2>^(1/2)`` (chapter text after
  eq. 2.28), where sigma_ij = (d_i + d_j) / 2 is averaged over all distinct pairs; k is
  reported as ``k <sigma^2>^(1/2)``. For monodisperse particles the scale is the diameter.
- g(r) (eq. 2.28) is normalised by N(N-1) rather than the chapter's N^2, so that an ideal
  gas gives g -> 1 exactly rather than 1 - 1/N (this is freud's ``finite_size`` mode).
  It is computed up to half the shortest box width: beyond it spherical shells are cut by
  the cell and, as the chapter notes, statistics are greatly reduced.
- S(k) = |sum_i exp(i k.r_i)|^2 / N over the allowed wavevectors k = 2 pi h^-T n (n integer,
  n != 0) of the (possibly tilted) cell. This is the chapter's ``N^-1 <rho(k) rho(-k)>``;
  the printed eq. 2.29 omits the i = j terms, which would give S(k) - 1. Because
  S(-k) = S(k), only one vector of each +-k pair is evaluated.

Everything is computed in float64 from ``jamflow.model.pairs`` separations. freud (float32) serves
as the second implementation in the tests; near jamming, contacts sit ~1e-8 inside sigma_ij,
below float32 resolution, which is why jamflow does not bin freud distances by default.
Ensembles: pass a sequence of packings; pair counts and ideal-gas normalisations (g), and
|rho(k)|^2 sums (S) are pooled over packings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import product
from typing import Iterable, Sequence

import numpy as np

from jamflow.model.box import Box
from jamflow.model.packing import Packing
from jamflow.model.pairs import candidate_pairs, separations
from jamflow.support.machine import MAX_BINS, check_bins, physical_memory

PAIR_CHUNK = 200_000  # pairs per separation batch (keeps Box.minimum_image memory bounded)
MAX_SPECIES = 8  # more distinct diameters than this is treated as continuous polydispersity


# --- helpers shared by the analysis modules -------------------------------------------------
UNITS_R = "units of <sigma^2>^1/2"


def positive(name: str, value, units: str = "") -> float:
    """``value`` as a float if it is a finite positive number, else a ValueError naming it."""
    ok = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)
    if not (ok and math.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a finite positive number{f' ({units})' if units else ''}, got {value!r}")
    return float(value)


def as_packings(packings: Packing | Iterable[Packing]) -> list[Packing]:
    """One packing or an ensemble -> non-empty list; all of the same dimension."""
    items = [packings] if isinstance(packings, Packing) else list(packings)
    if not items:
        raise ValueError("no packings given: pass a Packing or a non-empty sequence of them")
    if not all(isinstance(p, Packing) for p in items):
        raise ValueError("expected jamflow Packing objects; load files with jamflow.io.packing_file.load_packing "
                         "or jamflow.io.readers.packing_from_lammps")
    if len({p.dim for p in items}) != 1:
        raise ValueError("an ensemble must not mix 2D and 3D packings")
    return items


def rms_contact_distance(diameters) -> float:
    """<sigma_ij^2>^(1/2) over all distinct pairs i != j, sigma_ij = (d_i + d_j)/2 (diameters)."""
    d = np.asarray(diameters, float)
    n = len(d)
    if n < 2:
        raise ValueError("need at least two particles for a contact distance")
    s1, s2 = d.sum(), (d * d).sum()
    mean_sq = (2.0 * (n - 1) * s2 + 2.0 * (s1 * s1 - s2)) / (4.0 * n * (n - 1))
    return math.sqrt(mean_sq)


def max_reduced_radius(packings: Sequence[Packing]) -> float:
    """Half the shortest box width over the ensemble, in units of <sigma^2>^(1/2)."""
    return min(0.5 * p.box.widths.min() / rms_contact_distance(p.diameters) for p in packings)


def pair_chunks(packing: Packing, r_cut: float):
    """Yield (i, j, dr, r) for pairs i < j with r < r_cut (float64 minimum image), in batches."""
    i_all, j_all = candidate_pairs(packing, r_cut)
    for start in range(0, len(i_all), PAIR_CHUNK):
        i, j = i_all[start:start + PAIR_CHUNK], j_all[start:start + PAIR_CHUNK]
        dr = separations(packing, i, j)
        r = np.linalg.norm(dr, axis=1)
        keep = r < r_cut
        yield i[keep], j[keep], dr[keep], r[keep]


def ball_volume(r, dim: int):
    """Area (2D) or volume (3D) of a ball of radius r."""
    r = np.asarray(r, float)
    return math.pi * r**2 if dim == 2 else 4.0 * math.pi / 3.0 * r**3


def radial_edges(r_max: float, dr: float) -> np.ndarray:
    """Bin edges 0, dr, 2 dr, ... <= r_max; validated."""
    positive("bin width dr", dr)
    if not dr < r_max:
        raise ValueError(f"bin width dr = {dr} must be smaller than r_max = {r_max:.4g}")
    count = check_bins(math.floor(r_max / dr + 1e-9), f"bin width dr = {dr:g} up to r_max = {r_max:.4g}",
                       f"use a bin width of at least {r_max / MAX_BINS:.3g}")
    return np.arange(count + 1) * dr


def check_r_max(r_max, packings: Sequence[Packing]) -> float:
    """Default (None) or validated r_max in reduced units: at most half the shortest box width."""
    limit = max_reduced_radius(packings)
    if r_max is None:
        return limit
    positive("r_max", r_max, UNITS_R)
    if r_max > limit * (1 + 1e-12):
        raise ValueError(f"r_max = {r_max:g} exceeds half the shortest box width ({limit:.4g} in units of "
                         "<sigma^2>^1/2); beyond it shells are cut by the periodic cell (chapter section 4.2). "
                         "Use a smaller r_max or larger packings")
    return float(r_max)


# --- g(r) ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class RDFResult:
    """g(r) on bins of r / <sigma^2>^(1/2); ``partial[a, b]`` for discrete species."""

    edges: np.ndarray  #: (nbins + 1,) reduced units
    g: np.ndarray  #: (nbins,) g(r), 1 for an ideal gas
    counts: np.ndarray  #: (nbins,) pair counts (i < j) pooled over packings
    ideal: np.ndarray  #: (nbins,) expected counts for an ideal gas at the same densities
    species: np.ndarray  #: distinct diameters (empty when partials were not computed)
    partial: np.ndarray  #: (ns, ns, nbins) g_ab, symmetric; shape (0, 0, nbins) if not computed
    scales: np.ndarray  #: <sigma^2>^(1/2) of each packing (diameters)
    n_packings: int  #: packings pooled

    def __repr__(self) -> str:
        """One line: bins, r range, packings, species with partials, the first peak."""
        peak = int(np.nanargmax(self.g)) if len(self.g) else 0
        return (f"RDFResult(bins={len(self.g)}, r=[{self.edges[0]:.4g}, {self.edges[-1]:.4g}], "
                f"n_packings={self.n_packings}, partial_species={len(self.species)}, "
                f"peak_g={self.g[peak] if len(self.g) else float('nan'):.4g}, peak_r={self.r[peak] if len(self.g) else float('nan'):.4g})")

    @property
    def r(self) -> np.ndarray:
        """Bin centres, units of <sigma^2>^(1/2)."""
        return 0.5 * (self.edges[1:] + self.edges[:-1])

    @property
    def dr(self) -> float:
        """Bin width, units of <sigma^2>^(1/2)."""
        return float(self.edges[1] - self.edges[0])

    @property
    def stderr(self) -> np.ndarray:
        """Poisson estimate of the statistical error of g: sqrt(max(counts, 1)) / ideal."""
        return np.sqrt(np.maximum(self.counts, 1.0)) / self.ideal

    def first_peak(self, r_below: float | None = None) -> tuple[float, float]:
        """(r, g) at the maximum of g over bins with r < ``r_below`` (default: all bins).
        Pass the first minimum r_min to get the first (contact) peak."""
        upto = len(self.g) if r_below is None else max(1, int(np.searchsorted(self.r, r_below)))
        k = int(np.argmax(self.g[:upto]))
        return float(self.r[k]), float(self.g[k])


class RDF:
    """Pair distribution function g(r) (chapter eq. 2.28), total and partial, 2D/3D, tilted boxes.

    ``dr`` and ``r_max`` are in units of <sigma^2>^(1/2); ``r_max`` defaults to half the
    shortest box width. ``partial=True`` also returns g_ab for discrete species (at most
    8 distinct diameters, the same in every packing of the ensemble).

    Parameters
    ----------
    dr : float, default 0.01
        Bin width in units of <sigma^2>^(1/2) (> 0).
    r_max : float, optional
        The largest r in units of <sigma^2>^(1/2), at most half the shortest box width (the default).
    partial : bool, default False
        Also compute the partial g_ab of each pair of species.

    Raises
    ------
    ValueError
        A ``dr`` or ``r_max`` that is not a finite positive number.
    """

    def __init__(self, dr: float = 0.01, r_max: float | None = None, partial: bool = False):
        self.dr = positive("dr", dr, UNITS_R)
        self.r_max = None if r_max is None else positive("r_max", r_max, UNITS_R)
        self.partial = bool(partial)

    def compute(self, packings: Packing | Iterable[Packing]) -> RDFResult:
        """g(r) of one packing, or pooled over an ensemble (pair counts and ideal-gas counts summed).

        Parameters
        ----------
        packings : jamflow.Packing or iterable of jamflow.Packing
            One packing or a non-empty ensemble of the same dimension.

        Returns
        -------
        RDFResult
            g(r) (and g_ab) on bins of r / <sigma^2>^(1/2), normalised by N (N - 1).

        Raises
        ------
        ValueError
            No packings, mixed dimensions, ``r_max`` beyond half the shortest box width, or
            ``partial`` with more than 8 diameters or different species across the ensemble.
        """
        items = as_packings(packings)
        edges = radial_edges(check_r_max(self.r_max, items), self.dr)
        species = _common_species(items) if self.partial else np.empty(0)
        ns, nb = len(species), len(edges) - 1
        counts, ideal = np.zeros(nb), np.zeros(nb)
        pcounts, pideal = np.zeros((ns, ns, nb)), np.zeros((ns, ns, nb))
        scales = np.array([rms_contact_distance(p.diameters) for p in items])
        for packing, scale in zip(items, scales):
            shell = np.diff(ball_volume(edges * scale, packing.dim)) / packing.box.volume
            labels = np.searchsorted(species, packing.diameters) if ns else None
            for i, j, _, r in pair_chunks(packing, edges[-1] * scale):
                counts += np.histogram(r / scale, edges)[0]
                if ns:
                    _add_partial_counts(pcounts, labels[i], labels[j], r / scale, edges)
            counts_n = packing.n * (packing.n - 1) / 2.0
            ideal += counts_n * shell
            if ns:
                pideal += _partial_pair_numbers(labels, ns)[:, :, None] * shell[None, None, :]
        with np.errstate(divide="ignore", invalid="ignore"):
            partial = np.where(pideal > 0, pcounts / pideal, 0.0)
        return RDFResult(edges, counts / ideal, counts, ideal, species, partial, scales, len(items))


def _common_species(packings: Sequence[Packing]) -> np.ndarray:
    species = [np.unique(p.diameters) for p in packings]
    first = species[0]
    if len(first) > MAX_SPECIES:
        raise ValueError(f"{len(first)} distinct diameters: partial g(r) needs discrete species (at most "
                         f"{MAX_SPECIES}, e.g. sizes bi:1.4:0.5); use partial=False for continuous polydispersity")
    if any(len(s) != len(first) or not np.array_equal(s, first) for s in species[1:]):
        raise ValueError("partial g(r) over an ensemble needs the same species (diameters) in every packing")
    return first


def _add_partial_counts(pcounts, a, b, r, edges):
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    for x in range(pcounts.shape[0]):
        for y in range(x, pcounts.shape[0]):
            sel = (lo == x) & (hi == y)
            h = np.histogram(r[sel], edges)[0]
            pcounts[x, y] += h
            if x != y:
                pcounts[y, x] += h


def _partial_pair_numbers(labels, ns) -> np.ndarray:
    """Number of distinct (unordered) pairs per species pair: N_a N_b, or N_a (N_a - 1)/2."""
    n = np.bincount(labels, minlength=ns).astype(float)
    pairs = np.outer(n, n)
    pairs[np.diag_indices(ns)] = n * (n - 1) / 2.0
    return pairs


# --- S(k) ------------------------------------------------------------------------------------
def structure_factor_grid(packing: Packing, k_max: float) -> tuple[np.ndarray, np.ndarray]:
    """(k, S) for every allowed wavevector 0 < |k| <= k_max (units 1/diameter), one of each
    +-k pair: k = 2 pi h^-T n with integer n, since k.a_d = 2 pi n_d for every cell vector a_d.

    rho(k) = sum_j exp(2 pi i n.s_j) (s: fractional coordinates) factorises over dimensions,
    so rho on the whole integer grid is a product of per-dimension phase matrices (BLAS).
    """
    positive("k_max", k_max, "1/diameter")
    box = packing.box
    check_grid_memory(packing, k_max)
    bounds = _grid_bounds(box, k_max)
    frac = box.to_fractional(packing.positions)
    phases = [np.exp(2j * math.pi * np.outer(frac[:, d], np.arange(-b, b + 1))) for d, b in enumerate(bounds)]
    if box.dim == 2:
        rho = phases[0].T @ phases[1]
    else:
        rho = np.stack([(phases[0][:, m, None] * phases[1]).T @ phases[2] for m in range(phases[0].shape[1])])
    n = np.stack(np.meshgrid(*[np.arange(-b, b + 1) for b in bounds], indexing="ij"), axis=-1).reshape(-1, box.dim)
    k = 2 * math.pi * np.linalg.solve(box.h.T, n.T.astype(float)).T
    keep = _positive_half(n) & (np.einsum("kd,kd->k", k, k) <= k_max**2)
    rho = rho.reshape(-1)[keep]
    return k[keep], (rho * rho.conj()).real / packing.n


BYTES_PER_K = 28  # bytes per grid wavevector, times (dim + 1): measured 79 B per point in 2D (N = 32, k_max 1500)


def _grid_bounds(box, k_max: float) -> list[int]:
    return [int(math.ceil(k_max * np.linalg.norm(box.h[:, d]) / (2 * math.pi))) for d in range(box.dim)]


def grid_bytes(packing: Packing, k_max: float) -> float:
    """About the peak memory of ``structure_factor_grid(packing, k_max)``: the whole integer grid
    of wavevectors (2 b_d + 1 per dimension) is held at once."""
    points = math.prod(2.0 * b + 1 for b in _grid_bounds(packing.box, k_max))
    return points * (BYTES_PER_K * (packing.dim + 1)) + 16.0 * packing.n * sum(_grid_bounds(packing.box, k_max))


def check_grid_memory(packing: Packing, k_max: float, name: str = "k_max", scale: float = 1.0) -> None:
    """Refuse (ValueError, before any allocation) a k_max whose wavevector grid does not fit in
    this machine's memory, naming the largest value that fits (``scale``: the unit of k_max in
    diameters, as in StructureFactor)."""
    total = physical_memory()
    if total is None or grid_bytes(packing, k_max) <= total / 2:
        return
    lo, hi = 0.0, k_max  # the grid grows with k_max: bisect for the largest value within half the memory
    for _ in range(60):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if grid_bytes(packing, mid) <= total / 2 else (lo, mid)
    raise ValueError(f"{name} {k_max * scale:g} needs about {grid_bytes(packing, k_max) / 1e9:.3g} GB for its grid "
                     f"of wavevectors, more than half of this machine's {total / 1e9:.3g} GB; use {name} <= "
                     f"{math.floor(lo * scale * 100) / 100:g}")


def _positive_half(n: np.ndarray) -> np.ndarray:
    """Mask of integer vectors whose first non-zero component is positive (excludes 0)."""
    first = np.argmax(n != 0, axis=1)
    return n[np.arange(len(n)), first] > 0


@dataclass(frozen=True)
class StructureFactorResult:
    """Shell-averaged S(k); k in units of 1/<sigma^2>^(1/2); only non-empty shells."""

    k: np.ndarray  #: mean |k| of the vectors in each shell
    s: np.ndarray  #: mean S over the shell's vectors (pooled over packings)
    n_vectors: np.ndarray  #: vectors per shell (one of each +-k pair), summed over packings
    dk: float  #: shell width, units of 1/<sigma^2>^(1/2)
    n_packings: int  #: packings pooled

    def __repr__(self) -> str:
        """One line: shells, k range, dk, packings, the largest S(k) and where."""
        top = int(np.argmax(self.s)) if len(self.s) else 0
        return (f"StructureFactorResult(shells={len(self.k)}, k=[{self.k.min():.4g}, {self.k.max():.4g}], "
                f"dk={self.dk:.4g}, n_packings={self.n_packings}, s_max={self.s[top]:.4g}, k_at_max={self.k[top]:.4g})"
                if len(self.k) else f"StructureFactorResult(shells=0, dk={self.dk:.4g}, n_packings={self.n_packings})")

    @property
    def stderr(self) -> np.ndarray:
        """Rough statistical error: S / sqrt(vectors in shell) (S(k) is exponential-distributed
        per vector for a disordered system)."""
        return self.s / np.sqrt(self.n_vectors)


class StructureFactor:
    """Angularly averaged S(k) over the allowed wavevectors (chapter eq. 2.29 and text).

    ``k_max`` and ``dk`` are in units of 1/<sigma^2>^(1/2). Shell m collects
    |k| in [(m - 1/2) dk, (m + 1/2) dk); ``dk`` defaults to 2 pi / (longest box side), the
    reciprocal-lattice spacing, so the lowest allowed |k| values each get their own shell.

    Parameters
    ----------
    k_max : float, default 20.0
        The largest |k| in units of 1/<sigma^2>^(1/2) (> 0).
    dk : float, optional
        Shell width in the same units (0 < dk < k_max); default 2 pi / (longest box side).

    Raises
    ------
    ValueError
        A ``k_max`` or ``dk`` that is not a finite positive number, or ``dk >= k_max``.
    """

    def __init__(self, k_max: float = 20.0, dk: float | None = None):
        self.k_max = positive("k_max", k_max, "units of 1/<sigma^2>^1/2")
        if dk is not None and positive("dk", dk) >= self.k_max:
            raise ValueError(f"dk = {dk} must be smaller than k_max = {k_max}")
        self.dk = dk

    def check_memory(self, packings: Packing | Iterable[Packing]) -> None:
        """Refuse (ValueError, before any work) a k_max whose grid of wavevectors does not fit in
        memory for one of ``packings``, naming the largest value that does."""
        for packing in as_packings(packings):
            scale = rms_contact_distance(packing.diameters)
            check_grid_memory(packing, self.k_max / scale, "k_max (--k-max)", scale)

    def compute(self, packings: Packing | Iterable[Packing]) -> StructureFactorResult:
        """S(k) of one packing, or pooled over an ensemble (shell sums over every packing's vectors).

        Parameters
        ----------
        packings : jamflow.Packing or iterable of jamflow.Packing
            One packing or a non-empty ensemble of the same dimension; ``dk``'s default comes
            from the first.

        Returns
        -------
        StructureFactorResult
            Shell-averaged S(k), S = |sum_j exp(i k.r_j)|^2 / N, k in units of 1/<sigma^2>^(1/2).

        Raises
        ------
        ValueError
            No packings, mixed dimensions, or a ``k_max`` whose wavevector grid does not fit
            in memory (checked before any work).
        """
        items = as_packings(packings)
        scales = [rms_contact_distance(p.diameters) for p in items]
        dk = self.dk or 2 * math.pi * scales[0] / float(items[0].box.lengths.max())
        nshell = int(math.floor(self.k_max / dk + 0.5)) + 1
        ssum, ksum, count = np.zeros(nshell), np.zeros(nshell), np.zeros(nshell)
        self.check_memory(items)
        for packing, scale in zip(items, scales):
            k, values = structure_factor_grid(packing, self.k_max / scale)
            kred = np.linalg.norm(k, axis=1) * scale
            shell = np.floor(kred / dk + 0.5).astype(int)
            ok = shell < nshell
            ssum += np.bincount(shell[ok], values[ok], nshell)
            ksum += np.bincount(shell[ok], kred[ok], nshell)
            count += np.bincount(shell[ok], minlength=nshell)
        full = count > 0
        return StructureFactorResult(ksum[full] / count[full], ssum[full] / count[full], count[full].astype(int),
                                     float(dk), len(items))


# --- reference crystals ----------------------------------------------------------------------
def triangular_packing(nx: int, ny: int, spacing: float = 1.0, tilted: bool = False) -> Packing:
    """Perfect triangular (hexagonal) crystal of equal disks, diameter = spacing (touching).

    ``tilted=False``: rectangular cell nx x ny*sqrt(3)/2 (ny even). ``tilted=True``: the
    rhombic primitive cell nx x nx (ny ignored), a LAMMPS-tilted box with xy = lx / 2.
    """
    if tilted:
        cell = np.array([[1.0, 0.5], [0.0, math.sqrt(3) / 2]]) * spacing
        frac = np.array(list(product(range(nx), range(nx))), float)
        return Packing(frac @ cell.T, np.full(nx * nx, spacing), Box(cell * nx))
    if ny % 2:
        raise ValueError("a rectangular triangular-lattice cell needs an even number of rows ny")
    rows = [[(i + 0.5 * (j % 2)) * spacing, j * spacing * math.sqrt(3) / 2] for j in range(ny) for i in range(nx)]
    box = Box([[nx * spacing, 0.0], [0.0, ny * spacing * math.sqrt(3) / 2]])
    return Packing(np.array(rows), np.full(nx * ny, spacing), box)


def fcc_packing(cells: int, spacing: float = 1.0) -> Packing:
    """Perfect FCC crystal of touching equal spheres (nearest-neighbour distance = spacing)
    in a cubic box of cells^3 conventional cells (4 spheres each)."""
    a = spacing * math.sqrt(2)
    basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    corners = np.array(list(product(range(cells), repeat=3)), float)
    pos = (corners[:, None, :] + basis[None, :, :]).reshape(-1, 3) * a
    return Packing(pos, np.full(len(pos), spacing), Box.cube(cells * a, 3))
