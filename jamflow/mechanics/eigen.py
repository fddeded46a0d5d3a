"""The lowest eigenpairs of a symmetric sparse matrix (a dynamical matrix or Hessian), one routine
for the spectra of ``analysis.modes`` and the soft-mode steps of ``minimize.soft_modes``.

Shift-invert about -``shift`` (ARPACK, ``which="LM"``) finds the k eigenvalues nearest -shift,
which are the lowest when the matrix has none far below -shift (at or near an energy minimum it
is positive semi-definite). Small matrices are diagonalised densely instead.

ARPACK starts from a fixed vector (uniform on [-1, 1], generator seed ``START_SEED``): scipy's
default draws a fresh random one in every call, so spectra, and the soft-mode steps of ellipse
and spheroid jams, differed between two runs of the same command.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse.linalg as spla

from jamflow.model.frames import canonical_signs

START_SEED = 0  # ARPACK's start vector: the same in every call, so a run repeats bit for bit


def lowest_eigenpairs(matrix, k: int, shift: float, *, grow_above: float | None = None, ascending: bool = True,
                      dense_limit: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(values, vectors as columns) of the k lowest eigenpairs of the symmetric sparse ``matrix``.

    ``shift``: shift-invert about -shift. ``grow_above``: double k (at most n - 2) until the
    largest value found exceeds it (``analysis.modes``: every zero mode bracketed). ``ascending``:
    sort by value (otherwise ARPACK's order). ``dense_limit``: matrices of at most this many
    rows, or with k >= n - 1, are diagonalised densely (numpy ``eigh``: all n pairs, ascending).
    Each vector's sign is ``jamflow.model.frames.canonical_signs``'s, not the solver's.
    """
    n = matrix.shape[0]
    if n <= dense_limit or k >= n - 1:
        values, vectors = np.linalg.eigh(matrix.toarray())
        return values, canonical_signs(vectors)
    while True:
        k = min(k, n - 2)
        values, vectors = spla.eigsh(matrix.tocsc(), k=k, sigma=-shift, which="LM", v0=start_vector(n))
        if ascending:
            order = np.argsort(values)
            values, vectors = values[order], vectors[:, order]
        if grow_above is None or values[-1] > grow_above or k >= n - 2:
            return values, canonical_signs(vectors)
        k *= 2


def start_vector(n: int) -> np.ndarray:
    """ARPACK's start vector for an n x n matrix: the same for every call (``START_SEED``)."""
    return np.random.default_rng(START_SEED).uniform(-1.0, 1.0, n)
