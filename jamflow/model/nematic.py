"""Nematic order P2 of the particles' directors (chapter section 4.3)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jamflow.model.frames import canonical_signs
from jamflow.model.packing import Packing


# --- nematic order ---------------------------------------------------------------------------
@dataclass(frozen=True)
class NematicResult:
    """P2 = largest eigenvalue of the order tensor; ``director`` its unit eigenvector, signed by
    ``jamflow.model.frames.canonical_signs`` (n and -n are the same director)."""

    p2: float  #: P2, dimensionless: 0 for isotropic axes, 1 for aligned ones
    director: np.ndarray  #: (d,) unit eigenvector of P2, the mean axis
    tensor: np.ndarray  #: (d, d) the order tensor (d u u^T - 1) / (d - 1), averaged over particles

    def __repr__(self) -> str:
        """One line: P2 and the director."""
        return f"NematicResult(p2={self.p2:.4f}, director={np.round(self.director, 4).tolist()})"


class Nematic:
    """Nematic order P2 (chapter section 4.3) of particle axes in 2D or 3D.

    ``compute(orientations)``: unit (or any non-zero) axis vectors (N, d), in 2D angles (N,)
    in radians, or a ``Packing`` of particles that turn (their directors, the long axes of
    prolate particles). Head and tail are equivalent (n and -n give the same P2).
    """

    def compute(self, orientations) -> NematicResult:
        """P2 and the director of ``orientations``.

        Parameters
        ----------
        orientations : array_like or jamflow.Packing
            (N, d) axis vectors (normalised here; non-zero), (N,) 2D angles in radians, or a
            packing of particles with an axis (its directors).

        Returns
        -------
        NematicResult
            P2 (the largest eigenvalue of the order tensor), the director and the tensor.

        Raises
        ------
        ValueError
            A packing of particles without an axis (disks, spheres), or axes that are empty,
            of the wrong shape, not finite or zero.
        """
        if isinstance(orientations, Packing):
            if not orientations.shape.oriented:
                raise ValueError(f"nematic order needs particles with an axis; "
                                 f"{orientations.shape.name(orientations.dim)}s have none")
            orientations = orientations.directors
        u = _unit_axes(orientations)
        dim = u.shape[1]
        tensor = (dim * np.einsum("na,nb->ab", u, u) / len(u) - np.eye(dim)) / (dim - 1)
        values, vectors = np.linalg.eigh(tensor)
        return NematicResult(float(values[-1]), canonical_signs(vectors[:, -1]), tensor)


def _unit_axes(orientations) -> np.ndarray:
    a = np.asarray(orientations, float)
    if a.ndim == 1:
        a = np.column_stack([np.cos(a), np.sin(a)])
    if a.ndim != 2 or a.shape[1] not in (2, 3) or len(a) == 0:
        raise ValueError(f"orientations must be axis vectors of shape (N, 2) or (N, 3), or 2D angles (N,); "
                         f"got shape {np.shape(orientations)}")
    if not np.all(np.isfinite(a)):
        raise ValueError("orientations must be finite")
    norm = np.linalg.norm(a, axis=1)
    if np.any(norm == 0):
        raise ValueError("orientation vectors must be non-zero (they give each particle's long axis)")
    return a / norm[:, None]
