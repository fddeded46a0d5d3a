"""Sparse Cholesky solves of the minimisers' symmetric positive definite matrices.

CHOLMOD (Chen, Davis, Hager & Rajamanickam, ACM TOMS 35, 22 (2008)) through the ``cholespy``
wheel, a jamflow dependency; SciPy's SuperLU (minimum-degree ordering, no pivoting) where it
cannot be imported, with one warning per process. The Newton minimiser factorises with it
always, the Gauss-Newton polish from ``CHOLMOD_FROM_DOF`` coordinates on: SuperLU's
minimum-degree ordering of J^T J took 0.58-0.70 CPU s for a 2D N = 16384 packing whose particles
are numbered along the Morton curve (``jamflow.model.ordering``) against 0.21-0.34 s for the same
packing in random order, CHOLMOD 0.16 s (docs/notes/newton-krylov.md).
"""

from __future__ import annotations

import warnings
from functools import lru_cache

import numpy as np

CHOLMOD_FROM_DOF = 16384  # the polish factorises with CHOLMOD from this many coordinates (N d) on


def factorise(matrix):
    """solve(b) of the symmetric positive definite sparse ``matrix``: CHOLMOD, or SuperLU where
    ``cholespy`` cannot be imported."""
    cholmod = _cholmod()
    if cholmod is None:
        return superlu(matrix).solve
    solver_class, matrix_type = cholmod
    m = matrix.tocsr()
    solver = solver_class(m.shape[0], m.indptr.astype(np.int32), m.indices.astype(np.int32),
                          np.ascontiguousarray(m.data), matrix_type.CSR)

    def solve(b):
        out = np.empty_like(b)
        solver.solve(np.ascontiguousarray(b), out)
        return out

    return solve


def superlu(matrix):
    """SciPy's SuperLU of the symmetric positive definite ``matrix`` (minimum degree on A^T + A,
    diagonal pivots): an object with ``solve(b)``."""
    import scipy.sparse.linalg as spla

    return spla.splu(matrix.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                     options=dict(SymmetricMode=True))


@lru_cache(maxsize=1)
def _cholmod():
    """(CholeskySolverD, MatrixType) of ``cholespy``, or None with one warning."""
    try:
        from cholespy import CholeskySolverD, MatrixType
    except ImportError as err:
        warnings.warn(f"cholespy cannot be imported ({err}): the Newton minimiser and the polish of large packings "
                      "factorise with SciPy's SuperLU instead (slower); reinstall jamflow to get it", stacklevel=4)
        return None
    return CholeskySolverD, MatrixType
