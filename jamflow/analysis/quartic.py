"""What holds a zero mode: its energy at fourth order in the just-touching limit.

Along a zero mode e of a packing at onset no contact changes at first order (C e = 0, C the
compatibility matrix ds_c / dxi), so the contacts change at second order, ds_c = delta^2 b_c with
b_c = e^T (d2s_c) e / 2, and in the just-touching limit (V' -> 0) the energy is
sum_c V''(s_c)/2 min(0, ds_c)^2 ~ delta^4 (a contact that opens costs nothing): the quartic
modes of hypostatic ellipse packings (chapter Figure 2.17; Mailman et al., Phys. Rev. Lett. 102,
255501 (2009)). That straight line can overstate it: a motion along a curved path
xi = xi_0 + delta e + delta^2 eta changes the contacts by delta^2 (C eta + b), and where some eta
makes every contact open or stay (C eta + b >= 0), the mode is free to fourth order -- e.g. a
dimer whose contacts all sit on one site turns freely about that site, while the straight line
through its rotation moves the site and rises as delta^4. The correction eta is a second-order
one: it is kept orthogonal to the zero modes (``null``), whose own first-order rates are of the
order of the pressure and would otherwise be scaled up without bound. The second-order jamming
test of Donev et al., Phys. Rev. E 75, 051304 (2007), in energy form: with the contact forces
lambda (lambda^T C = 0), lambda^T (C eta + b) = lambda^T b < 0 along a mode the stress stiffens,
so no eta opens every contact and the relaxed coefficient stays finite.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.optimize import lsq_linear
from scipy.sparse.linalg import LinearOperator

from jamflow.model.packing import Packing
from jamflow.mechanics.hessian import Coordinates, _local_index, law_derivatives, reduced_distances

RELAXED_TOL = 1e-6  # relaxed / straight coefficient below which a zero mode is free to fourth order
DENSE_MAX = 1500  # unknowns (coordinates + contacts) up to which the exact dense active-set solver runs


def quartic_coefficients(packing: Packing, mode: np.ndarray, null: np.ndarray | None = None) -> tuple[float, float]:
    """(straight, relaxed) fourth-order energy coefficients of ``mode`` (eps / diameter^4 per
    unit mode): sum_c V''/2 min(0, b_c)^2 along the straight line, and its minimum over
    second-order path corrections eta orthogonal to the columns of ``null`` (orthonormal, the
    zero modes), min_eta sum_c V''/2 min(0, (C eta + b)_c)^2 (a bounded linear least-squares
    problem: scipy's exact active-set ``bvls`` up to DENSE_MAX unknowns, its sparse ``trf``
    above, which reaches free modes to relaxed / straight ~1e-10 instead of ~1e-28)."""
    red = reduced_distances(packing)
    if not len(red.s):
        return 0.0, 0.0
    coords = Coordinates.of(packing)
    index = _local_index(coords, red.i, red.j)
    local = np.asarray(mode, float)[index]
    b = 0.5 * np.einsum("pa,pab,pb->p", local, red.d2s, local)
    stiffness = np.maximum(law_derivatives(packing.potential, red.s)[1], 0.0)
    straight = float(0.5 * np.sum(stiffness * np.minimum(b, 0.0) ** 2))
    if straight == 0.0:
        return 0.0, 0.0
    root = np.sqrt(stiffness)
    p, n = len(b), coords.size
    rows = np.broadcast_to(np.arange(p)[:, None], index.shape)
    compat = sp.csr_matrix(((root[:, None] * red.ds).ravel(), (rows.ravel(), index.ravel())), shape=(p, n))
    null = np.zeros((n, 0)) if null is None else np.asarray(null, float)
    bounds = (np.concatenate([np.full(n, -np.inf), np.zeros(p)]), np.full(n + p, np.inf))
    if n + p <= DENSE_MAX:  # exact active-set solution
        projected = compat.toarray()
        projected -= (projected @ null) @ null.T  # eta orthogonal to the zero modes
        a = np.hstack([projected, -np.diag(root)])
        x = lsq_linear(a, -root * b, bounds=bounds, method="bvls", tol=1e-14).x
        residual = a @ x + root * b
    else:  # sparse trust-region reflective with the projection as an operator
        cz = compat @ null
        a = LinearOperator((p, n + p), matvec=lambda x: compat @ x[:n] - cz @ (null.T @ x[:n]) - root * x[n:],
                           rmatvec=lambda y: np.concatenate([compat.T @ y - null @ (cz.T @ y), -root * y]))
        x = lsq_linear(a, -root * b, bounds=bounds, method="trf", lsmr_tol="auto", tol=1e-12, max_iter=2000).x
        residual = a.matvec(x) + root * b
    relaxed = float(0.5 * np.sum(residual**2))
    return straight, min(relaxed, straight)
