"""The free rotations of rigid bodies touched on one site, and what is left of the zero modes.

A rigid body whose contacts all touch one of its sites turns freely about that site's centre:
every contact force passes through it, so no contact distance changes (the "rotational
rattlers" of Shiraishi, Mizuno and Ikeda, PRE 100, 012606 (2019); docs/notes/nmers.md). Each such
body adds d_f - d zero modes to the dynamical matrix (``jamflow.mechanics.hessian``), one per
rotational coordinate: turn by theta about the body axis n_a through the site (lever
l = r_site - R), i.e. rotation coordinate d_k theta and centre displacement -theta n_a x l.

``zero_modes`` tells whether the zero modes of a spectrum are exactly the d trivial
translations plus these free rotations: the known vectors must lie in the zero-mode space
(``residual``), and no zero mode may be left over (``unexplained``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jamflow.model.packing import Packing
from jamflow.model.pairs import overlapping_sites
from jamflow.mechanics.hessian import Coordinates, world_axes
from jamflow.mechanics.dynamical_matrix import DynamicalMatrixResult


def pivot_sites(packing: Packing) -> dict[int, int]:
    """{body: site} for every body of ``packing`` whose overlapping site pairs with other
    bodies all involve one of its sites (site index within the body)."""
    bi, bj, s, t, *_ = overlapping_sites(packing)
    n_sites = packing.shape.n_sites
    owner, site = np.concatenate([bi, bj]), np.concatenate([s, t]) % n_sites
    touched: dict[int, set] = {}
    for body, k in zip(owner.tolist(), site.tolist()):
        touched.setdefault(body, set()).add(k)
    return {body: next(iter(sites)) for body, sites in sorted(touched.items()) if len(sites) == 1}


def free_rotation_vectors(packing: Packing, coords: Coordinates | None = None) -> np.ndarray:
    """(d_f N, k) generalized displacements (columns normalised) of the free rotations of the
    one-site bodies of ``packing`` (floaters already removed), in ``Coordinates`` layout."""
    coords = coords or Coordinates.of(packing)
    pivots = pivot_sites(packing) if packing.shape.made_of_sites and coords.n_rot else {}
    if not pivots:
        return np.zeros((coords.size, 0))
    world = packing.shape.world_sites(packing.positions, packing.orientations, packing.diameters)
    axes = world_axes(packing, coords.axes)  # (N, r, 3)
    columns = []
    for body, site in pivots.items():
        lever = np.zeros(3)
        lever[:packing.dim] = world[body, site] - packing.positions[body]
        for b in range(coords.n_rot):
            v = np.zeros(coords.size)
            v[body * coords.dim:(body + 1) * coords.dim] = -np.cross(axes[body, b], lever)[:coords.dim]
            v[coords.n_translational + body * coords.n_rot + b] = coords.lengths[body, b]
            columns.append(v / np.linalg.norm(v))
    return np.column_stack(columns)


@dataclass(frozen=True)
class ZeroModes:
    """The zero modes of a spectrum against the d translations and the free rotations."""

    n_zero: int  #: eigenvalues with |e| <= e_min
    n_trivial: int  #: d
    n_free: int  #: independent free rotations of one-site bodies
    residual: float  #: largest distance of a (unit) known zero vector from the zero-mode space
    unexplained: int  #: zero modes beyond the trivial ones and the free rotations

    @property
    def exactly_trivial(self) -> bool:
        """Once the free rotations are set aside, exactly the d trivial zero modes remain."""
        return self.unexplained == 0 and self.residual < 1e-6


def zero_modes(spectrum) -> ZeroModes:
    """Compare ``spectrum`` (a complete ``jamflow.analysis.modes.SpectrumResult`` with
    eigenvectors) with the translations and free rotations of its matrix's packing."""
    if spectrum.eigenvectors is None or not spectrum.complete:
        raise ValueError("zero_modes needs every eigenvector: use Spectrum(method='dense', vectors=True)")
    dyn: DynamicalMatrixResult = spectrum.dynamical
    coords = dyn.coordinates
    known = np.column_stack([dyn.translations(), free_rotation_vectors(dyn.packing, coords)])
    basis, singular, _ = np.linalg.svd(known, full_matrices=False)
    basis = basis[:, singular > 1e-8 * singular.max()]
    zero = spectrum.eigenvectors[:, np.abs(spectrum.eigenvalues) <= spectrum.e_min]
    residual = float(np.linalg.norm(basis - zero @ (zero.T @ basis), axis=0).max()) if basis.size else 0.0
    n_known = basis.shape[1]
    return ZeroModes(zero.shape[1], dyn.dim, n_known - dyn.dim, residual, zero.shape[1] - n_known)
