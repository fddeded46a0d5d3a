"""Normal modes, density of states and mechanical-stability class (seed chapter section 3).

- ``Spectrum``: eigenvalues e_i (eps / diameter^2) of the dynamical matrix over the
  non-floaters; dense for small systems, sparse shift-invert for the lowest modes of large
  ones. |e_i| <= e_min (default 1e-6, seed ref. [28]) counts as zero; a periodic packing has
  d trivial zero modes (uniform translations). Frequencies omega_i = sqrt(e_i / M) with
  M = N m, m = 1 (the seed's definition, N including floaters), for e_i > e_min.
- ``DensityOfStates``: D(omega) = (N(omega + d omega) - N(omega)) / d omega, modes per unit
  frequency per packing, averaged over packings (seed Figure 2.16).
- ``Stability``: mechanically stable (exactly d zero modes, none negative), locally stable
  (extra zero modes, seed Figure 2.15b) or unstable (e_i < -e_min), with the evidence
  Delta V(delta) = V(xi_0 + delta e_1) - V(xi_0) along the lowest nontrivial mode e_1 and the
  power p of its symmetric part ~ delta^p (2 stable, 4 quartic, "flat" for a zero mode).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse.linalg as spla

from ..packing import Packing
from ..pairs import candidate_pairs, contact_distances, separations
from .hessian import DynamicalMatrix, DynamicalMatrixResult

DENSE_MAX_DOF = 4096  # above this many degrees of freedom "auto" uses the sparse solver


@dataclass(frozen=True)
class SpectrumResult:
    """Eigen-decomposition of one packing's dynamical matrix (ascending eigenvalues)."""

    eigenvalues: np.ndarray  # (m,), eps / diameter^2; all d N' of them when complete
    eigenvectors: np.ndarray | None  # (d N', m) orthonormal columns, or None
    dynamical: DynamicalMatrixResult
    e_min: float
    mass: float  # M in omega = sqrt(e / M)
    complete: bool  # False: only the lowest m modes (sparse solver)

    @property
    def dim(self) -> int:
        return self.dynamical.dim

    @property
    def n_dof(self) -> int:
        """d N', the matrix dimension."""
        return self.dynamical.n_dof

    @property
    def n_zero(self) -> int:
        """Modes with |e| <= e_min, the d trivial ones included."""
        return int(np.sum(np.abs(self.eigenvalues) <= self.e_min))

    @property
    def n_negative(self) -> int:
        return int(np.sum(self.eigenvalues < -self.e_min))

    @property
    def n_extra_zero(self) -> int:
        """Zero modes beyond the d trivial translations."""
        return self.n_zero - self.dim

    @property
    def nonzero(self) -> np.ndarray:
        """Eigenvalues above e_min, ascending."""
        return self.eigenvalues[self.eigenvalues > self.e_min]

    @property
    def lowest_nonzero(self) -> float:
        values = self.nonzero
        return float(values[0]) if len(values) else float("nan")

    @property
    def frequencies(self) -> np.ndarray:
        """omega_i = sqrt(e_i / M) of the nonzero modes, ascending (units sqrt(eps/m)/diameter)."""
        return np.sqrt(self.nonzero / self.mass)

    @property
    def translation_residual(self) -> float:
        """max |M T| over the exact translations T: ~1e-16 |M| if the matrix is periodic-exact."""
        m = self.dynamical.matrix
        return float(np.abs(m @ self.dynamical.translations()).max()) if m.shape[0] else 0.0


class Spectrum:
    """Eigenvalues (and vectors) of the dynamical matrix.

    ``e_min``: zero-mode threshold (eps / diameter^2). ``mass``: M in omega = sqrt(e / M),
    None for the seed's M = N m (m = 1). ``method``: "auto" (dense up to 4096 DOF), "dense"
    or "sparse" (shift-invert about -e_min for the ``n_modes`` lowest modes, enlarged until
    the zero modes are bracketed; eigenvalues far below -e_min can be missed there).
    ``vectors``: keep eigenvectors. ``dynamical``: how to build the matrix.
    """

    def __init__(self, e_min: float = 1e-6, mass: float | None = None, method: str = "auto",
                 n_modes: int = 32, vectors: bool = True, dynamical: DynamicalMatrix | None = None):
        if not (math.isfinite(e_min) and e_min > 0):
            raise ValueError(f"e_min must be a finite positive number (eps/diameter^2), got {e_min!r}")
        if mass is not None and not (math.isfinite(mass) and mass > 0):
            raise ValueError(f"mass must be a finite positive number or None (M = N m), got {mass!r}")
        if method not in ("auto", "dense", "sparse"):
            raise ValueError(f"method must be 'auto', 'dense' or 'sparse', got {method!r}")
        if not (isinstance(n_modes, (int, np.integer)) and n_modes >= 1):
            raise ValueError(f"n_modes must be a positive integer, got {n_modes!r}")
        self.e_min, self.mass, self.method = float(e_min), mass, method
        self.n_modes, self.vectors = int(n_modes), bool(vectors)
        self.dynamical = dynamical or DynamicalMatrix()

    def compute(self, packing: Packing) -> SpectrumResult:
        return self.from_matrix(self.dynamical.compute(packing))

    def from_matrix(self, dyn: DynamicalMatrixResult) -> SpectrumResult:
        mass = float(dyn.n_total) if self.mass is None else self.mass
        dense = self.method == "dense" or (self.method == "auto" and dyn.n_dof <= DENSE_MAX_DOF)
        if dense or dyn.n_dof <= self.n_modes + 1:
            values, vecs = _dense(dyn.matrix, self.vectors)
            return SpectrumResult(values, vecs, dyn, self.e_min, mass, True)
        values, vecs = _sparse_lowest(dyn.matrix, self.n_modes, self.e_min)
        return SpectrumResult(values, vecs if self.vectors else None, dyn, self.e_min, mass, False)


def _dense(matrix, vectors: bool):
    a = matrix.toarray()
    a = 0.5 * (a + a.T)
    if vectors:
        return sla.eigh(a)
    return sla.eigh(a, eigvals_only=True), None


def _sparse_lowest(matrix, k: int, e_min: float):
    """Lowest modes by shift-invert about -e_min; doubles k until one mode exceeds e_min."""
    n = matrix.shape[0]
    while True:
        k = min(k, n - 2)
        values, vecs = spla.eigsh(matrix.tocsc(), k=k, sigma=-e_min, which="LM")
        order = np.argsort(values)
        values, vecs = values[order], vecs[:, order]
        if values[-1] > e_min or k >= n - 2:
            return values, vecs
        k *= 2


@dataclass(frozen=True)
class DensityOfStatesResult:
    """D(omega) in modes per unit omega per packing, on bins ``edges``."""

    edges: np.ndarray  # (bins + 1,)
    density: np.ndarray  # (bins,)
    n_packings: int
    n_modes: int  # nonzero modes over all packings

    @property
    def centers(self) -> np.ndarray:
        return 0.5 * (self.edges[1:] + self.edges[:-1])


class DensityOfStates:
    """Histogram D(omega) of the nonzero frequencies of complete spectra, averaged.
    ``bins``: number of equal-width bins on [0, ``omega_max``] (default: largest omega)."""

    def __init__(self, bins: int = 40, omega_max: float | None = None):
        if not (isinstance(bins, (int, np.integer)) and bins >= 1):
            raise ValueError(f"bins must be a positive integer, got {bins!r}")
        if omega_max is not None and not (math.isfinite(omega_max) and omega_max > 0):
            raise ValueError(f"omega_max must be a finite positive number or None, got {omega_max!r}")
        self.bins, self.omega_max = int(bins), omega_max

    def compute(self, spectra) -> DensityOfStatesResult:
        spectra = list(spectra)
        if not spectra:
            raise ValueError("DensityOfStates needs at least one spectrum")
        if not all(s.complete for s in spectra):
            raise ValueError("D(omega) needs complete spectra; compute them with Spectrum(method='dense')")
        omegas = np.concatenate([s.frequencies for s in spectra])
        top = self.omega_max or (omegas.max() if len(omegas) else 1.0)
        edges = np.linspace(0.0, top, self.bins + 1)
        counts, _ = np.histogram(omegas, edges)
        return DensityOfStatesResult(edges, counts / (len(spectra) * np.diff(edges)), len(spectra), len(omegas))


# --- stability along the lowest nontrivial mode ---------------------------------------------

STABLE, LOCALLY_STABLE, UNSTABLE = "mechanically stable", "locally stable", "unstable"


@dataclass(frozen=True)
class StabilityResult:
    """Class of a packing and the energy profile along its lowest nontrivial mode."""

    label: str  # STABLE | LOCALLY_STABLE | UNSTABLE
    n_zero: int  # |e| <= e_min, d trivial ones included
    n_negative: int  # e < -e_min
    mode_eigenvalue: float  # Rayleigh quotient of the mode, eps / diameter^2
    mode: np.ndarray  # (d N',) unit vector orthogonal to the translations
    deltas: np.ndarray  # amplitudes delta (diameters)
    delta_v_plus: np.ndarray  # V(xi_0 + delta e_1) - V(xi_0), total, eps
    delta_v_minus: np.ndarray  # V(xi_0 - delta e_1) - V(xi_0)
    power: float  # slope of log|symmetric part| vs log delta (nan when flat)
    flat: bool  # symmetric part below e_min delta^2 / 2 at every delta
    sign: int  # sign of the symmetric part at the largest delta (-1: energy decreases)

    @property
    def delta_v(self) -> np.ndarray:
        """Symmetric part (odd orders, e.g. a residual force, cancel)."""
        return 0.5 * (self.delta_v_plus + self.delta_v_minus)

    @property
    def behaviour(self) -> str:
        """'flat', '[negative ]quadratic', '[negative ]quartic' or '[negative ]power P'."""
        if self.flat:
            return "flat"
        prefix = "negative " if self.sign < 0 else ""
        for name, p in (("quadratic", 2.0), ("quartic", 4.0)):
            if abs(self.power - p) < 0.3:
                return prefix + name
        return f"{prefix}power {self.power:.2f}"


class Stability:
    """Classify a packing (seed section 3) with the Delta V(delta) evidence.

    ``deltas``: amplitudes (diameters) of the deformation xi_0 + delta e_1; None chooses
    delta_open * logspace(-2, -0.5, 7), delta_open being the amplitude at which the first
    contact would open or a near pair close (``opening_amplitude``): the harmonic regime.
    For disks and spheres a linear deformation along a zero mode only lengthens contacts at
    second order, so such a mode shows "flat" (or a negative stress term), never quartic.
    ``spectrum``: the ``Spectrum`` used (its e_min is the zero threshold).
    """

    def __init__(self, deltas=None, spectrum: Spectrum | None = None):
        if deltas is not None:
            deltas = np.asarray(deltas, float)
            if deltas.ndim != 1 or len(deltas) < 2 or not np.all(np.isfinite(deltas) & (deltas > 0)):
                raise ValueError("deltas must be at least two finite positive amplitudes (diameters)")
        self.deltas = deltas
        self.spectrum = spectrum or Spectrum()

    def compute(self, packing: Packing, spectrum: SpectrumResult | None = None) -> StabilityResult:
        spec = spectrum or self.spectrum.compute(packing)
        if spec.eigenvectors is None:
            raise ValueError("Stability needs eigenvectors: use Spectrum(vectors=True)")
        dyn = spec.dynamical
        value, mode = lowest_nontrivial_mode(spec)
        u = mode.reshape(-1, dyn.dim)
        deltas = self.deltas if self.deltas is not None else opening_amplitude(dyn.packing, u) * np.logspace(-2, -0.5, 7)
        plus = np.array([energy_change(dyn.packing, d * u) for d in deltas])
        minus = np.array([energy_change(dyn.packing, -d * u) for d in deltas])
        sym = 0.5 * (plus + minus)
        flat = bool(np.all(np.abs(sym) <= 0.5 * spec.e_min * deltas**2))
        power = float("nan") if flat else float(np.polyfit(np.log(deltas), np.log(np.abs(sym) + 1e-300), 1)[0])
        label = UNSTABLE if spec.n_negative else (LOCALLY_STABLE if spec.n_zero > spec.dim else STABLE)
        return StabilityResult(label, spec.n_zero, spec.n_negative, value, mode, deltas, plus, minus, power, flat,
                               int(np.sign(sym[-1])))


def lowest_nontrivial_mode(spec: SpectrumResult) -> tuple[float, np.ndarray]:
    """Lowest mode orthogonal to the d translations: Rayleigh-Ritz on the eigenvectors up to
    the first nonzero one (at least d + 1) with the translations projected out (a degenerate
    zero-mode subspace can mix translations into the solver's vectors)."""
    dyn = spec.dynamical
    t = dyn.translations()
    m = min(max(spec.dim + 1, spec.n_negative + spec.n_zero + 1), spec.eigenvectors.shape[1])
    v = spec.eigenvectors[:, :m]
    w = v - t @ (t.T @ v)
    basis, s, _ = np.linalg.svd(w, full_matrices=False)
    basis = basis[:, s > 0.5]
    if basis.shape[1] == 0:
        raise ValueError("no nontrivial mode: the packing has no degrees of freedom beyond translations")
    values, coeffs = np.linalg.eigh(basis.T @ (dyn.matrix @ basis))
    mode = basis @ coeffs[:, 0]
    return float(values[0]), mode / np.linalg.norm(mode)


def opening_amplitude(packing: Packing, u: np.ndarray) -> float:
    """Smallest amplitude delta at which the contact network changes when every particle
    moves by delta * u (diameters): a contact opens or a near pair closes to first order
    (|sigma - r| / |rate|), or a contact opens at second order by motion perpendicular to it
    (|du|^2 delta^2 / 2r reaching the overlap). Pairs up to 1.5 largest diameters are checked."""
    i, j = candidate_pairs(packing, 1.5 * packing.diameters.max())
    dr = separations(packing, i, j)
    r = np.linalg.norm(dr, axis=1)
    du = u[i] - u[j]
    gap = np.abs(contact_distances(packing, i, j) - r)
    rate = np.abs(np.einsum("pd,pd->p", dr, du)) / r
    curvature = np.where(r < contact_distances(packing, i, j), np.einsum("pd,pd->p", du, du) / (2.0 * r), 0.0)
    with np.errstate(divide="ignore"):
        first = np.where(rate > 0, gap / rate, np.inf)
        second = np.where(curvature > 0, np.sqrt(gap / curvature), np.inf)
    smallest = float(np.min(np.minimum(first, second), initial=np.inf))
    if not np.isfinite(smallest):
        raise ValueError("the mode moves no pair: it is a rigid translation, not a nontrivial mode")
    return smallest


_GAUSS_T, _GAUSS_W = np.polynomial.legendre.leggauss(12)


def energy_change(packing: Packing, displacement: np.ndarray) -> float:
    """V(x + u) - V(x), total energy in eps, summed pair by pair.

    Each pair's term is the integral of V'(s) from the old to the new distance (clipped at
    sigma_ij), with the distance change computed from u as (2 r.du + du.du) / (r + r'),
    so the result stays accurate when |u| is far below the overlaps, where subtracting two
    total energies loses every digit. 12-point Gauss-Legendre: exact for alpha = 2.
    """
    u = np.asarray(displacement, float).reshape(packing.n, packing.dim)
    reach = packing.diameters.max() + 2.0 * float(np.linalg.norm(u, axis=1).max())
    i, j = candidate_pairs(packing, reach)
    dr = separations(packing, i, j)
    du = u[i] - u[j]
    r = np.linalg.norm(dr, axis=1)
    r_new = np.linalg.norm(dr + du, axis=1)
    sigma = contact_distances(packing, i, j)
    change = (2.0 * np.einsum("pd,pd->p", dr, du) + np.einsum("pd,pd->p", du, du)) / (r + r_new)
    inside = (r < sigma) & (r_new < sigma)
    lo = np.minimum(r, sigma)
    length = np.where(inside, change, np.minimum(r_new, sigma) - lo)
    nodes = lo[:, None] + length[:, None] * 0.5 * (_GAUSS_T[None, :] + 1.0)
    slopes = packing.potential.dv_dr(nodes, sigma[:, None])
    return float(np.sum(0.5 * length * (slopes @ _GAUSS_W)))
