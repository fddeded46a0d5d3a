"""Eigenvectors fixed by the problem, not by the eigen-solver.

An eigen-solver (LAPACK through numpy or scipy, ARPACK) may return any sign of an eigenvector,
and any basis of the eigenspace of a repeated eigenvalue; two machines can differ. Where an
eigenvector decides a stored or printed result, jamflow fixes it by rules that use only the
problem's own data:

- ``canonical_signs``: every column's first entry (in index order) of at least half its largest
  magnitude is positive (a director, a normal mode).
- ``principal_frame``: the principal axes of a rigid body as a proper rotation, ascending
  eigenvalue, signs and the axes of tied eigenvalues fixed by the body's sites (its docstring).
"""

from __future__ import annotations

import numpy as np

TIE_TOL = 1e-8  # eigenvalues this close (relative to the largest |eigenvalue|) count as tied
SITE_TOL = 1e-9  # a site nearer than this x the largest site distance to a plane lies on it


def canonical_signs(vectors: np.ndarray) -> np.ndarray:
    """``vectors`` (n,) or (n, m) with every column's sign fixed: its first entry of at least
    half the column's largest magnitude is positive (columns of zeros are left alone). Exact
    under a change of sign: v and -v give the same bits."""
    v = np.array(vectors, dtype=float)
    if v.size == 0:
        return v
    cols = v.reshape(len(v), -1)
    size = np.abs(cols)
    first = np.argmax(size >= 0.5 * size.max(axis=0), axis=0)
    flip = cols[first, np.arange(cols.shape[1])] < 0
    cols[:, flip] *= -1.0
    return cols.reshape(v.shape)


def principal_frame(tensor: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """(d, d) proper rotation (det +1) whose columns are the principal axes of the symmetric
    ``tensor`` in ascending eigenvalue order; ``offsets`` (S, d) are the body's sites relative
    to its centre of mass, in their order. The frame depends on the tensor and the sites only:

    - each of the first d - 1 axes has the first site off the plane through the centre
      perpendicular to it (distance > ``SITE_TOL`` x the largest site distance) on its
      negative side (sites listed along an axis keep that direction); if no site is off that
      plane, ``canonical_signs`` decides;
    - the last axis completes a right-handed frame (2D: the first turned by +90 degrees;
      3D: the cross product of the first two);
    - axes of tied eigenvalues (``TIE_TOL``) are not taken from the solver: in tie order, each
      is the part of the first site offset, else of the first coordinate axis, orthogonal to
      the untied axes and to the tied ones already chosen (Gram-Schmidt), signed as above.
    """
    tensor = np.asarray(tensor, float)
    offsets = np.asarray(offsets, float)
    d = len(tensor)
    values, vectors = np.linalg.eigh(tensor)
    scale = max(float(np.abs(values).max()), np.finfo(float).tiny)
    tied = np.abs(np.diff(values)) <= TIE_TOL * scale  # tied[k]: eigenvalues k and k + 1
    group = np.zeros(d, bool)
    group[:-1] |= tied
    group[1:] |= tied
    reach = float(np.linalg.norm(offsets, axis=1).max())
    near = SITE_TOL * reach
    untied = [vectors[:, k] for k in range(d) if not group[k]]
    chosen, axes = [], []
    for k in range(d - 1):
        axis = _orthogonal_part(offsets, near, untied + chosen) if group[k] else vectors[:, k]
        axes.append(_signed(axis, offsets, near))
        if group[k]:
            chosen.append(axes[-1])
    last = np.array([-axes[0][1], axes[0][0]]) if d == 2 else np.cross(axes[0], axes[1])
    return np.column_stack(axes + [last])


def _signed(axis: np.ndarray, offsets: np.ndarray, near: float) -> np.ndarray:
    """``axis`` with the first site off its plane on the negative side (else ``canonical_signs``)."""
    along = offsets @ axis
    off = np.flatnonzero(np.abs(along) > near)
    if len(off) == 0:
        return canonical_signs(axis)
    return -axis if along[off[0]] > 0 else axis


def _orthogonal_part(offsets: np.ndarray, near: float, basis: list) -> np.ndarray:
    """The unit part of the first site offset longer than ``near`` orthogonal to the orthonormal
    ``basis``, else of the first coordinate axis whose part is longer than 0.3 (one is: some
    axis keeps at least 1/3 of its square norm in a subspace of dimension >= 1)."""
    for candidates, floor in ((offsets, near), (np.eye(offsets.shape[1]), 0.3)):
        for c in candidates:
            r = c.copy()
            for b in basis:
                r -= (r @ b) * b
            norm = float(np.linalg.norm(r))
            if norm > floor:
                return r / norm
    raise ValueError("no direction is left orthogonal to the given axes")
