"""The two homogeneous strains of the elastic moduli (chapter section 4.5), written once for both the
strain sweeps and the Hessian route.

A strain of amplitude a maps the cell and every particle centre affinely, x -> F(a) x
(orientations unchanged), and the modulus is the slope of a stress response R at a = 0, with the
particles relaxed at every a:

- ``SHEAR``: simple shear x -> x + gamma y (chapter eq. 2.4, the shear-periodic cell: the xy tilt
  grows by gamma L_y), F = I + gamma e_x e_y^T; R = Sigma = -P_xy; G = dSigma/dgamma.
- ``BULK``: isotropic compression by a = ln(phi / phi_0), F = exp(-a / d) I; R = P = tr(P) / d;
  B = dP/da = phi dP/dphi.

P_ab is the virial pressure tensor of chapter eq. 2.34 (``engine.base.State``, positive under
compression). The Hessian route needs, per strain, the velocity L = dF/da at a = 0 (a pair's
separation changes by L r_ij) and how the relaxed energy curvature d^2U/da^2 becomes the modulus:
G = U''/V (Sigma = U'/V at every gamma, V fixed); B = (U''_L - V tr(P F''))/V + P (P = U'/V, V =
V_0 e^-a) with U''_L the curvature along the straight path F = I + a L (the part quadratic in
L r_ij) and F'' = I / d^2, which gives B = U''_L / V + P (d - 1) / d.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from jamflow.model.box import Box


@dataclass(frozen=True)
class Strain:
    """One homogeneous strain: ``kind`` "shear" or "bulk", the modulus it measures (``modulus``
    "G" or "B") and the name of its response (``response_name``)."""

    kind: str  #: "shear" (simple shear, x += a y) or "bulk" (isotropic compression, phi = phi0 e^a)
    modulus: str  #: "G" or "B"
    response_name: str  #: "Sigma" (= -P_xy) or "P"
    strain_name: str  #: "gamma" or "ln(phi/phi0)"

    def gradient(self, amplitude: float, dim: int) -> np.ndarray:
        """F(a), (d, d)."""
        a = float(amplitude)
        if self.kind == "shear":
            f = np.eye(dim)
            f[0, 1] = a
            return f
        return math.exp(-a / dim) * np.eye(dim)

    def velocity(self, dim: int) -> np.ndarray:
        """L = dF/da at a = 0, (d, d)."""
        if self.kind == "shear":
            out = np.zeros((dim, dim))
            out[0, 1] = 1.0
            return out
        return -np.eye(dim) / dim

    def cell(self, box: Box, amplitude: float) -> Box:
        """The strained cell F(a) h; the shear adds a L_y to the xy tilt (accumulated strain)."""
        if self.kind == "shear":
            h = box.h.copy()
            h[0, :] += amplitude * box.h[1, :]
            return box.with_h(h)
        return box.scaled(math.exp(-float(amplitude) / box.dim))

    def response(self, pressure_tensor) -> float:
        """Sigma = -P_xy (shear) or P = tr(P) / d (bulk), eps / diameter^d."""
        p = np.asarray(pressure_tensor, float)
        if self.kind == "shear":
            return float(-p[0, 1])
        return float(np.trace(p) / len(p))

    def modulus_from_curvature(self, curvature: float, volume: float, pressure_tensor) -> float:
        """The modulus from the relaxed energy curvature along the straight path I + a L
        (``velocity``): G = U''/V; B = U''/V + P (d - 1)/d (module docstring)."""
        if self.kind == "shear":
            return curvature / volume
        p = np.asarray(pressure_tensor, float)
        d = len(p)
        return curvature / volume + float(np.trace(p) / d) * (d - 1) / d


SHEAR = Strain("shear", "G", "Sigma", "gamma")
BULK = Strain("bulk", "B", "P", "ln(phi/phi0)")
STRAINS = (SHEAR, BULK)
