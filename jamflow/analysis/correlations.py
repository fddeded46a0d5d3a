"""Spatial correlations and correlation lengths (chapter section 4.4, Figures 2.27-2.29).

- Envelope of g(r) - 1: its local maxima beyond the first neighbour shell decay as
  exp(-r / xi) (Figure 2.28b).
- Bond-orientational correlations from the per-particle Q_i of ``order.particle_bond_order``
  (2D: q6^i = psi_6(i); 3D: sqrt(4 pi/13) q_6m(i)), binned over pairs i != j at distance r:
  complex  <q6(r) q6*(0)> = <Re Q_i . conj(Q_j)>  (the conjugate makes it real and phase-
  sensitive; the chapter writes q6(r) q6(0)),
  magnitude <|q6(r)| |q6(0)|> = <|Q_i| |Q_j|>,
  C(r) = |<q6(r) q6*(0)> - <q6(inf) q6*(0)>|, where the r -> inf value is estimated by the
  mean of Re Q_i . conj(Q_j) over *all* distinct pairs of the packing (its large-r limit for
  a homogeneous system). The local maxima of C(r) give xi (Figure 2.28a).
Exponential fits are least squares on log(y) against r (straight lines on the chapter's
semi-log plots). Maxima are used from the first neighbour minimum outwards until the first
one that is not 3 statistical errors above zero. r in units of <sigma^2>^(1/2), float64.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable

import numpy as np
from scipy.ndimage import gaussian_filter1d
from scipy.signal import find_peaks

from jamflow.model.packing import Packing
from jamflow.analysis.order import even_degree, first_minimum, particle_bond_order
from jamflow.analysis.structure import (UNITS_R, RDF, RDFResult, as_packings, check_r_max, max_reduced_radius, pair_chunks,
                        positive, radial_edges, rms_contact_distance)


# --- exponential envelope fits --------------------------------------------------------------
@dataclass(frozen=True)
class ExponentialFit:
    """y ~ amplitude * exp(-r / xi) through the local maxima (r_points, y_points).

    ``xi`` is inf when the maxima do not decay (a crystal) and NaN with fewer than 3
    significant maxima (then ``reason`` says why)."""

    xi: float  #: correlation length, in the units of r (<sigma^2>^(1/2)); inf: no decay, nan: no fit
    xi_stderr: float  #: its standard error from the least-squares line (nan without a fit)
    amplitude: float  #: y at r = 0 of the fitted exponential
    r_points: np.ndarray  #: positions of the maxima fitted
    y_points: np.ndarray  #: their heights
    reason: str = ""  #: why there is no finite xi ("" when there is one)

    def __repr__(self) -> str:
        """One line: xi, its error, amplitude, points, the reason (if any)."""
        return (f"ExponentialFit(xi={self.xi:.4g}, xi_stderr={self.xi_stderr:.2g}, amplitude={self.amplitude:.4g}, "
                f"points={len(self.r_points)}" + (f", reason={self.reason!r})" if self.reason else ")"))


def fit_exponential(r, y) -> ExponentialFit:
    """Least-squares line through (r, log y); y > 0 required; xi = -1/slope."""
    r, y = np.asarray(r, float), np.asarray(y, float)
    if len(r) < 3:
        return ExponentialFit(math.nan, math.nan, math.nan, r, y, f"only {len(r)} significant maxima (need 3)")
    if np.any(y <= 0):
        raise ValueError("exponential fit needs positive values")
    (slope, intercept), cov = np.polyfit(r, np.log(y), 1, cov=True)
    if slope >= 0:
        return ExponentialFit(math.inf, math.nan, float(np.exp(intercept)), r, y, "maxima do not decay")
    xi = -1.0 / slope
    return ExponentialFit(float(xi), float(math.sqrt(cov[0, 0]) * xi * xi), float(np.exp(intercept)), r, y)


def envelope_fit(r, y, noise, r_from: float, min_separation: float = 0.5, snr: float = 3.0) -> ExponentialFit:
    """Fit exp(-r/xi) through the local maxima of ``y`` at r >= r_from that stand ``snr``
    statistical errors (``noise``, per point) above zero; stops at the first maximum that
    does not. Maxima closer than ``min_separation`` (units of r) are merged (largest kept)."""
    r, y, noise = (np.asarray(a, float) for a in (r, y, noise))
    dr = float(r[1] - r[0])
    peaks, _ = find_peaks(np.nan_to_num(y, nan=-np.inf), distance=max(1, int(round(min_separation / dr))))
    peaks = peaks[r[peaks] >= r_from]
    significant = y[peaks] > snr * noise[peaks]
    cut = len(peaks) if np.all(significant) else int(np.argmin(significant))
    peaks = peaks[:cut]
    return fit_exponential(r[peaks], y[peaks])


def rdf_correlation_length(rdf: RDFResult, r_min: float | None = None, smooth: float = 0.05) -> ExponentialFit:
    """xi from the local maxima of g(r) - 1 beyond the first minimum r_min (Figure 2.28b).
    g is smoothed over ``smooth`` (units of <sigma^2>^(1/2)) before maxima are located."""
    r_min = first_minimum(rdf, smooth) if r_min is None else float(r_min)
    window = max(smooth / rdf.dr, 1e-9)
    gs = gaussian_filter1d(rdf.g, window, mode="nearest")
    noise = rdf.stderr / math.sqrt(max(1.0, window * math.sqrt(2 * math.pi)))
    return envelope_fit(rdf.r, gs - 1.0, noise, r_min)


class PairCorrelationLength:
    """``compute(packings)``: xi from the g(r) - 1 envelope of a packing or an ensemble.

    Parameters
    ----------
    dr : float, default 0.02
        Bin width of g(r), units of <sigma^2>^(1/2).
    r_min : float, optional
        Where the fitted maxima start (same units); None: the first minimum of g(r).
    smooth : float, default 0.05
        Width of the Gaussian that smooths g(r) before its maxima are located (same units).
    """

    def __init__(self, dr: float = 0.02, r_min: float | None = None, smooth: float = 0.05):
        self.rdf, self.smooth = RDF(dr=dr), positive("smooth", smooth, UNITS_R)
        self.r_min = None if r_min is None else positive("r_min", r_min, UNITS_R)

    def compute(self, packings: Packing | Iterable[Packing]) -> ExponentialFit:
        """xi of ``packings`` (one or an ensemble): an exponential through the maxima of g(r) - 1 beyond r_min
        that stand 3 statistical errors above zero (``rdf_correlation_length``)."""
        return rdf_correlation_length(self.rdf.compute(packings), self.r_min, self.smooth)


# --- bond-orientational correlations ---------------------------------------------------------
@dataclass(frozen=True)
class BondCorrelationResult:
    """q_l spatial correlations on bins of r / <sigma^2>^(1/2), pooled over packings."""

    edges: np.ndarray  #: (nbins + 1,) bin edges, units of <sigma^2>^(1/2)
    complex_corr: np.ndarray  #: <Re Q_i . conj(Q_j)> per bin (NaN where no pairs)
    magnitude_corr: np.ndarray  #: <|Q_i| |Q_j|> per bin
    complex_stderr: np.ndarray  #: standard error of complex_corr (pairs treated as independent)
    counts: np.ndarray  #: pairs per bin
    baseline: float  #: <Re Q_i . conj(Q_j)> over all distinct pairs: the r -> inf value
    r_min: float  #: neighbour cutoff used for Q_i
    l: int  #: the degree of q_l (even)
    n_packings: int  #: packings pooled
    fit: ExponentialFit  #: xi from the local maxima of C(r)

    def __repr__(self) -> str:
        """One line: l, bins, r range, packings, baseline, the fitted length."""
        return (f"BondCorrelationResult(l={self.l}, bins={len(self.counts)}, r=[{self.edges[0]:.4g}, "
                f"{self.edges[-1]:.4g}], n_packings={self.n_packings}, baseline={self.baseline:.4g}, "
                f"xi={self.fit.xi:.4g})")

    @property
    def r(self) -> np.ndarray:
        """(nbins,) bin centres, units of <sigma^2>^(1/2)."""
        return 0.5 * (self.edges[1:] + self.edges[:-1])

    @property
    def c(self) -> np.ndarray:
        """C(r) = |<q(r) q*(0)> - <q(inf) q*(0)>| (Figure 2.28a, 2.29)."""
        return np.abs(self.complex_corr - self.baseline)


class BondCorrelation:
    """Complex and magnitude q_l correlation functions and their length (chapter section 4.4).

    ``r_min`` (neighbour cutoff, units of <sigma^2>^(1/2)): None = first minimum of the
    ensemble's g(r). ``dr``, ``r_max``: binning of the correlation functions (same units;
    r_max defaults to half the shortest box width).

    Parameters
    ----------
    l : int, default 6
        The degree (even, >= 0).
    r_min : float, optional
        Neighbour cutoff of q_l, units of <sigma^2>^(1/2); None: the first minimum of g(r).
    dr : float, default 0.1
        Bin width of the correlation functions, same units.
    r_max : float, optional
        Their largest r, at most half the shortest box width (the default).
    """

    def __init__(self, l: int = 6, r_min: float | None = None, dr: float = 0.1, r_max: float | None = None):
        self.l, self.dr = even_degree(l), positive("dr", dr, UNITS_R)
        self.r_min = None if r_min is None else positive("r_min", r_min, UNITS_R)
        self.r_max = None if r_max is None else positive("r_max", r_max, UNITS_R)

    def compute(self, packings: Packing | Iterable[Packing]) -> BondCorrelationResult:
        """The correlation functions of ``packings`` (one or an ensemble, pooled) and the length
        fitted to the maxima of C(r) beyond r_min.

        Raises
        ------
        ValueError
            No packings, mixed dimensions, ``r_max`` beyond half the box, or no first minimum of g(r).
        """
        items = as_packings(packings)
        edges = radial_edges(check_r_max(self.r_max, items), self.dr)
        r_min = self.r_min
        if r_min is None:
            r_min = first_minimum(RDF(dr=0.02, r_max=min(3.0, max_reduced_radius(items))).compute(items))
        nb = len(edges) - 1
        sums = {name: np.zeros(nb) for name in ("c", "c2", "m", "n")}
        base_num = base_den = 0.0
        for packing in items:
            scale = rms_contact_distance(packing.diameters)
            q, n = particle_bond_order(packing, r_min * scale, self.l)
            has = n > 0
            mag = np.linalg.norm(q, axis=1)
            for i, j, _, r in pair_chunks(packing, edges[-1] * scale):
                ok = has[i] & has[j]
                i, j, x = i[ok], j[ok], r[ok] / scale
                prod = np.einsum("pm,pm->p", q[i], q[j].conj()).real
                for name, w in (("c", prod), ("c2", prod**2), ("m", mag[i] * mag[j]), ("n", None)):
                    sums[name] += np.histogram(x, edges, weights=w)[0]
            total = q[has].sum(axis=0)
            base_num += float(np.vdot(total, total).real - np.sum(mag[has] ** 2))
            base_den += float(has.sum() * (has.sum() - 1))
        count = sums["n"]
        with np.errstate(invalid="ignore", divide="ignore"):
            cplx, magn = sums["c"] / count, sums["m"] / count
            err = np.sqrt(np.maximum(sums["c2"] / count - cplx**2, 0.0) / count)
        baseline = base_num / base_den if base_den > 0 else math.nan
        r = 0.5 * (edges[1:] + edges[:-1])
        fit = envelope_fit(r, np.abs(cplx - baseline), np.nan_to_num(err, nan=np.inf), r_min)
        return BondCorrelationResult(edges, cplx, magn, err, count.astype(int), baseline, float(r_min),
                                     int(self.l), len(items), fit)
