"""The dynamical matrix of a packing with its floaters removed, and its result (chapter section 3, eq. 2.27)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from jamflow.mechanics.contacts import Contacts, ContactsResult, remove_floaters
from jamflow.mechanics.hessian import Coordinates, hessian
from jamflow.model.packing import Packing


@dataclass(frozen=True)
class DynamicalMatrixResult:
    """Dynamical matrix over the non-floaters (unit masses: equal to the Hessian)."""

    matrix: sp.csr_matrix  #: (d_f N', d_f N'), eps / diameter^2
    particles: np.ndarray  #: (N',) indices of the rows' particles in the original packing
    packing: Packing  #: the packing the matrix belongs to (floaters removed)
    contacts: ContactsResult | None  #: None when floaters were kept
    n_total: int  #: N, particles in the original packing

    def __repr__(self) -> str:
        """One line: matrix shape and stored entries, N' of N, dim, shape."""
        p = self.packing
        return (f"DynamicalMatrixResult(shape={self.matrix.shape}, nnz={self.matrix.nnz}, kept={p.n}, "
                f"N={self.n_total}, dim={p.dim}, particle_shape={p.shape.spec(p.dim)!r})")

    @property
    def dim(self) -> int:
        """d."""
        return self.packing.dim

    @property
    def n_dof(self) -> int:
        """d_f N', the matrix dimension."""
        return self.matrix.shape[0]

    @property
    def coordinates(self) -> Coordinates:
        """The layout of the rows: centres, then rotations d_k theta."""
        return Coordinates.of(self.packing)

    @property
    def n_translational(self) -> int:
        """d N', rows of centre coordinates (the rest are rotations d_k theta)."""
        return self.packing.n * self.dim

    def translations(self) -> np.ndarray:
        """(d_f N', d) orthonormal uniform translations: the trivial zero modes."""
        return self.coordinates.translations()

    def translational_fraction(self, vectors: np.ndarray) -> np.ndarray:
        """Share of |e|^2 in the centre coordinates of each column of ``vectors`` (1: purely
        translational, 0: purely rotational)."""
        v = np.asarray(vectors, float).reshape(self.n_dof, -1)
        return np.sum(v[:self.n_translational] ** 2, axis=0) / np.sum(v**2, axis=0)


class DynamicalMatrix:
    """Sparse dynamical matrix; ``remove_floaters`` drops floaters first (default).
    ``contacts`` configures the floater search (a ``Contacts`` instance; default counts every
    overlapping site pair of rigid bodies as a contact, the constraints the matrix holds)."""

    def __init__(self, remove_floaters: bool = True, contacts: Contacts | None = None):
        self.remove_floaters = bool(remove_floaters)
        self.contacts = contacts or Contacts(count="sites")

    def compute(self, packing: Packing) -> DynamicalMatrixResult:
        """The matrix of ``packing`` (floaters removed first unless ``remove_floaters`` is False).

        Raises
        ------
        ValueError
            Walls, gravity or fixed particles, or every particle a floater.
        """
        if not self.remove_floaters:
            return DynamicalMatrixResult(hessian(packing), np.arange(packing.n), packing, None, packing.n)
        found = self.contacts.compute(packing)
        kept = remove_floaters(packing, found)
        return DynamicalMatrixResult(hessian(kept), found.kept, kept, found, packing.n)
