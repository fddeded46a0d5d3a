"""The force floor: the default force tolerance of a minimisation, and the force below which a
packing counts as balanced whatever its contact forces (``mechanics.checks``).

Round-off in positions of a box of side L limits forces to ~L * 1e-16 * d2V/dr2, so the floor is
``base * max(1, L / 20) * max(1, k)``, k the contact stiffness of the potential (repulsive LJ is
72x stiffer at contact than the linear spring) and ``base`` the shape's ``force_tol_base``
(1e-14; 5e-13 for ellipses/spheroids, whose quartic modes make every minimiser creep near onset,
docs/notes/ellipses.md). Forces in eps/diameter."""

from __future__ import annotations

from jamflow.model.shapes.shape import FORCE_TOL_BASE  # disks, spheres, rigid bodies (``Shape.force_tol_base``)


def force_floor(box, stiffness: float = 1.0, base: float = FORCE_TOL_BASE) -> float:
    """``base * max(1, L / 20) * max(1, stiffness)``, L the longest box side."""
    return base * max(1.0, float(box.lengths.max()) / 20.0) * max(1.0, stiffness)


def packing_force_floor(packing) -> float:
    """The force floor of a packing: its box, its potential's contact stiffness, its shape's base."""
    return force_floor(packing.box, packing.potential.contact_stiffness, packing.shape.force_tol_base)
