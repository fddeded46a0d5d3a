"""Normal modes, density of states and mechanical-stability class (chapter section 3).

Every shape: the dynamical matrix is over xi = (centres, d_k theta) (``hessian``), so its
d_f N' modes mix translations and rotations; ``SpectrumResult.translational_fraction`` is the
share of each eigenvector in the centre coordinates (the mode character; 1 - it is rotational).

- ``Spectrum``: eigenvalues e_i (eps / diameter^2) of the dynamical matrix over the
  non-floaters; dense for small systems, sparse shift-invert for the lowest modes of large
  ones. |e_i| <= e_min (default 1e-6, chapter ref. [28]) counts as zero; a periodic packing of any
  shape has d trivial zero modes (uniform translations; periodic boundaries break rotational
  invariance). Frequencies omega_i = sqrt(e_i / M) with M = N m, m = 1 (the chapter's definition,
  N including floaters), for e_i > e_min; unit mass and inertia m d_k^2, so xi has unit mass.
- ``DensityOfStates``: D(omega) = (N(omega + d omega) - N(omega)) / d omega, modes per unit
  frequency per packing, averaged over packings (chapter Figure 2.16); with eigenvectors (or their kept fractions) also its
  translational part (each mode weighted by its translational fraction).
- ``Stability``: mechanically stable (exactly d zero modes, none negative), stable at quartic
  order (every extra zero mode raises the energy as delta^4: hypostatic packings of ellipses
  at onset, chapter Figure 2.17), locally stable (other extra zero modes, chapter Figure 2.15b) or
  unstable (e_i < -e_min), with the evidence Delta V(delta) = V(xi_0 + delta e) - V(xi_0) along
  the lowest nontrivial modes and the power p of its symmetric part ~ delta^p (2 stable,
  4 quartic, "flat" for a floppy mode). Energy changes along a displacement:
  ``jamflow.mechanics.deformation``.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.linalg as sla

from jamflow.model.frames import canonical_signs
from jamflow.model.packing import Packing
from jamflow.analysis import quartic
from jamflow.mechanics.deformation import energy_change, network_amplitudes, opening_amplitude  # noqa: F401 (public here)
from jamflow.mechanics.dynamical_matrix import DynamicalMatrix, DynamicalMatrixResult
from jamflow.mechanics.eigen import lowest_eigenpairs
from jamflow.support.machine import check_bins
from jamflow.support.settings_errors import SettingError

DENSE_MAX_DOF = 4096  # above this many degrees of freedom "auto" uses the sparse solver


@dataclass(frozen=True)
class SpectrumResult:
    """Eigen-decomposition of one packing's dynamical matrix (ascending eigenvalues)."""

    eigenvalues: np.ndarray  #: (m,), eps / diameter^2; all d N' of them when complete
    eigenvectors: np.ndarray | None  #: (d N', m) orthonormal columns (signs: ``model.frames.canonical_signs``), or None
    dynamical: DynamicalMatrixResult  #: the matrix and the packing it was built from
    e_min: float  #: zero-mode threshold, eps / diameter^2
    mass: float  #: M in omega = sqrt(e / M): N m (N with floaters, m = 1) unless ``Spectrum(mass=...)``
    complete: bool  #: False: only the lowest m modes (sparse solver)
    #: the translational fractions kept by ``without_vectors`` (not compared, not in the repr)
    kept_fraction: np.ndarray | None = field(default=None, repr=False, compare=False)

    def __repr__(self) -> str:
        """One line: modes (of d_f N'), zero and negative counts, lowest nonzero e, e_min, vectors."""
        vectors = "None" if self.eigenvectors is None else str(self.eigenvectors.shape)
        return (f"SpectrumResult(modes={len(self.eigenvalues)}, n_dof={self.n_dof}, complete={self.complete}, "
                f"n_zero={self.n_zero}, n_negative={self.n_negative}, lowest_nonzero={self.lowest_nonzero:.4e}, "
                f"e_min={self.e_min:g}, eigenvectors={vectors})")

    def without_vectors(self) -> "SpectrumResult":
        """This spectrum without its eigenvectors ((d_f N')^2 numbers) but with their translational
        fractions (m numbers), so that figures and D(omega) still show each mode's character."""
        return replace(self, eigenvectors=None, kept_fraction=self.translational_fraction)

    @property
    def dim(self) -> int:
        """d, the packing's dimension (and the number of trivial translations)."""
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
        """Modes with e < -e_min: the packing is not at an energy minimum when there are any."""
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
        """The smallest eigenvalue above e_min, eps / diameter^2 (nan when there is none)."""
        values = self.nonzero
        return float(values[0]) if len(values) else float("nan")

    @property
    def frequencies(self) -> np.ndarray:
        """omega_i = sqrt(e_i / M) of the nonzero modes, ascending (units sqrt(eps/m)/diameter)."""
        return np.sqrt(self.nonzero / self.mass)

    @property
    def translational_fraction(self) -> np.ndarray | None:
        """(m,) share of each eigenvector in the centre coordinates (None without vectors, unless
        ``without_vectors`` kept it): 1 for every mode of disks and spheres, between 0 (purely
        rotational) and 1 otherwise."""
        if self.eigenvectors is None:
            return self.kept_fraction
        return self.dynamical.translational_fraction(self.eigenvectors)

    @property
    def translation_residual(self) -> float:
        """max |M T| over the exact translations T: ~1e-16 |M| if the matrix is periodic-exact."""
        m = self.dynamical.matrix
        return float(np.abs(m @ self.dynamical.translations()).max()) if m.shape[0] else 0.0


@dataclass(frozen=True)
class Branch:
    """One branch of the sorted spectrum: its modes' count, frequency range sqrt(|e| / M) and
    mean translational fraction."""

    name: str  #: "1 zero", "2 rotational" or "3 translational" (``BRANCH_NAMES``)
    count: int  #: modes in the branch
    omega_low: float  #: lowest sqrt(|e| / M) in the branch (nan when empty)
    omega_high: float  #: highest sqrt(|e| / M) in the branch (nan when empty)
    translational: float  #: mean translational fraction of its modes (nan when empty)


BRANCH_NAMES = ("1 zero", "2 rotational", "3 translational")


def branch_labels(spec: SpectrumResult) -> np.ndarray | None:
    """Per mode 1, 2 or 3, the branch of the spectrum of particles that turn (chapter Figure 2.17):
    1 the nontrivial zero modes (|e| <= e_min: the quartic modes at onset), 2 the nonzero modes
    that are mostly rotational (translational fraction < 1/2), 3 the mostly translational ones;
    0 for the d trivial translations (the zero modes of largest translational fraction). None
    for disks/spheres, or without eigenvectors or a complete spectrum."""
    fraction = spec.translational_fraction
    if not spec.dynamical.packing.shape.oriented or fraction is None or not spec.complete:
        return None
    zero = np.abs(spec.eigenvalues) <= spec.e_min
    labels = np.where(zero, 1, np.where(fraction < 0.5, 2, 3))
    k = np.flatnonzero(zero)
    labels[k[np.argsort(fraction[k], kind="stable")[max(len(k) - spec.dim, 0):]]] = 0
    return labels


def branches(spec: SpectrumResult) -> list[Branch] | None:
    """The three branches (``branch_labels``) with their counts, frequency ranges and mean
    translational fractions; None where there are no branches."""
    labels = branch_labels(spec)
    if labels is None:
        return None
    omega, fraction = np.sqrt(np.abs(spec.eigenvalues) / spec.mass), spec.translational_fraction
    out = []
    for b, name in enumerate(BRANCH_NAMES, 1):
        k = labels == b
        out.append(Branch(name, int(k.sum()), float(omega[k].min()) if k.any() else math.nan,
                          float(omega[k].max()) if k.any() else math.nan,
                          float(fraction[k].mean()) if k.any() else math.nan))
    return out


class Spectrum:
    """Eigenvalues (and vectors) of the dynamical matrix.

    ``e_min``: zero-mode threshold (eps / diameter^2). ``mass``: M in omega = sqrt(e / M),
    None for the chapter's M = N m (m = 1). ``method``: "auto" (dense up to 4096 DOF), "dense"
    or "sparse" (shift-invert about -e_min for the ``n_modes`` lowest modes, enlarged until
    the zero modes are bracketed; eigenvalues far below -e_min can be missed there).
    ``vectors``: keep eigenvectors. ``dynamical``: how to build the matrix.

    Parameters
    ----------
    e_min : float, default 1e-6
        Eigenvalues with |e| <= e_min are zero modes, eps / diameter^2 (> 0).
    mass : float, optional
        M in omega = sqrt(e / M); None: M = N m with m = 1 and N counting floaters (the
        chapter's convention); 1.0: the per-particle omega = sqrt(e).
    method : {"auto", "dense", "sparse"}, default "auto"
        Dense (all d_f N' modes) up to 4096 degrees of freedom under "auto", else sparse.
    n_modes : int, default 32
        Modes the sparse solver starts with (>= 1); enlarged until the zero modes are bracketed.
    vectors : bool, default True
        Keep the eigenvectors (needed for branches, translational fractions and mode profiles).
    dynamical : DynamicalMatrix, optional
        How the matrix is built (default ``DynamicalMatrix()``).

    Raises
    ------
    ValueError
        A bad ``e_min``, ``mass`` (``SettingError``), ``method`` or ``n_modes``.
    """

    def __init__(self, e_min: float = 1e-6, mass: float | None = None, method: str = "auto",
                 n_modes: int = 32, vectors: bool = True, dynamical: DynamicalMatrix | None = None):
        if not (math.isfinite(e_min) and e_min > 0):
            raise SettingError("e_min", f"must be a finite positive number (eps/diameter^2), got {e_min!r}")
        if mass is not None and not (math.isfinite(mass) and mass > 0):
            raise SettingError("mass", f"must be a finite positive number or None (M = N m), got {mass!r}")
        if method not in ("auto", "dense", "sparse"):
            raise ValueError(f"method must be 'auto', 'dense' or 'sparse', got {method!r}")
        if not (isinstance(n_modes, (int, np.integer)) and n_modes >= 1):
            raise ValueError(f"n_modes must be a positive integer, got {n_modes!r}")
        self.e_min, self.mass, self.method = float(e_min), mass, method
        self.n_modes, self.vectors = int(n_modes), bool(vectors)
        self.dynamical = dynamical or DynamicalMatrix()

    def compute(self, packing: Packing) -> SpectrumResult:
        """The spectrum of ``packing``'s dynamical matrix (floaters removed, rotations as d_k theta).

        Parameters
        ----------
        packing : jamflow.Packing
            A packing at an energy minimum (lengths in diameters, energies in eps).

        Returns
        -------
        SpectrumResult
            Ascending eigenvalues (eps / diameter^2), eigenvectors when kept, and M.
        """
        return self.from_matrix(self.dynamical.compute(packing))

    def from_matrix(self, dyn: DynamicalMatrixResult) -> SpectrumResult:
        """The spectrum of a dynamical matrix already built (``DynamicalMatrix.compute``)."""
        mass = float(dyn.n_total) if self.mass is None else self.mass
        dense = self.method == "dense" or (self.method == "auto" and dyn.n_dof <= DENSE_MAX_DOF)
        if dense or dyn.n_dof <= self.n_modes + 1:
            values, vecs = _dense(dyn.matrix, self.vectors)
            return SpectrumResult(values, vecs, dyn, self.e_min, mass, True)
        # shift-invert about -e_min, k doubled until one mode exceeds e_min (the zero modes bracketed)
        values, vecs = lowest_eigenpairs(dyn.matrix, self.n_modes, self.e_min, grow_above=self.e_min)
        return SpectrumResult(values, vecs if self.vectors else None, dyn, self.e_min, mass, False)


def _dense(matrix, vectors: bool):
    a = matrix.toarray()
    a = 0.5 * (a + a.T)
    if vectors:
        values, vecs = sla.eigh(a)
        return values, canonical_signs(vecs)
    return sla.eigh(a, eigvals_only=True), None


@dataclass(frozen=True)
class DensityOfStatesResult:
    """D(omega) in modes per unit omega per packing, on bins ``edges``."""

    edges: np.ndarray  #: (bins + 1,)
    density: np.ndarray  #: (bins,) modes per unit omega per packing
    n_packings: int  #: spectra pooled
    n_modes: int  #: nonzero modes over all packings
    translational: np.ndarray | None = None  #: (bins,) part of D carried by centre motion; None without vectors

    def __repr__(self) -> str:
        """One line: bins and their range, packings, modes, whether the translational part is known."""
        return (f"DensityOfStatesResult(bins={len(self.density)}, omega=[{self.edges[0]:.4g}, {self.edges[-1]:.4g}], "
                f"n_packings={self.n_packings}, n_modes={self.n_modes}, "
                f"translational={'yes' if self.translational is not None else 'None'})")

    @property
    def rotational(self) -> np.ndarray | None:
        """(bins,) part of D carried by rotations (D - translational)."""
        return None if self.translational is None else self.density - self.translational

    @property
    def centers(self) -> np.ndarray:
        """(bins,) omega at the middle of each bin."""
        return 0.5 * (self.edges[1:] + self.edges[:-1])

    @property
    def normalized(self) -> np.ndarray:
        """(bins,) D(omega) as a probability density over omega: ``density`` / (modes per packing),
        all nonzero modes counted, so that sum(normalized * bin widths) = ``fraction_in_range``
        (1 when the bins cover every mode; nan without modes)."""
        return self.density * self.n_packings / self.n_modes if self.n_modes else np.full(len(self.density), np.nan)

    @property
    def n_in_range(self) -> int:
        """Nonzero modes, over all packings, inside the bins [0, omega_max]."""
        return int(round(float(np.sum(self.density * np.diff(self.edges))) * self.n_packings))

    @property
    def fraction_in_range(self) -> float:
        """Share of all nonzero modes inside the bins: the integral of ``normalized`` (nan without modes)."""
        return self.n_in_range / self.n_modes if self.n_modes else math.nan


class DensityOfStates:
    """Histogram D(omega) of the nonzero frequencies of complete spectra, averaged.
    ``bins``: number of equal-width bins on [0, ``omega_max``] (default: largest omega). An
    ``omega_max`` below the largest omega leaves modes out of the bins, with a warning: D stays
    normalised over all modes and integrates to ``fraction_in_range``.

    Parameters
    ----------
    bins : int, default 40
        Number of equal-width bins (>= 1).
    omega_max : float, optional
        Upper edge of the bins, in the units of omega = sqrt(e / M) (M = N m by default); None:
        the largest omega.

    Raises
    ------
    ValueError
        A ``bins`` that is not a positive integer or too many, or a bad ``omega_max``
        (``SettingError``).
    """

    def __init__(self, bins: int = 40, omega_max: float | None = None):
        if not (isinstance(bins, (int, np.integer)) and bins >= 1):
            raise SettingError("bins", f"must be a positive integer, got {bins!r}")
        check_bins(bins, f"--bins {bins}", "give fewer")
        if omega_max is not None and not (math.isfinite(omega_max) and omega_max > 0):
            raise SettingError("omega_max", f"must be a finite positive number or None, got {omega_max!r}")
        self.bins, self.omega_max = int(bins), omega_max

    def compute(self, spectra) -> DensityOfStatesResult:
        """D(omega) over ``spectra``: histogram of their nonzero omega / (bin width x number of spectra).

        Parameters
        ----------
        spectra : iterable of SpectrumResult
            Complete spectra (dense), one per packing; omega = sqrt(e / M) with each spectrum's M.

        Returns
        -------
        DensityOfStatesResult
            D(omega) in modes per unit omega per packing, with its translational part when
            every spectrum has eigenvectors.

        Raises
        ------
        ValueError
            No spectra, or a spectrum that is not complete.
        """
        spectra = list(spectra)
        if not spectra:
            raise ValueError("DensityOfStates needs at least one spectrum")
        if not all(s.complete for s in spectra):
            raise ValueError("D(omega) needs complete spectra; compute them with Spectrum(method='dense')")
        omegas = np.concatenate([s.frequencies for s in spectra])
        top = self.omega_max or (omegas.max() if len(omegas) else 1.0)
        edges = np.linspace(0.0, top, self.bins + 1)
        norm = len(spectra) * np.diff(edges)
        counts, _ = np.histogram(omegas, edges)
        translational = None
        if all(s.translational_fraction is not None for s in spectra):
            weights = np.concatenate([s.translational_fraction[s.eigenvalues > s.e_min] for s in spectra])
            translational = np.histogram(omegas, edges, weights=weights)[0] / norm
        result = DensityOfStatesResult(edges, counts / norm, len(spectra), len(omegas), translational)
        if result.n_in_range < result.n_modes:
            warnings.warn(f"omega_max (--omega-max) {top:g} leaves {result.n_modes - result.n_in_range} of "
                          f"{result.n_modes} nonzero modes out of D(omega) (the largest omega is {omegas.max():.4g}): "
                          f"D, normalised over all modes, integrates to {result.fraction_in_range:.4g} over [0, "
                          f"{top:g}]; a larger omega_max covers them", stacklevel=2)
        return result


# --- stability along the lowest nontrivial modes ---------------------------------------------

STABLE, LOCALLY_STABLE, UNSTABLE = "mechanically stable", "locally stable", "unstable"
QUARTIC_STABLE = "stable at quartic order"
HARMONIC, BEYOND_OPENING = "harmonic", "beyond opening"  # the amplitude ranges (``ModeProfile.regime``)


@dataclass(frozen=True)
class ModeProfile:
    """Energy profile Delta V(delta) along one nontrivial mode."""

    eigenvalue: float  #: Rayleigh quotient of the mode, eps / diameter^2
    mode: np.ndarray  #: (d_f N',) unit vector orthogonal to the translations (sign: ``model.frames.canonical_signs``)
    deltas: np.ndarray  #: amplitudes delta (diameters)
    delta_v_plus: np.ndarray  #: V(xi_0 + delta e) - V(xi_0), total, eps
    delta_v_minus: np.ndarray  #: V(xi_0 - delta e) - V(xi_0), eps
    power: float  #: slope of log|symmetric part| vs log delta (zero modes: the part beyond e delta^2/2; nan if flat)
    flat: bool  #: symmetric part below e_min delta^2 / 2 at every delta
    sign: int  #: sign of the symmetric part at the largest delta (-1: energy decreases)
    regime: str  #: HARMONIC (below the first contact opening) or BEYOND_OPENING (zero modes)
    translational_fraction: float  #: share of |e|^2 in the centre coordinates
    participation: float  #: 1 / sum_k w_k^2, w_k particle k's share of |e|^2: particles taking part (1 to N')
    quartic_straight: float = float("nan")  #: zero modes: fourth-order coefficient along the line (``quartic``)
    quartic_relaxed: float = float("nan")  #: ... and its minimum over curved paths; nan: not computed

    def __repr__(self) -> str:
        """One line: eigenvalue, behaviour, power, character, participation, amplitudes."""
        return (f"ModeProfile(eigenvalue={self.eigenvalue:.4e}, behaviour={self.behaviour!r}, power={self.power:.3g}, "
                f"translational_fraction={self.translational_fraction:.3f}, participation={self.participation:.2f}, "
                f"deltas={len(self.deltas)})")

    @property
    def delta_v(self) -> np.ndarray:
        """Symmetric part (odd orders, e.g. a residual force, cancel)."""
        return 0.5 * (self.delta_v_plus + self.delta_v_minus)

    @property
    def behaviour(self) -> str:
        """'flat', '[negative ]quadratic', '[negative ]quartic' or '[negative ]power P'; a zero
        mode whose relaxed fourth-order coefficient is positive is 'quartic' (``quartic``)."""
        if self.flat:
            return "flat"
        if math.isfinite(self.quartic_relaxed):
            return "quartic"
        prefix = "negative " if self.sign < 0 else ""
        for name, p in (("quadratic", 2.0), ("quartic", 4.0)):
            if abs(self.power - p) < 0.3:
                return prefix + name
        return f"{prefix}power {self.power:.2f}"


@dataclass(frozen=True)
class StabilityResult:
    """Class of a packing and the energy profiles along its lowest nontrivial modes; the
    fields ``mode_eigenvalue`` ... ``sign`` describe the lowest one (``profiles[0]``)."""

    label: str  #: STABLE | QUARTIC_STABLE | LOCALLY_STABLE | UNSTABLE
    n_zero: int  #: |e| <= e_min, d trivial ones included
    n_negative: int  #: e < -e_min
    mode_eigenvalue: float  #: the lowest nontrivial mode's Rayleigh quotient, eps / diameter^2
    mode: np.ndarray  #: (d_f N',) that mode, a unit vector orthogonal to the translations
    deltas: np.ndarray  #: amplitudes delta along it (diameters)
    delta_v_plus: np.ndarray  #: V(xi_0 + delta e) - V(xi_0), total, eps
    delta_v_minus: np.ndarray  #: V(xi_0 - delta e) - V(xi_0), eps
    power: float  #: fitted power of its energy profile (``ModeProfile.power``; nan if flat)
    flat: bool  #: its energy profile is flat (``ModeProfile.flat``)
    sign: int  #: sign of its symmetric energy change at the largest delta (-1: the energy decreases)
    profiles: tuple = ()  #: ModeProfile per profiled mode, ascending eigenvalue

    def __repr__(self) -> str:
        """One line: class, zero and negative modes, the lowest mode's eigenvalue and behaviour, profiles."""
        behaviour = self.behaviour if self.profiles else "none"
        return (f"StabilityResult(label={self.label!r}, n_zero={self.n_zero}, n_negative={self.n_negative}, "
                f"mode_eigenvalue={self.mode_eigenvalue:.4e}, behaviour={behaviour!r}, profiles={len(self.profiles)}, "
                f"n_quartic={self.n_quartic})")

    @property
    def delta_v(self) -> np.ndarray:
        """Symmetric part of the lowest mode's energy change, (delta_v_plus + delta_v_minus) / 2, eps."""
        return 0.5 * (self.delta_v_plus + self.delta_v_minus)

    @property
    def behaviour(self) -> str:
        """The lowest profiled mode's behaviour (``ModeProfile.behaviour``)."""
        return self.profiles[0].behaviour

    @property
    def behaviours(self) -> list[str]:
        """The behaviour of every profiled mode, ascending eigenvalue."""
        return [p.behaviour for p in self.profiles]

    @property
    def n_quartic(self) -> int:
        """Profiled modes whose energy rises as delta^4 (chapter Figure 2.17, branch 1)."""
        return sum(b == "quartic" for b in self.behaviours)

    @property
    def n_single_flat(self) -> int:
        """Profiled flat modes carried by about one particle (participation < 1.5): a particle
        free to move or turn alone, e.g. a dimer whose contacts all lie on one of its sites."""
        return sum(p.flat and p.participation < 1.5 for p in self.profiles)


class Stability:
    """Classify a packing (chapter section 3) with the Delta V(delta) evidence.

    ``n_modes``: how many of the lowest nontrivial modes to profile; "zero" (default): every
    nontrivial zero mode (|e| <= e_min) and the lowest nonzero one. ``deltas``: amplitudes
    (diameters) of xi_0 + delta e, or None to choose them per mode: for nonzero modes the
    harmonic regime delta_open * logspace(-2, -0.5, 7), delta_open being the amplitude at which
    the contact network first changes (``opening_amplitude``); for zero modes the range
    beyond it, top * logspace(-1.5, 0, 7) with top = min(0.1 delta_close, 0.03), delta_close the
    amplitude at which a pair not in contact would touch (to second order). A zero mode's energy
    shows there what holds it (its power is fitted to Delta V - e delta^2 / 2, the part beyond
    its sub-threshold quadratic term): contacts that open (disks, spheres: "flat") or contacts that overlap at second
    order, Delta V ~ delta^4 ("quartic": the just-touching limit of ellipse packings, chapter
    Figure 2.17). Moving along a mode moves centres by delta u and turns particles by
    delta (d_k theta) / d_k. Class: unstable if any e < -e_min; mechanically stable if exactly
    d zero modes; stable at quartic order if every extra zero mode was profiled and is quartic;
    locally stable otherwise. ``spectrum``: the ``Spectrum`` used (its e_min is the threshold).

    Parameters
    ----------
    deltas : array_like, optional
        At least two positive amplitudes (diameters), the same for every mode; None: per mode.
    spectrum : Spectrum, optional
        How spectra are computed (default ``Spectrum()``); it must keep eigenvectors.
    n_modes : int or "zero", default "zero"
        Lowest nontrivial modes to profile (>= 1), or every nontrivial zero mode and the
        lowest nonzero one.
    relaxed : bool, default True
        Compute the fourth-order coefficients of zero modes (``analysis.quartic``), which
        decide "quartic" and "flat".

    Raises
    ------
    ValueError
        Bad ``deltas`` or ``n_modes``.
    """

    def __init__(self, deltas=None, spectrum: Spectrum | None = None, n_modes="zero", relaxed: bool = True):
        if deltas is not None:
            deltas = np.asarray(deltas, float)
            if deltas.ndim != 1 or len(deltas) < 2 or not np.all(np.isfinite(deltas) & (deltas > 0)):
                raise ValueError("deltas must be at least two finite positive amplitudes (diameters)")
        if n_modes != "zero" and not (isinstance(n_modes, (int, np.integer)) and n_modes >= 1):
            raise ValueError(f"n_modes must be a positive integer or 'zero' (every zero mode), got {n_modes!r}")
        self.deltas = deltas
        self.spectrum = spectrum or Spectrum()
        self.n_modes = n_modes
        self.relaxed = bool(relaxed)

    def compute(self, packing: Packing, spectrum: SpectrumResult | None = None) -> StabilityResult:
        """Class of ``packing`` and the energy profiles along its lowest nontrivial modes.

        Parameters
        ----------
        packing : jamflow.Packing
            A packing at an energy minimum (lengths in diameters).
        spectrum : SpectrumResult, optional
            Its spectrum with eigenvectors, if already computed; None: computed here.

        Returns
        -------
        StabilityResult
            The label (mechanically stable, stable at quartic order, locally stable or
            unstable) and one ``ModeProfile`` per profiled mode.

        Raises
        ------
        ValueError
            The spectrum has no eigenvectors.
        """
        spec = spectrum or self.spectrum.compute(packing)
        if spec.eigenvectors is None:
            raise ValueError("Stability needs eigenvectors: use Spectrum(vectors=True)")
        count = None if self.n_modes == "zero" else int(self.n_modes)
        values, modes = lowest_nontrivial_modes(spec, count)
        profiles = tuple(self.profile(spec, value, mode) for value, mode in zip(values, modes.T))
        first = profiles[0]
        return StabilityResult(self.classify(spec, profiles), spec.n_zero, spec.n_negative, first.eigenvalue,
                               first.mode, first.deltas, first.delta_v_plus, first.delta_v_minus, first.power,
                               first.flat, first.sign, profiles)

    @staticmethod
    def classify(spec: SpectrumResult, profiles) -> str:
        """The class label of a spectrum and its mode profiles (the rule in the class docstring)."""
        if spec.n_negative:
            return UNSTABLE
        if spec.n_zero <= spec.dim:
            return STABLE
        zero = [p for p in profiles if abs(p.eigenvalue) <= spec.e_min]
        if len(zero) == spec.n_extra_zero and all(p.behaviour == "quartic" for p in zero):
            return QUARTIC_STABLE
        return LOCALLY_STABLE

    def profile(self, spec: SpectrumResult, value: float, mode: np.ndarray) -> ModeProfile:
        """Delta V(delta) along ``mode`` (eigenvalue ``value``, eps / diameter^2) at this object's amplitudes."""
        dyn = spec.dynamical
        u, w = dyn.coordinates.split(mode)
        zero = abs(value) <= spec.e_min
        deltas = self.deltas
        if deltas is None:
            if zero:
                closing = network_amplitudes(dyn.packing, u, w)[1]
                deltas = min(0.1 * closing, 0.03) * np.logspace(-1.5, 0, 7)
            else:
                deltas = opening_amplitude(dyn.packing, u, w) * np.logspace(-2, -0.5, 7)
        plus = np.array([energy_change(dyn.packing, d * u, d * w) for d in deltas])
        minus = np.array([energy_change(dyn.packing, -d * u, -d * w) for d in deltas])
        sym = 0.5 * (plus + minus)
        flat = bool(np.all(np.abs(sym) <= 0.5 * spec.e_min * deltas**2))
        straight = relaxed = float("nan")
        if zero and self.relaxed:
            null = spec.eigenvectors[:, np.abs(spec.eigenvalues) <= spec.e_min]
            straight, relaxed = quartic.quartic_coefficients(dyn.packing, mode, null)
            if math.isfinite(relaxed):
                flat = bool(relaxed <= quartic.RELAXED_TOL * straight)  # free to fourth order
        # a zero mode's quadratic part e delta^2 / 2 is below the threshold: fit what lies beyond it
        beyond = sym - 0.5 * value * deltas**2 if zero else sym
        power = float("nan") if flat else float(np.polyfit(np.log(deltas), np.log(np.abs(beyond) + 1e-300), 1)[0])
        weight = np.sum(u**2, axis=1) + np.sum(w**2, axis=1)
        return ModeProfile(value, mode, deltas, plus, minus, power, flat, int(np.sign(sym[-1])),
                           BEYOND_OPENING if zero and self.deltas is None else HARMONIC,
                           float(dyn.translational_fraction(mode)[0]), float(1.0 / np.sum(weight**2)),
                           straight, relaxed)


def lowest_nontrivial_modes(spec: SpectrumResult, count: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The lowest modes orthogonal to the d translations, ascending: Rayleigh-Ritz on the
    eigenvectors up to the first nonzero one (at least d + 1; ``count`` more if asked) with the
    translations projected out (a degenerate zero-mode subspace can mix translations into the
    solver's vectors). ``count`` None: every nontrivial mode up to the first nonzero one."""
    dyn = spec.dynamical
    t = dyn.translations()
    m = max(spec.dim + 1, spec.n_negative + spec.n_zero + 1)
    if count is not None:
        m = max(m, spec.dim + count)
    m = min(m, spec.eigenvectors.shape[1])
    v = spec.eigenvectors[:, :m]
    w = v - t @ (t.T @ v)
    basis, s, _ = np.linalg.svd(w, full_matrices=False)
    basis = basis[:, s > 0.5]
    if basis.shape[1] == 0:
        raise ValueError("no nontrivial mode: the packing has no degrees of freedom beyond translations")
    values, coeffs = np.linalg.eigh(basis.T @ (dyn.matrix @ basis))
    modes = basis @ coeffs
    modes = canonical_signs(modes / np.linalg.norm(modes, axis=0))
    keep = len(values) if count is None else min(count, len(values))
    return values[:keep], modes[:, :keep]


def lowest_nontrivial_mode(spec: SpectrumResult) -> tuple[float, np.ndarray]:
    """The lowest mode orthogonal to the d translations (``lowest_nontrivial_modes``)."""
    values, modes = lowest_nontrivial_modes(spec, 1)
    return float(values[0]), modes[:, 0]
