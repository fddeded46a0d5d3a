"""Order parameters (chapter section 4.3): nematic P2, bond-orientational Q6, translational G.

Bond-orientational order (eqs. 2.30-2.33), neighbours j of i are the particles with
r_ij < r_min, r_min the first minimum of g(r) (found by ``first_minimum``), in units of
<sigma^2>^(1/2) like g(r). Per particle we form a complex vector Q_i:

- 2D: Q_i = psi_l(i) = n_i^-1 sum_j exp(i l theta_ij) -- the hexatic (psi_6) quantity;
  the chapter's 2D Q6 is exactly this hexatic order (freud.order.Hexatic).
- 3D: Q_i = sqrt(4 pi / (2l+1)) q_lm(i), q_lm(i) = n_i^-1 sum_j Y_l^m(theta_ij, phi_ij),
  m = -l..l (freud.order.Steinhardt's particle_harmonics up to that factor).

Then Q6^g = |<Q_i>| in both dimensions (eqs. 2.30, 2.32); Q6^l = <|Q_i|> in 2D (eq. 2.31)
but (<|Q_i|^2>)^(1/2) in 3D (eq. 2.33): the chapter averages inside the square root in 3D.
Particles without neighbours (n_i = 0) have no defined Q_i: they are left out of every
average and counted in ``n_isolated`` (freud returns NaN for them in Steinhardt).
Only even l is supported: then Y_l^m(-r) = Y_l^m(r), so bond directions do not matter.
Everything is float64 (freud, float32, is the second implementation in the tests).

Nematic P2 (section 4.3): P2 = <(d cos^2 theta - 1)/(d - 1)> maximised over the director,
i.e. the largest eigenvalue of Q = <(d n n - I)/(d - 1)>, director = its eigenvector. The
chapter prints the 2D form as <2 cos^2 theta - 1/2>, which would give 3/2 for perfect
alignment; jamflow uses <2 cos^2 theta - 1> = <cos 2 theta>, which is 1 for aligned rods.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter1d
from scipy.special import sph_harm_y

from jamflow.model.packing import Packing
from jamflow.model.nematic import Nematic, NematicResult  # noqa: F401 -- re-exported: P2 is measured here too (section 4.3)
from jamflow.analysis.structure import UNITS_R, RDF, RDFResult, max_reduced_radius, pair_chunks, positive, rms_contact_distance


# --- r_min: the first minimum of g(r) --------------------------------------------------------
def first_minimum(rdf: RDFResult, smooth: float = 0.05) -> float:
    """Position (units of <sigma^2>^(1/2)) of the first minimum of g(r) after the first peak.

    g is smoothed with a Gaussian of width ``smooth`` (same units) so that noise and the
    sub-peaks of mixtures do not count. The first shell starts where the smoothed g first
    reaches half its maximum (not at the global maximum: in a simple cubic crystal the
    sqrt 2 shell is as high as the first). The minimum is the lowest point of the first
    stretch after that where the smoothed g falls below 1, taken in the middle of that
    stretch's lowest plateau (a perfect crystal has g = 0 between shells). The dip must be
    deeper than 3 statistical errors; otherwise (e.g. a gas) a ValueError asks for an
    explicit r_min.
    """
    gs = gaussian_filter1d(rdf.g, max(smooth / rdf.dr, 1e-9), mode="nearest")
    peak = int(np.argmax(gs >= 0.5 * gs.max()))
    below = np.nonzero(gs[peak:] < 1.0)[0]
    if len(below) == 0:
        raise ValueError("g(r) never drops below 1 after its first peak: no first neighbour shell to "
                         "delimit (gas-like or too few pairs); pass r_min explicitly")
    start = peak + below[0]
    above = np.nonzero(gs[start:] >= 1.0)[0]
    stop = start + above[0] if len(above) else len(gs)
    segment = gs[start:stop]
    floor = np.nonzero(segment <= segment.min() + 1e-9 * max(1.0, gs[peak]))[0]
    where = start + int(round(0.5 * (floor[0] + floor[-1])))
    noise = _smoothed_error(rdf, smooth, where)
    if 1.0 - gs[where] < 3.0 * noise or gs[peak] - 1.0 < 3.0 * noise:
        raise ValueError(f"the first minimum of g(r) near r = {rdf.r[where]:.3f} is not significant (depth "
                         f"{1 - gs[where]:.3g} vs statistical error {noise:.3g}); average more packings, use a "
                         "coarser dr, or pass r_min explicitly")
    return float(rdf.r[where])


def _smoothed_error(rdf: RDFResult, smooth: float, k: int) -> float:
    """Poisson error of g at bin k after averaging over ~smooth / dr bins."""
    window = max(1.0, smooth / rdf.dr * math.sqrt(2 * math.pi))
    return float(rdf.stderr[k] / math.sqrt(window))


def neighbour_rdf(packing: Packing, dr: float = 0.02, r_max: float = 3.0) -> RDFResult:
    """g(r) up to min(r_max, half the box width): enough to locate r_min cheaply."""
    return RDF(dr=dr, r_max=min(r_max, max_reduced_radius([packing]))).compute(packing)


# --- translational order G ---------------------------------------------------------------------
@dataclass(frozen=True)
class TranslationalOrderResult:
    """G = g(r_min) / g(r_max) (chapter section 4.3); r in units of <sigma^2>^(1/2)."""

    G: float  #: g(r_min) / g(r_max), dimensionless: 0 for a perfect crystal
    r_min: float  #: the first minimum of g(r)
    r_max: float  #: the first peak of g(r), below r_min
    g_min: float  #: smoothed g at r_min (a broad feature: smoothing removes noise, not signal)
    g_max: float  #: raw height of the first peak (near-singular: smoothing would bias it)


def translational_order(rdf: RDFResult, r_min: float | None = None, smooth: float = 0.05) -> TranslationalOrderResult:
    """G from a computed g(r); zero for a perfect crystal, finite for jammed packings."""
    r_min = first_minimum(rdf, smooth) if r_min is None else float(r_min)
    gs = gaussian_filter1d(rdf.g, max(smooth / rdf.dr, 1e-9), mode="nearest")
    k_min = int(np.clip(np.searchsorted(rdf.edges, r_min) - 1, 0, len(rdf.g) - 1))
    r_peak, g_peak = rdf.first_peak(r_min)
    g_min = float(gs[k_min])
    return TranslationalOrderResult(g_min / g_peak, r_min, r_peak, g_min, g_peak)


class TranslationalOrder:
    """``TranslationalOrder(dr).compute(packing)``: G from that packing's own g(r).

    Parameters
    ----------
    dr : float, default 0.02
        Bin width of g(r), units of <sigma^2>^(1/2) (> 0).
    r_min : float, optional
        The first minimum of g(r) in the same units; None: found in g(r) (``first_minimum``).
    smooth : float, default 0.05
        Width of the Gaussian that smooths g(r) before its minimum is read, same units.

    Raises
    ------
    ValueError
        A ``dr``, ``r_min`` or ``smooth`` that is not a finite positive number.
    """

    def __init__(self, dr: float = 0.02, r_min: float | None = None, smooth: float = 0.05):
        self.dr, self.smooth = positive("dr", dr, UNITS_R), positive("smooth", smooth, UNITS_R)
        self.r_min = None if r_min is None else positive("r_min", r_min, UNITS_R)

    def compute(self, packing: Packing) -> TranslationalOrderResult:
        """G of ``packing`` from its g(r) up to r = 3 (or half the box width).

        Parameters
        ----------
        packing : jamflow.Packing
            Any packing of round particles (lengths in diameters).

        Returns
        -------
        TranslationalOrderResult
            G = g(r_min) / g(r_max), r in units of <sigma^2>^(1/2).

        Raises
        ------
        ValueError
            ``r_min`` None and no significant first minimum in g(r) (gas-like, or too few pairs).
        """
        return translational_order(neighbour_rdf(packing, self.dr), self.r_min, self.smooth)


# --- bond-orientational order ----------------------------------------------------------------
def particle_bond_order(packing: Packing, r_cut: float, l: int = 6) -> tuple[np.ndarray, np.ndarray]:
    """(Q, n): per-particle complex vectors Q (N, 1) in 2D or (N, 2l+1) in 3D (normalised so
    |Q_i| is psi_l(i) resp. q_l(i)), and neighbour counts n (N,). ``r_cut`` in diameters.
    Rows of particles with no neighbour are zero."""
    even_degree(l)
    positive("neighbour cutoff", r_cut, "diameters")
    width = 1 if packing.dim == 2 else 2 * l + 1
    total = np.zeros((packing.n, width), complex)
    count = np.zeros(packing.n)
    for i, j, dr, _ in pair_chunks(packing, r_cut):
        h = _bond_harmonics(dr, l)
        for side in (i, j):
            np.add.at(total, side, h)
            np.add.at(count, side, 1.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        q = np.where(count[:, None] > 0, total / count[:, None], 0.0)
    return q, count.astype(int)


def even_degree(l) -> int:
    """``l`` as an int if it is an even non-negative integer (bond directions are unsigned), else a ValueError."""
    if not (isinstance(l, (int, np.integer)) and not isinstance(l, bool) and l >= 0 and l % 2 == 0):
        raise ValueError(f"l must be an even non-negative integer (bond directions are unsigned), got {l!r}")
    return int(l)


def _bond_harmonics(dr: np.ndarray, l: int) -> np.ndarray:
    """exp(i l theta) (2D, shape (B, 1)) or sqrt(4 pi/(2l+1)) Y_l^m (3D, (B, 2l+1), m = -l..l)."""
    if dr.shape[1] == 2:
        return np.exp(1j * l * np.arctan2(dr[:, 1], dr[:, 0]))[:, None]
    r = np.linalg.norm(dr, axis=1)
    polar = np.arccos(np.clip(dr[:, 2] / r, -1.0, 1.0))
    azimuth = np.mod(np.arctan2(dr[:, 1], dr[:, 0]), 2 * math.pi)
    m = np.arange(-l, l + 1)
    return math.sqrt(4 * math.pi / (2 * l + 1)) * sph_harm_y(l, m[None, :], polar[:, None], azimuth[:, None])


@dataclass(frozen=True)
class BondOrderResult:
    """Q_l global and local (chapter eqs. 2.30-2.33) and the per-particle values behind them."""

    global_order: float  #: Q_l^g (chapter eqs. 2.30, 2.32; 2D: |<psi_l>|), dimensionless
    local_order: float  #: Q_l^l (chapter eqs. 2.31, 2.33; 2D: <|psi_l|>, 3D: rms of q_l(i))
    r_min: float  #: neighbour cutoff, units of <sigma^2>^(1/2)
    l: int  #: the degree (even; 6 by default)
    dim: int  #: 2 or 3
    particle_order: np.ndarray  #: (N, 1) or (N, 2l+1) complex Q_i (zero rows: isolated)
    n_neighbours: np.ndarray  #: (N,) neighbours within r_min of each particle

    def __repr__(self) -> str:
        """One line: l, dim, Q_l global and local, r_min, N, isolated particles."""
        return (f"BondOrderResult(l={self.l}, dim={self.dim}, global_order={self.global_order:.4f}, "
                f"local_order={self.local_order:.4f}, r_min={self.r_min:.4g}, N={len(self.n_neighbours)}, "
                f"n_isolated={int(np.sum(self.n_neighbours == 0))})")

    @property
    def n_isolated(self) -> int:
        """Particles with no neighbour within r_min (left out of the averages)."""
        return int(np.sum(self.n_neighbours == 0))

    @property
    def magnitudes(self) -> np.ndarray:
        """|psi_l(i)| (2D) or q_l(i) (3D); NaN for isolated particles."""
        mag = np.linalg.norm(self.particle_order, axis=1)
        return np.where(self.n_neighbours > 0, mag, np.nan)


def bond_order_parameters(q: np.ndarray, n: np.ndarray, dim: int) -> tuple[float, float]:
    """(global, local) from per-particle Q and neighbour counts, chapter eqs. 2.30-2.33."""
    have = n > 0
    if not np.any(have):
        raise ValueError("no particle has a neighbour within r_min; increase r_min")
    qh = q[have]
    global_order = float(np.linalg.norm(qh.mean(axis=0)))
    mags = np.linalg.norm(qh, axis=1)
    local_order = float(mags.mean()) if dim == 2 else float(np.sqrt(np.mean(mags**2)))
    return global_order, local_order


class BondOrder:
    """Q_l^g and Q_l^l (default l = 6) with neighbours r_ij < r_min.

    ``r_min`` in units of <sigma^2>^(1/2); None: the first minimum of this packing's g(r)
    (bin ``dr``). Pass the ensemble's r_min for a set of packings.

    Parameters
    ----------
    l : int, default 6
        The degree: even and >= 0.
    r_min : float, optional
        Neighbour cutoff in units of <sigma^2>^(1/2); None: the first minimum of g(r).
    dr : float, default 0.02
        Bin width of the g(r) that locates r_min, same units.

    Raises
    ------
    ValueError
        An odd or negative ``l``, or a ``dr`` or ``r_min`` that is not a finite positive number.
    """

    def __init__(self, l: int = 6, r_min: float | None = None, dr: float = 0.02):
        self.l, self.dr = even_degree(l), positive("dr", dr, UNITS_R)
        self.r_min = None if r_min is None else positive("r_min", r_min, UNITS_R)

    def compute(self, packing: Packing) -> BondOrderResult:
        """Q_l of ``packing``: 2D the hexatic psi_l, 3D Steinhardt's q_l.

        Parameters
        ----------
        packing : jamflow.Packing
            Any packing (lengths in diameters).

        Returns
        -------
        BondOrderResult
            Q_l global and local, with the per-particle values and neighbour counts.

        Raises
        ------
        ValueError
            No significant first minimum of g(r) (pass ``r_min``), or no particle has a neighbour.
        """
        r_min = self.r_min if self.r_min is not None else first_minimum(neighbour_rdf(packing, self.dr))
        q, n = particle_bond_order(packing, r_min * rms_contact_distance(packing.diameters), self.l)
        g, loc = bond_order_parameters(q, n, packing.dim)
        return BondOrderResult(g, loc, float(r_min), int(self.l), packing.dim, q, n)






