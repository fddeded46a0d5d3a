"""External terms that FIRE evaluates beside the pair kernel, and the box as coordinates.

``external`` adds the smooth walls (the potential's own law at s = h / (a_i / 2), h the
distance of particle i from a wall face; ``jamflow.model.walls`` has the numpy form and the
conventions) and gravity (V = g x_(d-1) per mobile particle), and zeroes the forces on fixed
particles (rough-wall particles: a mask, so FIRE never moves them).

Constant stress (the box as a degree of freedom, the way ASE's ``UnitCellFilter`` turns the
cell into extra coordinates): the box coordinates q_k = L e_k are the amplitudes of strain
modes B_k (iso: the identity; aniso: each diagonal entry; tri: every upper-triangular entry),
L the box side at the start of the minimisation, so a unit of q moves the far face by about
a length, like a particle coordinate. A step dq deforms box, positions and the pair list's
image offsets affinely, x -> (1 + de) x with de = sum_k dq_k B_k / L (upper-triangular, so the
box stays upper-triangular). The generalized force is -dH/dq for the enthalpy H = U + P V:
g_k = sum_ab B_k,ab (W_ba - P V delta_ab) / L, W_ab = sum r_a f_b the virial of pairs and
walls (-dU/de_ab = W_ba for an affine deformation), so g = 0 exactly when the virial
pressure tensor equals P delta_ab on the relaxed components. Units: eps, diameter.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from jamflow.model.box import STRESS_MODES
from jamflow.engines.compiled import jit
from jamflow.engines.compiled.laws import energy_force


class Field(NamedTuple):
    """What acts on the particles besides their pairs, and the box coordinates."""

    h: np.ndarray  # (d, d) the current box; box steps deform it in place
    walled: np.ndarray  # (d,) 1.0 on walled axes (walls at x_a = 0 and x_a = h_aa)
    law: tuple  # the potential's Params (the walls' law)
    half: np.ndarray  # (N,) a_i / 2, the contact distance of particle i with a wall
    mobile: np.ndarray  # (N,) 1.0 mobile, 0.0 fixed
    any_fixed: bool
    gravity: float  # g along -e_(d-1), per particle (unit mass)
    basis: np.ndarray  # (k, d, d) strain modes B_k; k = 0: fixed box
    pressure: float  # target pressure P (eps / diameter^d)
    length: float  # L: box coordinate q = L e


def strain_basis(mode: str, dim: int) -> np.ndarray:
    """(k, d, d) strain modes: iso (1), aniso (d), tri (d (d + 1) / 2, with shear)."""
    if mode not in STRESS_MODES:
        raise ValueError(f"unknown stress mode {mode!r}; use one of {', '.join(STRESS_MODES)}")
    if mode == "iso":
        return np.eye(dim)[None].copy()
    pairs = [(a, a) for a in range(dim)] + ([(a, b) for a in range(dim) for b in range(a + 1, dim)]
                                           if mode == "tri" else [])
    basis = np.zeros((len(pairs), dim, dim))
    for k, (a, b) in enumerate(pairs):
        basis[k, a, b] = 1.0
    return basis


def make_field(packing, pressure: float = 0.0, mode: str | None = None) -> Field:
    """The field of ``packing`` (walls of its box, its fixed particles and gravity); with
    ``mode``, the box coordinates of that stress mode at target ``pressure``."""
    d = packing.dim
    basis = np.zeros((0, d, d)) if mode is None else strain_basis(mode, d)
    return Field(np.array(packing.box.h, dtype=float), np.array([0.0 if p else 1.0 for p in packing.box.periodic]),
                 packing.potential.params, 0.5 * np.asarray(packing.diameters, float),
                 packing.mobile.astype(float), packing.fixed is not None, float(packing.gravity), basis,
                 float(pressure), float(packing.box.volume ** (1.0 / d)))


@jit
def external(fld, x, f, virial):
    """Add walls and gravity to f and the virial, zero the forces on fixed particles;
    return their energy."""
    n, d = x.shape
    energy = 0.0
    for a in range(d):
        if fld.walled[a] == 0.0:
            continue
        top = fld.h[a, a]
        for i in range(n):
            if fld.mobile[i] == 0.0:
                continue
            reach = fld.half[i]
            for side in range(2):
                h = x[i, a] if side == 0 else top - x[i, a]
                if h >= reach:
                    continue
                v, dv = energy_force(fld.law, h / reach)
                push = -dv / reach  # -dV/dh, away from the face
                energy += v
                f[i, a] += push if side == 0 else -push
                virial[a, a] += h * push
    if fld.gravity != 0.0:
        for i in range(n):
            if fld.mobile[i] != 0.0:
                energy += fld.gravity * x[i, d - 1]
                f[i, d - 1] -= fld.gravity
    if fld.any_fixed:
        for i in range(n):
            if fld.mobile[i] == 0.0:
                for a in range(d):
                    f[i, a] = 0.0
    return energy


@jit
def box_forces(fld, virial, gb):
    """gb[k] = -dH/dq_k = sum_ab B_k,ab (W_ba - P V delta_ab) / L."""
    d = virial.shape[0]
    volume = 1.0
    for a in range(d):
        volume *= fld.h[a, a]
    for k in range(fld.basis.shape[0]):
        acc = 0.0
        for a in range(d):
            for b in range(d):
                load = virial[b, a] - (fld.pressure * volume if a == b else 0.0)
                acc += fld.basis[k, a, b] * load
        gb[k] = acc / fld.length


@jit
def _apply(e, rows):
    """rows[i] <- (1 + e) rows[i] for every row (a point or offset in Cartesian coordinates)."""
    d = e.shape[0]
    tmp = np.zeros(d)
    for i in range(rows.shape[0]):
        for a in range(d):
            acc = rows[i, a]
            for b in range(d):
                acc += e[a, b] * rows[i, b]
            tmp[a] = acc
        for a in range(d):
            rows[i, a] = tmp[a]


@jit
def deform(fld, model, x, u, factor):
    """Step the box coordinates by factor * u: deform the box, the positions and the pair
    list's image offsets (``model.shift``) by de = factor sum_k u_k B_k / L."""
    d = x.shape[1]
    e = np.zeros((d, d))
    for k in range(u.shape[0]):
        for a in range(d):
            for b in range(d):
                e[a, b] += factor * u[k] * fld.basis[k, a, b] / fld.length
    _apply(e, x)
    _apply(e, model.shift)
    _apply(e, fld.h.T)  # columns of h are the cell vectors
